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
# A full-body clip has all of these.
REQUIRED_LANDMARKS: tuple[str, ...] = (
    "pelvis",
    "chest",
    "neck",
    "head",
    *(f"{side}_{name}" for side in SIDES for name in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "toe")),
)
# A capture may cover part of the body: every region is complete or absent,
# the spine is always there, and legs need the pelvis.
REGIONS: dict[str, tuple[str, ...]] = {
    "spine": ("chest", "neck", "head"),
    "pelvis": ("pelvis", "left_hip", "right_hip"),
    **{f"{side}_leg": (f"{side}_knee", f"{side}_ankle", f"{side}_toe") for side in SIDES},
    **{f"{side}_arm": (f"{side}_shoulder", f"{side}_elbow", f"{side}_wrist") for side in SIDES},
}


def check_coverage(names, source: str) -> list[str]:
    """The body regions landmarks `names` cover; `ClipFormatError` (naming
    `source` and the missing landmarks) when a region is incomplete, the
    spine is missing, or legs come without the pelvis."""
    names = set(names)
    covered = [region for region, members in REGIONS.items() if set(members) <= names]
    incomplete = {
        region: [m for m in members if m not in names]
        for region, members in REGIONS.items()
        if region not in covered and set(members) & names
    }
    if "spine" not in covered:
        incomplete.setdefault("spine", [m for m in REGIONS["spine"] if m not in names])
    legs = [r for r in covered if r.endswith("_leg")]
    if legs and "pelvis" not in covered:
        incomplete.setdefault("pelvis", [m for m in REGIONS["pelvis"] if m not in names])
    if incomplete:
        missing = [m for members in incomplete.values() for m in members]
        regions = ", ".join(r.replace("_", " ") for r in incomplete)
        raise ClipFormatError(f"{source}: the skeleton lacks landmarks {', '.join(missing[:6])} (of the {regions})")
    return covered


def pelvis_frames(landmarks: Mapping[str, np.ndarray]) -> np.ndarray:
    """(T, 3, 3) root orientation: y from the right to the left hip, z up the
    spine; for a capture without the pelvis, of the chest (y from the right
    to the left shoulder, z from the chest to the neck)."""
    left, right, low, high = ("left_hip", "right_hip", "pelvis", "chest")
    if "pelvis" not in landmarks:
        left, right, low, high = ("left_shoulder", "right_shoulder", "chest", "neck")
    y = np.asarray(landmarks[left]) - np.asarray(landmarks[right])
    y /= np.linalg.norm(y, axis=-1, keepdims=True)
    up = np.asarray(landmarks[high]) - np.asarray(landmarks[low])
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

    The root is the pelvis landmark with the pelvis frame's orientation (the
    chest's, for a capture of the upper body: see `check_coverage`);
    velocities are finite differences of the samples.
    """
    covered = check_coverage(landmarks, source)
    if "pelvis" not in covered and not {"left_arm", "right_arm"} <= set(covered):
        raise ClipFormatError(f"{source}: a capture without the pelvis needs both arms (the chest's frame)")
    unknown = [name for name in landmarks if name not in LANDMARKS]
    if unknown:
        raise ClipFormatError(f"{source}: unknown landmarks {', '.join(unknown[:4])}")
    names = [name for name in LANDMARKS if name in landmarks]
    positions = np.stack([np.asarray(landmarks[name], dtype=float) for name in names], axis=1)
    if positions.ndim != 3 or positions.shape[0] == 0:
        raise ClipFormatError(f"{source}: has zero frames")
    if not np.all(np.isfinite(positions)):
        raise ClipFormatError(f"{source}: landmark positions contain NaN or infinite values")
    root_position = positions[:, names.index("pelvis" if "pelvis" in names else "chest")]
    with np.errstate(all="ignore"):
        frames = pelvis_frames(landmarks)
    broken = ~np.all(np.isfinite(frames), axis=(1, 2))
    if broken.any():
        raise ClipFormatError(
            f"{source}: frame {int(np.argmax(broken))}: the root's frame is undefined (coinciding landmarks)"
        )
    quaternion = matrix_to_quat(frames)
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


ARM_SPAN = ("left_wrist", "left_elbow", "left_shoulder", "right_shoulder", "right_elbow", "right_wrist")


def body_height(points: Mapping[str, np.ndarray]) -> float:
    """Standing height (m) from landmark trajectories (z up): the head top (or
    head) over the lowest foot landmark, plus the ankle's height over the
    sole (median over frames); for a capture without legs, the arm span,
    which is about a person's height."""
    if "left_ankle" in points:
        top = points.get("head_top", points["head"])[:, 2]
        feet = [points[n][:, 2] for n in ("left_ankle", "right_ankle", "left_toe", "right_toe") if n in points]
        return float(np.median(top - np.min(feet, axis=0))) + 0.05
    span = sum(np.linalg.norm(points[a] - points[b], axis=1) for a, b in zip(ARM_SPAN[:-1], ARM_SPAN[1:]))
    return float(np.median(span))


def torso_tilt(points: Mapping[str, np.ndarray]) -> tuple[str, np.ndarray]:
    """The torso's lean from the up axis (z), degrees per frame (0: upright,
    90: lying, 180: upside down), and which segment gave it: the pelvis to
    the neck, or the chest to the neck for a capture without the pelvis. A
    torso of no length is taken as lying (it shows no uprightness)."""
    low = "pelvis" if "pelvis" in points else "chest"
    torso = np.asarray(points["neck"], dtype=float) - np.asarray(points[low], dtype=float)
    length = np.linalg.norm(torso, axis=1)
    cosine = np.divide(torso[:, 2], length, out=np.zeros(len(torso)), where=length > 0)
    return f"{low} to neck", np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def landmarks_of(clip: MotionClip) -> dict[str, np.ndarray]:
    """{landmark: (T, 3)} of a human clip."""
    return {name: clip.key_body_positions[:, i] for i, name in enumerate(clip.key_body_names)}
