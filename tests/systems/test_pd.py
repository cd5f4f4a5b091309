"""SaturatedPdController: the method's PD with torque saturation, against Drake's built-in PD."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.embodiment.actions import ActionScaling
from hotu_drake.systems.pd import AddActionToTargets, AddPdControl, SaturatedPdController
from tests.systems.conftest import make_scene
from tests.systems.ports import assert_inputs_wired, assert_port_contract


def _fixed_udh(time_step: float):
    """The UDH (built-in PD on) with its pelvis welded 1 m above the world origin."""
    udh = embodiment.load("udh", "none")
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=time_step), builder)
    model = udh.add_to_plant(plant)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("pelvis", model), RigidTransform([0, 0, 1.0]))
    plant.Finalize()
    return udh, builder, plant, model


def test_action_scaling_maps_limits_to_unit_range():
    h1 = embodiment.load("h1", "none")
    scaling = ActionScaling.for_embodiment(h1)
    assert scaling.to_targets(-np.ones(25)) == pytest.approx(h1.position_lower)
    assert scaling.to_targets(np.ones(25)) == pytest.approx(h1.position_upper)
    targets = h1.standing_pose
    assert scaling.to_targets(scaling.to_action(targets)) == pytest.approx(targets)
    assert np.all(scaling.to_targets(5 * np.ones(25)) <= h1.position_upper + 1e-12)  # actions are clipped
    curi = ActionScaling.for_embodiment(embodiment.load("curi", "none"))
    assert np.all(np.isfinite(curi.scale)) and np.all(np.isfinite(curi.offset))


def test_explicit_and_builtin_pd_give_the_same_torques():
    udh, builder, plant, model = _fixed_udh(1e-6)
    controller = builder.AddSystem(SaturatedPdController(plant, model, udh))
    builder.Connect(plant.get_state_output_port(model), controller.get_input_port(0))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    rng = np.random.default_rng(3)
    lower, upper = udh.position_lower, udh.position_upper
    q = lower + rng.uniform(0.3, 0.7, len(lower)) * (upper - lower)
    v = rng.normal(0.0, 0.5, len(lower))
    targets = lower + rng.uniform(0.0, 1.0, len(lower)) * (upper - lower)
    plant.SetPositions(plant_context, model, q)
    plant.SetVelocities(plant_context, model, v)
    plant.get_desired_state_input_port(model).FixValue(plant_context, np.concatenate([targets, np.zeros_like(v)]))
    controller.get_input_port(1).FixValue(controller.GetMyMutableContextFromRoot(context), targets)
    explicit = controller.get_output_port(0).Eval(controller.GetMyContextFromRoot(context)).copy()
    simulator.AdvanceTo(1e-6)  # one step: the built-in PD acts inside the discrete update
    builtin = plant.get_net_actuation_output_port(model).Eval(plant_context)
    saturated = np.abs(explicit) >= udh.effort_limits - 1e-9
    assert saturated.any() and (~saturated).any()  # both regimes are exercised
    # The implicit PD acts on the end-of-step velocity: light links speed up within the step.
    assert builtin == pytest.approx(explicit, rel=2e-2, abs=1e-2)
    assert np.all(np.abs(explicit) <= udh.effort_limits + 1e-9)


def test_reference_motion_source_plays_a_clip():
    from hotu_drake.systems.reference import ReferenceMotionSource
    from tests.clips import udh_test_clip

    clip = udh_test_clip("none", frames=11, fps=10.0)
    source = ReferenceMotionSource(clip, loop=True)
    context = source.CreateDefaultContext()
    context.SetTime(0.35)  # between frames 3 and 4
    q = source.GetOutputPort("joint_positions").Eval(context)
    assert q == pytest.approx(0.5 * (clip.joint_positions[3] + clip.joint_positions[4]))
    state = source.GetOutputPort("state").Eval(context)
    assert state.size == 13 + 2 * len(clip.joint_names)
    assert np.linalg.norm(state[:4]) == pytest.approx(1.0)
    context.SetTime(1.0 + 0.35)  # looped: the clip lasts 1 s
    assert source.GetOutputPort("joint_positions").Eval(context) == pytest.approx(q)
    held = ReferenceMotionSource(clip, loop=False)
    held_context = held.CreateDefaultContext()
    held_context.SetTime(5.0)
    assert held.GetOutputPort("joint_positions").Eval(held_context) == pytest.approx(clip.joint_positions[-1])


def test_explicit_pd_in_a_closed_loop_reaches_its_targets():
    """Fixed-base UDH, plant without built-in PD, SaturatedPdController on the actuation.

    An explicit PD needs a short step: at 0.5 ms every joint settles within
    0.05 rad of its target (1 ms still leaves the light wrists ringing).
    """
    from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig

    udh = embodiment.load("udh", "none")
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=5e-4), builder)
    model = udh.add_to_plant(plant, builtin_pd=False)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("pelvis", model), RigidTransform([0, 0, 1.0]))
    plant.Finalize()
    assert not any(plant.get_joint_actuator(i).has_controller() for i in plant.GetJointActuatorIndices(model))
    controller = builder.AddSystem(SaturatedPdController(plant, model, udh))
    builder.Connect(plant.get_state_output_port(model), controller.get_input_port(0))
    builder.Connect(controller.get_output_port(0), plant.get_actuation_input_port(model))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    targets = udh.standing_pose.copy()
    targets[udh.joint_names.index("left_elbow_y")] = -1.2
    targets[udh.joint_names.index("right_shoulder_y")] = -0.8
    controller.get_input_port(1).FixValue(controller.GetMyMutableContextFromRoot(context), targets)
    plant.SetPositions(plant_context, model, udh.standing_pose)
    simulator.AdvanceTo(1.0)
    q = plant.GetPositions(plant_context, model)
    assert np.max(np.abs(q - targets)) < 0.05
    torques = controller.get_output_port(0).Eval(controller.GetMyContextFromRoot(context))
    assert np.all(np.abs(torques) <= udh.effort_limits + 1e-9)


def test_port_contract():
    s = make_scene(builtin_pd=False)
    n = len(s.embodiment.joint_names)
    targets = AddActionToTargets(s.builder, s.embodiment, explicit=True)
    controller = AddPdControl(s.builder, s.plant, s.model, s.embodiment, targets.get_output_port(), explicit=True)
    assert_inputs_wired(s.builder, controller)
    assert_port_contract(controller, {"state": s.plant.num_multibody_states(s.model), "targets": n}, {"torques": n})
    assert s.builder.IsConnectedOrExported(s.plant.get_actuation_input_port(s.model))
    # With the built-in PD, the targets go to the plant's desired state (q and v) and no controller is added.
    s = make_scene()
    targets = AddActionToTargets(s.builder, s.embodiment)
    assert targets.get_output_port().size() == 2 * n
    assert AddPdControl(s.builder, s.plant, s.model, s.embodiment, targets.get_output_port()) is None
    assert s.builder.IsConnectedOrExported(s.plant.get_desired_state_input_port(s.model))
