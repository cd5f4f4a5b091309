"""TransferReferenceSystem: where a retargeted UDH episode says the robot should be next.

A transferred skill's fine-tuning layer (`train finetune`) sees, next to the
robot's observation, the goal and s_I, the reference one control step ahead
relative to the robot now (`TransferReference.features`): the joints'
offsets, the key bodies' offsets and the object's offset (both in the
pelvis' heading frame), and the episode's phase. The transfer environments
(`envs.transfer`) and this system compute them with the same
`TransferReference`, so a diagram deploys the layer as it was trained.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import Value
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem

from hotu_drake.errors import InputError
from hotu_drake.motion.clip import MotionClip

TARGET_TRACK = "target_marker"  # the name of a reference's target track


def track_index(clip: MotionClip, kind: str) -> int | None:
    """The index of the clip's first object track whose name starts with `kind` (any case), or None."""
    if clip.object_poses is None:
        return None
    kind = kind.lower()
    return next((k for k, n in enumerate(clip.object_names) if n.lower().startswith(kind)), None)


def reference_size(clip: MotionClip) -> int:
    """The length of a reference's features: joints, key bodies, object, phase."""
    return len(clip.joint_names) + 3 * len(clip.key_body_names) + 3 + 1


class TransferReference:
    """A reference episode (a robot clip with a track of the task's object,
    `object_kind`, and a `target_marker` track) read at the control rate."""

    def __init__(self, clip: MotionClip, object_kind: str, control_period: float):
        self.clip, self.control_period = clip, control_period
        missing = [n for n in (object_kind, TARGET_TRACK) if track_index(clip, n) is None]
        if missing:
            raise InputError(f"{clip.source}: no {' or '.join(missing)} track to track")
        self.object_track = track_index(clip, object_kind)
        self.target_track = track_index(clip, TARGET_TRACK)

    @property
    def size(self) -> int:
        """The length of `features`."""
        return reference_size(self.clip)

    def start(self) -> tuple[np.ndarray, np.ndarray]:
        """The object's start pose [x y z qw qx qy qz] and the target position."""
        poses = self.clip.object_poses[0]
        return poses[self.object_track].copy(), poses[self.target_track, :3].copy()

    def errors(self, time: float, joints: np.ndarray, key_positions: np.ndarray, object_position: np.ndarray):
        """Reference one control step after `time` minus the robot at `time`:
        joints (n,), key bodies (k, 3), the object (3,), world frame; and the phase."""
        clip = self.clip
        ahead = time + self.control_period
        frame = min(int(round(ahead * clip.fps)), clip.num_frames - 1)
        return (
            clip.joint_positions[frame] - joints,
            clip.key_body_positions[frame] - key_positions,
            clip.object_poses[frame, self.object_track, :3] - object_position,
            min(ahead / max(clip.duration, 1e-9), 1.0),
        )

    @staticmethod
    def features(errors, root_rotation: np.ndarray) -> np.ndarray:
        """`errors` as the layer sees them: the offsets in the heading frame of `root_rotation`."""
        joints, keys, obj, phase = errors
        yaw = np.arctan2(root_rotation[1, 0], root_rotation[0, 0])
        c, s = np.cos(yaw), np.sin(yaw)
        world_to_heading = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        return np.concatenate([joints, (keys @ world_to_heading.T).ravel(), world_to_heading @ obj, [phase]])


class TransferReferenceSystem(LeafSystem):
    """The reference features of a transfer, from the plant.

    .. pydrake_system::

        name: TransferReferenceSystem
        input_ports:
        - observation
        - body_poses
        output_ports:
        - reference

    `observation` is the ObservationSystem's (its joint columns give the
    joints), `body_poses` the plant's.
    """

    def __init__(
        self,
        reference: TransferReference,
        observation_size: int,
        joint_columns: np.ndarray,
        key_bodies: list[int],
        root_body: int,
        object_body: int,
    ):
        super().__init__()
        self._reference = reference
        self._columns = np.asarray(joint_columns)
        self._keys, self._root, self._object = [int(b) for b in key_bodies], int(root_body), int(object_body)
        self._observation = self.DeclareVectorInputPort("observation", observation_size)
        self._poses = self.DeclareAbstractInputPort("body_poses", Value[list[RigidTransform]]([]))
        self.DeclareVectorOutputPort("reference", reference.size, self._CalcReference)

    def _CalcReference(self, context: Context, output: BasicVector) -> None:
        poses = self._poses.Eval(context)
        joints = self._observation.Eval(context)[self._columns]
        keys = np.array([poses[b].translation() for b in self._keys])
        errors = self._reference.errors(context.get_time(), joints, keys, poses[self._object].translation())
        output.SetFromVector(self._reference.features(errors, poses[self._root].rotation().matrix()))


def AddTransferReference(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    model,
    observation_system,
    reference: TransferReference,
    root_body_name: str,
    object_body,
) -> TransferReferenceSystem:
    """Add a `TransferReferenceSystem` named `transfer_reference` fed by the
    ObservationSystem and the plant's body poses; its `reference` output
    goes to the skill's `reference` input."""
    keys = [plant.GetBodyByName(name, model).index() for name in reference.clip.key_body_names]
    root = plant.GetBodyByName(root_body_name, model).index()
    observation = observation_system.GetOutputPort("observation")
    system = TransferReferenceSystem(
        reference, observation.size(), observation_system.joint_position_columns, keys, root, object_body.index()
    )
    added = builder.AddNamedSystem("transfer_reference", system)
    builder.Connect(observation, added.GetInputPort("observation"))
    builder.Connect(plant.get_body_poses_output_port(), added.GetInputPort("body_poses"))
    return added
