"""InteractionGraphSystem: a scripted hand on the box turns the edge on; off when it leaves; s_I and
the goal in the body's heading frame."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.objects import add_object
from hotu_drake.systems.interaction_graph import AddInteractionGraph, InteractionGraphSystem
from tests.systems.conftest import make_scene
from tests.systems.ports import assert_inputs_wired, assert_port_contract


def _scene(yaw: float = 0.0):
    udh = embodiment.load("udh", "full")
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.005, contact_model="point"), builder)
    model = udh.add_to_plant(plant)
    turn = RotationMatrix.MakeZRotation(yaw)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("pelvis", model), RigidTransform(turn, [0, 0, 1.0]))
    box = add_object(plant, "box")
    plant.Finalize()
    graph = builder.AddSystem(InteractionGraphSystem(plant, model, udh, {"box": plant.GetBodyByName("box", box)}))
    builder.Connect(plant.get_body_poses_output_port(), graph.get_input_port(0))
    builder.Connect(scene_graph.get_query_output_port(), graph.get_input_port(1))
    builder.ExportInput(graph.get_input_port(2), "object_targets")
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, model, udh.standing_pose)
    target = turn @ np.array([1.0, 0.5, 0.15])
    diagram.get_input_port(0).FixValue(context, target)
    return udh, plant, model, graph, diagram, context, plant_context, target


def test_hand_on_box_turns_the_edge_on_and_off():
    udh, plant, model, graph, diagram, context, plant_context, target = _scene()
    palm = plant.GetBodyByName("left_hand", model)
    hand = plant.EvalBodyPoseInWorld(plant_context, palm).translation()
    box = plant.GetBodyByName("box")
    # The box's face just inside the palm (left hand: palm faces -y, toward the body).
    plant.SetFreeBodyPose(plant_context, box, RigidTransform(hand + [0.0, -0.15 - 0.01, -0.09]))
    simulator = Simulator(diagram, context)
    simulator.AdvanceTo(0.005)  # the discrete plant reports the contacts of its last step
    graph_context = graph.GetMyContextFromRoot(context)
    on = graph.GetOutputPort("graph").Eval(graph_context)
    assert on.edges[("left_hand", "box")] and not on.edges[("right_hand", "box")]
    box_position = plant.EvalBodyPoseInWorld(plant_context, box).translation()
    hand = plant.EvalBodyPoseInWorld(plant_context, palm).translation()  # after the step
    assert on.hand_object[("left_hand", "box")] == pytest.approx(box_position - hand)
    assert on.object_target["box"] == pytest.approx(target - box_position)
    interaction = graph.GetOutputPort("interaction").Eval(graph_context)
    assert interaction.size == graph.interaction_size == 3 * 2 + 3 + 2
    assert interaction[:3] == pytest.approx(box_position - hand) and interaction[-2:] == pytest.approx([1.0, 0.0])

    plant.SetFreeBodyPose(plant_context, box, RigidTransform(hand + [1.0, 0.0, 0.0]))
    simulator.AdvanceTo(0.010)
    off = graph.GetOutputPort("graph").Eval(graph_context)
    assert not off.edges[("left_hand", "box")]
    assert graph.GetOutputPort("interaction").Eval(graph_context)[-2:] == pytest.approx([0.0, 0.0])


def test_port_contract():
    s = make_scene(finalize=False)
    box = add_object(s.plant, "box")
    s.plant.Finalize()
    bodies = {"box": s.plant.GetBodyByName("box", box)}
    graph = AddInteractionGraph(
        s.builder, s.plant, s.scene_graph, s.model, s.embodiment, bodies, np.array([[1.0, 0.0, 0.5]])
    )
    assert_inputs_wired(s.builder, graph)
    # s_I for two hands and one object: d_ho (2 x 3), d_og (3), e_ho (2).
    inputs = {"body_poses": None, "geometry_query": None, "object_targets": 3}
    assert_port_contract(graph, inputs, {"graph": None, "interaction": 3 * 2 + 3 + 2, "goal": 12})


def test_interaction_and_goal_turn_with_the_body():
    """The same scene turned about z gives the same s_I and goal: they are in the body's heading frame."""
    outputs = []
    for yaw in (0.0, 0.7):
        udh, plant, model, graph, diagram, context, plant_context, target = _scene(yaw)
        box = plant.GetBodyByName("box")
        turn = RotationMatrix.MakeZRotation(yaw)
        plant.SetFreeBodyPose(plant_context, box, RigidTransform(turn, turn @ np.array([0.5, 0.2, 1.1])))
        graph_context = graph.GetMyContextFromRoot(context)
        outputs.append([graph.GetOutputPort(p).Eval(graph_context).copy() for p in ("interaction", "goal")])
    assert outputs[0][0][6:9] == pytest.approx(np.array([1.0, 0.5, 0.15]) - [0.5, 0.2, 1.1])  # facing +x
    for a, b in zip(*outputs):
        np.testing.assert_allclose(a, b, atol=1e-9)
