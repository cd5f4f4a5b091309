"""Diagram-level regression tests: every legged robot stands after a drop,
and CURI's base follows a commanded planar velocity."""

import numpy as np
import pytest
from pydrake.math import RollPitchYaw

from hotu_drake import embodiment
from hotu_drake.diagrams import build_standing_simulation
from hotu_drake.scenario import load_scenario

LEGGED = ("udh", "naviai", "h1", "bruce", "walker")


@pytest.mark.parametrize("name", LEGGED)
def test_legged_robot_stands_after_a_drop(name):
    scenario = load_scenario(f"stand_{name}")
    assert scenario.embodiment == name and scenario.initial.drop_height == pytest.approx(0.1)
    emb = embodiment.load(scenario.embodiment, scenario.hands)
    sim = build_standing_simulation(emb, scenario.plant_config, scenario.initial.drop_height)
    start = sim.pelvis_height()
    assert start == pytest.approx(emb.standing_pelvis_height + 0.1, abs=1e-6)
    sim.simulator.AdvanceTo(scenario.duration)

    nominal = emb.standing_pelvis_height
    assert sim.pelvis_height() == pytest.approx(nominal, rel=0.10)
    context = sim.plant.GetMyContextFromRoot(sim.simulator.get_context())
    pelvis = sim.plant.GetBodyByName(emb.key_bodies["pelvis"], sim.model)
    roll, pitch, _ = RollPitchYaw(sim.plant.EvalBodyPoseInWorld(context, pelvis).rotation()).vector()
    assert abs(roll) < 0.2 and abs(pitch) < 0.2
    # Settled, not still falling: the root barely moves.
    assert np.linalg.norm(sim.plant.GetVelocities(context)[3:6]) < 0.05


@pytest.mark.parametrize("name", ["udh", "naviai", "h1", "walker"])
def test_legged_robot_with_full_hands_stands_after_a_drop(name):
    sim = build_standing_simulation(embodiment.load(name, "full"), drop_height=0.1)
    sim.simulator.AdvanceTo(5.0)
    assert sim.pelvis_height() == pytest.approx(sim.embodiment.standing_pelvis_height, rel=0.10)
    q = sim.joint_positions()
    # The fingers hold their pose too: no finger joint drifts by more than 0.2 rad.
    drift = [abs(q[j] - target) for j, target in sim.embodiment.standing_pose_dict().items() if "_" in j]
    assert max(drift) < 0.2


def test_curi_holds_its_torso_and_arms():
    curi = embodiment.load("curi", "full")
    sim = build_standing_simulation(curi)
    sim.simulator.AdvanceTo(3.0)
    q = sim.joint_positions()
    assert max(abs(q[j] - target) for j, target in curi.standing_pose_dict().items()) < 0.06


def test_curi_base_follows_a_commanded_planar_velocity():
    curi = embodiment.load("curi", "none")
    sim = build_standing_simulation(curi, base_command=True)
    twist = np.array([0.3, 0.1, 0.2])  # vx, vy in the base frame (m/s), yaw rate (rad/s)
    sim.diagram.GetInputPort("twist").FixValue(sim.simulator.get_mutable_context(), twist)
    duration = 3.0
    sim.simulator.AdvanceTo(duration)

    # The exact pose of a constant body-frame twist (a circular arc).
    vx, vy, wz = twist
    yaw = wz * duration
    x = (vx * np.sin(yaw) + vy * (np.cos(yaw) - 1.0)) / wz
    y = (vx * (1.0 - np.cos(yaw)) + vy * np.sin(yaw)) / wz
    q = sim.joint_positions()
    assert q["base_x"] == pytest.approx(x, abs=0.03)
    assert q["base_y"] == pytest.approx(y, abs=0.03)
    assert q["base_yaw"] == pytest.approx(yaw, abs=0.02)
    context = sim.plant.GetMyContextFromRoot(sim.simulator.get_context())
    base = sim.plant.GetBodyByName("base", sim.model)
    velocity = sim.plant.EvalBodySpatialVelocityInWorld(context, base)
    c, s = np.cos(q["base_yaw"]), np.sin(q["base_yaw"])
    assert velocity.translational()[:2] == pytest.approx([c * vx - s * vy, s * vx + c * vy], abs=0.02)
    assert velocity.rotational()[2] == pytest.approx(wz, abs=0.01)


def test_planar_base_command_ports():
    from hotu_drake.systems import PlanarBaseCommand

    command = PlanarBaseCommand(np.zeros(5), (0, 1, 2))
    assert command.get_input_port(0).get_name() == "twist" and command.get_input_port(0).size() == 3
    assert command.get_output_port(0).get_name() == "desired_state" and command.get_output_port(0).size() == 10
    context = command.CreateDefaultContext()
    command.get_input_port(0).FixValue(context, [1.0, 0.0, 0.0])
    assert command.get_output_port(0).Eval(context)[5] == pytest.approx(1.0)
