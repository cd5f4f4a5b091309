"""TransferReferenceSystem: its ports, and the reference one control step
ahead relative to the robot, in the pelvis' heading frame."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw

from hotu_drake.errors import InputError
from hotu_drake.motion.clip import MotionClip
from hotu_drake.objects import add_object
from hotu_drake.plant import set_robot_state
from hotu_drake.systems.observation import AddObservation
from hotu_drake.systems.transfer_reference import AddTransferReference, TransferReference
from tests.systems.conftest import make_scene
from tests.systems.ports import assert_inputs_wired, assert_port_contract

FRAMES, FPS = 31, 30.0


def _reference(emb, object_names=("box", "target_marker")) -> MotionClip:
    """One second of BRUCE: the joints ramping, the key bodies and the box moving along +x."""
    t = np.arange(FRAMES) / FPS
    q = emb.standing_pose[None] + 0.2 * t[:, None]
    root = np.tile([0.0, 0.0, emb.standing_root_height], (FRAMES, 1))
    keys = list(dict.fromkeys(emb.key_bodies.values()))
    key_positions = np.zeros((FRAMES, len(keys), 3)) + t[:, None, None] * np.array([1.0, 0.0, 0.0])
    poses = np.zeros((FRAMES, len(object_names), 7))
    poses[..., 3] = 1.0
    poses[:, 0, :3] = np.stack([0.5 + t, 0.0 * t, 0.4 + 0.0 * t], axis=1)
    return MotionClip.from_positions(
        emb.name, "test", FPS, emb.joint_names, q, root, np.tile([1.0, 0, 0, 0], (FRAMES, 1)), keys, key_positions,
        object_names=list(object_names), object_poses=poses,
    )  # fmt: skip


def test_port_contract_and_the_features_of_a_turned_robot():
    scene = make_scene(finalize=False)
    box = scene.plant.GetBodyByName("box", add_object(scene.plant, "box"))
    scene.plant.Finalize()
    emb, plant = scene.embodiment, scene.plant
    reference = TransferReference(_reference(emb), "box", 1.0 / FPS)
    observation = AddObservation(scene.builder, plant, scene.model, emb)
    system = AddTransferReference(scene.builder, plant, scene.model, observation, reference, emb.spec.root.name, box)
    assert_inputs_wired(scene.builder, system)
    size = observation.GetOutputPort("observation").size()
    assert_port_contract(system, {"observation": size, "body_poses": None}, {"reference": reference.size})
    assert reference.size == len(emb.joint_names) + 3 * len(reference.clip.key_body_names) + 4
    diagram = scene.builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    set_robot_state(plant, plant_context, scene.model, emb)
    turn = RollPitchYaw(0, 0, np.pi / 2).ToRotationMatrix()  # the robot faces +y
    root = plant.GetBodyByName(emb.spec.root.name, scene.model)
    plant.SetFreeBodyPose(plant_context, root, RigidTransform(turn, [0.0, 0.0, emb.standing_root_height]))
    plant.SetFreeBodyPose(plant_context, box, RigidTransform([0.5, 0.0, 0.4]))
    features = system.GetOutputPort("reference").Eval(system.GetMyContextFromRoot(context))
    n, k = len(emb.joint_names), len(reference.clip.key_body_names)
    joints = observation.GetOutputPort("observation").Eval(observation.GetMyContextFromRoot(context))
    np.testing.assert_allclose(
        features[:n], reference.clip.joint_positions[1] - joints[observation.joint_position_columns]
    )
    # The box should be 1/30 m further along +x: in the heading frame of a robot facing +y, that is -y.
    np.testing.assert_allclose(features[n + 3 * k : n + 3 * k + 3], [0.0, -1 / FPS, 0.0], atol=1e-9)
    assert features[-1] == pytest.approx((1 / FPS) / reference.clip.duration)


def test_a_reference_needs_the_object_and_target_tracks():
    from hotu_drake import embodiment

    emb = embodiment.load("bruce", "none")
    with pytest.raises(InputError, match="no target_marker track"):
        TransferReference(_reference(emb, ("box",)), "box", 1.0 / FPS)
    with pytest.raises(InputError, match="no drill track"):
        TransferReference(_reference(emb), "drill", 1.0 / FPS)
