"""Where the human landmarks sit on the unified digital human.

The UDH is the human of the method: its configuration determines every
landmark (`udh_landmarks`), which is how the procedural library makes human
demonstrations and how retargeting reads a source onto the UDH.
"""

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.kinematics import batch_link_poses
from hotu_drake.embodiment.landmarks import landmark_placements as _placements
from hotu_drake.motion.clip import MotionClip
from hotu_drake.rotations import quat_to_matrix


def landmark_placements(udh: Embodiment) -> dict[str, tuple[str, np.ndarray]]:
    """Landmark -> (UDH link, offset in that link's frame)."""
    return _placements(udh.spec)


def points_on_clip(
    emb: Embodiment, clip: MotionClip, placements: dict[str, tuple[str, np.ndarray]]
) -> dict[str, np.ndarray]:
    """{name: (T, 3)} world positions of points fixed on links (landmarks,
    markers), over an embodiment's clip."""
    poses = batch_link_poses(
        emb.spec, clip.joint_names, clip.joint_positions, quat_to_matrix(clip.root_quaternion), clip.root_position
    )
    out = {}
    for name, (link, offset) in placements.items():
        rot, pos = poses[link]
        out[name] = pos + rot @ offset
    return out


def udh_landmarks(udh: Embodiment, clip: MotionClip) -> dict[str, np.ndarray]:
    """{landmark: (T, 3)} world positions for a UDH clip."""
    return points_on_clip(udh, clip, landmark_placements(udh))
