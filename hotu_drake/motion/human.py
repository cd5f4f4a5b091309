"""The human skeleton every demonstration is read into: named landmarks.

A demonstration, whatever its source (BVH joints, C3D markers, the
procedural library), becomes a `MotionClip` with embodiment `"human"`, no
joints, and these landmarks as key bodies (world positions, metres, z up).
Retargeting matches the directions between landmarks, so it does not depend
on a source's joint conventions or rest pose.
"""

from collections.abc import Mapping

import numpy as np

from hotu_drake.embodiment.spec import FINGERS, SIDES
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.rotations import matrix_to_quat

HUMAN = "human"

# head_front: a point 10 cm in front of the head centre (gives the head's yaw).
AXIAL_LANDMARKS = ("pelvis", "spine", "chest", "neck", "head", "head_top", "head_front")
LIMB_LANDMARKS = ("shoulder", "elbow", "wrist", "hand", "hip", "knee", "ankle", "toe")
# Finger points: 1 = base knuckle, 2, 3 = the next joints, 4 = tip.
FINGER_POINTS = (1, 2, 3, 4)

LANDMARKS: tuple[str, ...] = (
    *AXIAL_LANDMARKS,
    *(f"{side}_{name}" for side in SIDES for name in LIMB_LANDMARKS),
    *(f"{side}_{finger}_{i}" for side in SIDES for finger in FINGERS for i in FINGER_POINTS),
)
# Without these a clip cannot be retargeted.
REQUIRED_LANDMARKS: tuple[str, ...] = (
    "pelvis",
    "chest",
    "neck",
    "head",
    *(f"{side}_{name}" for side in SIDES for name in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "toe")),
)


def finger_landmarks(side: str) -> list[str]:
    return [f"{side}_{finger}_{i}" for finger in FINGERS for i in FINGER_POINTS]


def pelvis_frames(landmarks: Mapping[str, np.ndarray]) -> np.ndarray:
    """(T, 3, 3) pelvis orientation: y from right to left hip, z up the spine."""
    y = np.asarray(landmarks["left_hip"]) - np.asarray(landmarks["right_hip"])
    y /= np.linalg.norm(y, axis=-1, keepdims=True)
    up = np.asarray(landmarks["chest"]) - np.asarray(landmarks["pelvis"])
    z = up - np.sum(up * y, axis=-1, keepdims=True) * y
    z /= np.linalg.norm(z, axis=-1, keepdims=True)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-1)


def human_clip(
    landmarks: Mapping[str, np.ndarray],
    fps: float,
    source: str,
    object_names: list[str] | None = None,
    object_poses: np.ndarray | None = None,
    contact_names: list[str] | None = None,
    contacts: np.ndarray | None = None,
) -> MotionClip:
    """Build a human clip from landmark trajectories {name: (T, 3)}.

    The root is the pelvis landmark with the pelvis frame's orientation;
    velocities are finite differences of the samples.
    """
    missing = [name for name in REQUIRED_LANDMARKS if name not in landmarks]
    if missing:
        raise ClipFormatError(f"{source}: the skeleton lacks landmarks {', '.join(missing[:4])}")
    unknown = [name for name in landmarks if name not in LANDMARKS]
    if unknown:
        raise ValueError(f"unknown landmarks {unknown[:4]}")
    names = [name for name in LANDMARKS if name in landmarks]
    positions = np.stack([np.asarray(landmarks[name], dtype=float) for name in names], axis=1)
    if positions.ndim != 3 or positions.shape[0] == 0:
        raise ClipFormatError(f"{source}: has zero frames")
    if not np.all(np.isfinite(positions)):
        raise ClipFormatError(f"{source}: landmark positions contain NaN or infinite values")
    root_position = positions[:, names.index("pelvis")]
    quaternion = matrix_to_quat(pelvis_frames(landmarks))
    return MotionClip.from_positions(
        HUMAN,
        source,
        fps,
        [],
        np.zeros((len(positions), 0)),
        root_position,
        quaternion,
        names,
        positions,
        object_names=list(object_names or []),
        object_poses=object_poses,
        contact_names=list(contact_names or []),
        contacts=contacts,
    )


def landmarks_of(clip: MotionClip) -> dict[str, np.ndarray]:
    """{landmark: (T, 3)} of a human clip."""
    return {name: clip.key_body_positions[:, i] for i, name in enumerate(clip.key_body_names)}
