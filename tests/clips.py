"""Small UDH clips for tests: smooth joint motion within limits, a moving root."""

import numpy as np

from hotu_drake import embodiment
from hotu_drake.motion.clip import MotionClip
from hotu_drake.rotations import matrix_to_quat


def udh_test_clip(hands: str = "none", frames: int = 240, fps: float = 120.0, seed: int = 0) -> MotionClip:
    """Every joint sways around the standing pose (ankle roll held: two foot
    landmarks cannot show it); fingers bend with their rolling-contact twins;
    the root walks forward while turning."""
    udh = embodiment.load("udh", hands)
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    lower, upper = udh.position_lower, udh.position_upper
    amplitude = np.minimum(0.25 * (upper - lower), 0.5)
    middle = np.clip(udh.standing_pose, lower + amplitude, upper - amplitude)
    phase = rng.uniform(0, 2 * np.pi, len(middle))
    frequency = rng.uniform(0.3, 1.0, len(middle))
    q = middle + amplitude * np.sin(2 * np.pi * frequency * t[:, None] + phase)
    for i, name in enumerate(udh.joint_names):
        if any(part in name for part in ("_hip_", "_knee_", "_ankle_")):
            q[:, i] = udh.standing_pose[i] + 0.1 * np.sin(2 * np.pi * 0.5 * t + phase[i])
        if "_ankle_x" in name:
            q[:, i] = udh.standing_pose[i]
        finger = name.split("_")[1] if name.count("_") == 2 else ""
        index = name.rsplit("_", 1)[-1]
        if finger in ("index", "middle", "ring", "little") and index in ("1", "3", "5"):
            q[:, i] = q[:, i - 1]
        if finger == "thumb" and index in ("2", "4"):
            q[:, i] = q[:, i - 1]
    yaw = 0.3 * t
    rotation = np.zeros((frames, 3, 3))
    rotation[:, 0, 0], rotation[:, 0, 1] = np.cos(yaw), -np.sin(yaw)
    rotation[:, 1, 0], rotation[:, 1, 1] = np.sin(yaw), np.cos(yaw)
    rotation[:, 2, 2] = 1.0
    quaternion = matrix_to_quat(rotation)
    position = np.stack([0.3 * t, 0.1 * t, np.full(frames, udh.standing_root_height)], axis=1)
    return MotionClip.from_positions(
        "udh", "tests/udh_test_clip", fps, udh.joint_names, q, position, quaternion, part_index=udh.parts
    )
