"""Where the human landmarks sit on the unified digital human.

The UDH is the human of the method: its configuration determines every
landmark (`udh_landmarks`), which is how the procedural library makes human
demonstrations and how retargeting reads a source onto the UDH.
"""

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.kinematics import batch_link_poses
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import FINGER_POINTS, SIDES
from hotu_drake.motion.rotations import quat_to_matrix

# (link, offset in the link frame at q = 0, scaled by the UDH's size).
_AXIAL = {
    "pelvis": ("pelvis", (0.0, 0.0, 0.0)),
    "spine": ("pelvis", (0.0, 0.0, 0.13)),
    "chest": ("torso", (0.0, 0.0, 0.12)),
    "neck": ("head", (0.0, 0.0, 0.0)),
    "head": ("head", (0.0, 0.0, 0.175)),
    "head_top": ("head", (0.0, 0.0, 0.27)),
}
_LIMB = {
    "shoulder": ("upper_arm", (0.0, 0.0, 0.0)),
    "elbow": ("forearm", (0.0, 0.0, 0.0)),
    "wrist": ("hand", (0.0, 0.0, 0.0)),
    "hand": ("hand", (0.0, 0.0, -0.14)),
    "hip": ("thigh", (0.0, 0.0, 0.0)),
    "knee": ("shin", (0.0, 0.0, 0.0)),
    "ankle": ("foot", (0.0, 0.0, 0.0)),
    "toe": ("foot", (0.10, 0.0, -0.04)),
}
# Finger points 1-4 on the qb SoftHand chains: (joint index, or "tip").
_FINGER_JOINTS = {
    "thumb": (0, 1, 3, "tip"),
    "index": (0, 2, 4, "tip"),
    "middle": (0, 2, 4, "tip"),
    "ring": (0, 2, 4, "tip"),
    "little": (0, 2, 4, "tip"),
}


def _scale(udh: Embodiment) -> float:
    """Size of this UDH relative to the nominal 1.61 m one (from its thigh length)."""
    shin = np.asarray(udh.spec.link("left_shin").origin)
    thigh = np.asarray(udh.spec.link("left_thigh").origin)
    return float(np.linalg.norm(shin - thigh) / 0.4215)


def landmark_placements(udh: Embodiment) -> dict[str, tuple[str, np.ndarray]]:
    """Landmark -> (UDH link, offset in that link's frame)."""
    s = _scale(udh)
    out = {name: (link, s * np.asarray(offset)) for name, (link, offset) in _AXIAL.items()}
    for side in SIDES:
        for name, (link, offset) in _LIMB.items():
            out[f"{side}_{name}"] = (f"{side}_{link}", s * np.asarray(offset))
        if udh.hands == "full":
            for finger, joints in _FINGER_JOINTS.items():
                for point, joint in zip(FINGER_POINTS, joints):
                    if joint == "tip":
                        link = udh.spec.link(f"{side}_{finger}_{len(_finger_links(udh, side, finger)) - 1}_link")
                        tip = 2.0 * np.asarray(link.visuals[0].position)  # end of the last phalanx
                        out[f"{side}_{finger}_{point}"] = (link.name, tip)
                    else:
                        out[f"{side}_{finger}_{point}"] = (f"{side}_{finger}_{joint}_link", np.zeros(3))
    return out


def _finger_links(udh: Embodiment, side: str, finger: str) -> list[str]:
    prefix = f"{side}_{finger}_"
    return [j for j in udh.joint_names if j.startswith(prefix)]


def udh_landmarks(udh: Embodiment, clip: MotionClip) -> dict[str, np.ndarray]:
    """{landmark: (T, 3)} world positions for a UDH clip."""
    poses = batch_link_poses(
        udh.spec,
        clip.joint_names,
        clip.joint_positions,
        quat_to_matrix(clip.root_quaternion),
        clip.root_position,
    )
    out = {}
    for name, (link, offset) in landmark_placements(udh).items():
        rot, pos = poses[link]
        out[name] = pos + rot @ offset
    return out
