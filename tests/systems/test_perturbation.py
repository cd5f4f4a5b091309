"""Perturbation: a cube waits, is thrown at the robot at its time, and hits it."""

import numpy as np
import pytest
from pydrake.multibody.plant import AddMultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.plant import add_ground
from hotu_drake.scenario import default_plant_config
from hotu_drake.systems.perturbation import (
    AddPerturbation,
    CubeLaunch,
    Perturbation,
    add_perturbation_cubes,
    place_perturbation_cubes,
)
from tests.systems.conftest import make_scene
from tests.systems.ports import assert_inputs_wired, assert_port_contract


def test_cube_waits_then_flies_at_the_robot_and_hits_it():
    h1 = embodiment.load("h1", "none")
    settings = default_plant_config()
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(settings, builder)
    model = h1.add_to_plant(plant)
    add_ground(plant)
    launches = [CubeLaunch(time=0.5, start=(1.2, 0.0, 1.3), speed=5.0, mass=2.0, aim_height=0.3)]
    (cube,) = add_perturbation_cubes(plant, launches)
    plant.Finalize()
    torso = plant.GetBodyByName("torso", model)
    perturbation = builder.AddSystem(Perturbation(plant, [cube], launches, torso, settings.time_step))
    builder.Connect(plant.get_body_poses_output_port(), perturbation.GetInputPort("body_poses"))
    builder.Connect(perturbation.GetOutputPort("spatial_forces"), plant.get_applied_spatial_force_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    q = h1.standing_pose
    plant.get_desired_state_input_port(model).FixValue(plant_context, np.concatenate([q, np.zeros_like(q)]))
    positions = plant.GetPositions(plant_context, model)
    positions[4:7] = [0.0, 0.0, h1.standing_root_height]
    positions[7:] = q
    plant.SetPositions(plant_context, model, positions)
    place_perturbation_cubes(plant, plant_context, [cube], launches)

    simulator.AdvanceTo(0.45)  # waiting, held still against gravity
    assert plant.EvalBodyPoseInWorld(plant_context, cube).translation() == pytest.approx([1.2, 0.0, 1.3], abs=1e-3)
    simulator.AdvanceTo(0.52)  # thrown: moving toward the torso at about 5 m/s
    velocity = plant.EvalBodySpatialVelocityInWorld(plant_context, cube).translational()
    assert np.linalg.norm(velocity) == pytest.approx(5.0, rel=0.1) and velocity[0] < -4.0
    hit = False
    for step in range(1, 60):
        simulator.AdvanceTo(0.52 + 0.005 * step)
        contacts = plant.get_contact_results_output_port().Eval(plant_context)
        for i in range(contacts.num_point_pair_contacts()):
            info = contacts.point_pair_contact_info(i)
            if cube.index() in (info.bodyA_index(), info.bodyB_index()) and int(info.bodyA_index()) > 0:
                other = info.bodyB_index() if info.bodyA_index() == cube.index() else info.bodyA_index()
                hit = hit or plant.get_body(other).model_instance() == model
    assert hit


def test_port_contract():
    s = make_scene(finalize=False)
    launches = [CubeLaunch()]
    cubes = add_perturbation_cubes(s.plant, launches)
    s.plant.Finalize()
    torso = s.plant.GetBodyByName(s.embodiment.key_bodies["torso"], s.model)
    thrower = AddPerturbation(s.builder, s.plant, cubes, launches, torso, 0.005)
    assert_inputs_wired(s.builder, thrower)
    assert_port_contract(thrower, {"body_poses": None}, {"spatial_forces": None})
    assert add_perturbation_cubes(s.plant, []) == []  # no launches: no cubes, no model instance
