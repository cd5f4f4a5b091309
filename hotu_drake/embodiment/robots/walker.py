"""UBTech Walker: 28 body DoF + 2 x 10 hand joints (48 DoF), 74.4 kg.

Kinematics and masses from the facts sheet (W1-W4, W4 masses). The root is
the torso at shoulder level (pelvis included). Arm axes differ between the
sides in the files and are kept as filed. The filed hip and knee efforts
(15-30 N m) cannot hold a 74 kg biped; as the sheet suggests, legs get
100 N m at hips and knees and 50 N m at the ankles (est.).
"""

from __future__ import annotations

import numpy as np

from hotu_drake.embodiment.builder import Dof, Drive, SpecBuilder, key_bodies, mirrored_pose, pick
from hotu_drake.embodiment.hands import WALKER_PALM_MASS, HandFrame, add_walker_hand, register_hand, walker_palm
from hotu_drake.embodiment.spec import SIDES, EmbodimentSpec, box, capsule, sphere

X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
KP = 870.0  # W2/W3: position actuators kp 870 on every joint


def _hand_frame(forearm: np.ndarray) -> HandFrame:
    """Right hand frame: x along the forearm, palm normal +y, index at +z."""
    x = forearm / np.linalg.norm(forearm)
    z = np.array([1.0, 0.0, 0.0])
    y = np.cross(z, x)
    return HandFrame(np.column_stack([x, y / np.linalg.norm(y), z]))


_RIGHT_FOREARM = np.array([0.0, -0.209, -0.978])
_HAND_FRAME = _hand_frame(_RIGHT_FOREARM)


def build(hands: str = "full") -> EmbodimentSpec:
    b = SpecBuilder("walker", "UBTech Walker", hands)
    torso = box((0.25, 0.40, 0.50), (0, 0, -0.20))
    b.root("torso", 20.773, "torso", [torso], [torso])
    head = [sphere(0.11, (0, 0, 0.10))]
    b.chain(
        "torso", "head", (0, -0.0002, 0.0985), [Dof("z", Z, -1.5708, 1.5708), Dof("y", Y, -0.2, 0.2)],
        Drive(10, 1.8, KP, 5), "neck", 0.11 + 2.003 + 1.208, head, head,
    )
    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        j3 = np.array(pick(side, (0, -0.0597, -0.2216), (0, 0.0602, -0.2205)))
        b.chain(
            "torso", f"{side}_shoulder_pitch_link", (0, sy * 0.2414, 0.0184),
            [Dof("y", pick(side, (0, 0.966, -0.257), (0, -0.965, -0.260)),
                 *pick(side, (-3.1416, 0.7854), (-0.7854, 3.1416)))],
            Drive(30, 2.094, KP, 15), "shoulder", 0.373, [sphere(0.05)], [], side,
        )
        upper_arm = [sphere(0.06), capsule(0.05, (0, 0, 0), tuple(j3))]
        b.chain(
            f"{side}_shoulder_pitch_link", f"{side}_upper_arm", (0, 0, 0),
            [Dof("x", pick(side, X, (-1, 0, 0)), -1.5708, 0.0175)],
            Drive(25, 3.142, KP, 8), "shoulder", 1.059, upper_arm, upper_arm[1:], side,
        )
        b.chain(
            f"{side}_upper_arm", f"{side}_upper_arm_twist_link", tuple(j3),
            [Dof("z", pick(side, (0, -0.257, -0.966), (0, 0.260, -0.965)), -1.9199, 1.9199)],
            Drive(15, 3.142, KP, 5), "shoulder", 1.311, [sphere(0.05)], [], side,
        )
        j5 = np.array(pick(side, (0, -0.068, -0.1999), (0, 0.0722, -0.2118)))
        forearm = [capsule(0.04, (0, 0, 0), tuple(j5))]
        b.chain(
            f"{side}_upper_arm_twist_link", f"{side}_forearm", (0, -sy * 0.0247, -0.0065),
            [Dof("x", pick(side, (-1, 0, 0), X), -2.234, 0.0)],
            Drive(15, 3.142, KP, 5), "elbow", 1.025, forearm, forearm, side,
        )
        b.chain(
            f"{side}_forearm", f"{side}_wrist_twist_link", tuple(j5),
            [Dof("z", pick(side, (0, -0.209, -0.978), (0, 0.215, -0.977)), -2.3562, 2.3562, velocity=4.887)],
            Drive(2.5, 3.142, KP, 5), "wrist", 0.523, [sphere(0.035)], [], side,
        )
        hand_visuals, hand_collisions = walker_palm(side, _HAND_FRAME)
        b.chain(
            f"{side}_wrist_twist_link", f"{side}_hand", (0, 0, 0),
            [
                Dof("y", pick(side, (0, 0.978, -0.209), (0, -0.977, -0.215)), -0.3508, 0.3508),
                Dof("x", pick(side, X, (-1, 0, 0)), -0.3508, 0.3508),
            ],
            Drive(2.5, 3.142, KP, 5), "wrist", 0.167 + 0.056 + WALKER_PALM_MASS,
            hand_visuals, hand_collisions, side,
        )
        register_hand(b, side, "walker", f"{side}_hand", _HAND_FRAME)
        if hands == "full":
            add_walker_hand(b, side, f"{side}_hand", _HAND_FRAME)

    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        b.chain(
            "torso", f"{side}_hip_yaw_link", (0, sy * 0.110, -0.4371), [Dof("z", Z, -1.0472, 1.0472)],
            Drive(100, 2.094, KP, 15), "hip", 0.988, [sphere(0.05)], [], side,
        )
        b.chain(
            f"{side}_hip_yaw_link", f"{side}_hip_roll_link", (0, 0, 0), [Dof("x", X, -0.5236, 0.5236)],
            Drive(100, 3.142, KP, 8), "hip", 3.392, [sphere(0.07)], [], side,
        )
        thigh = [capsule(0.07, (0, 0, -0.02), (0, sy * 0.0615, -0.27))]
        b.chain(
            f"{side}_hip_roll_link", f"{side}_thigh", (0, 0, 0), [Dof("y", Y, -1.3963, 0.5236)],
            Drive(100, 3.142, KP, 5), "hip", 4.637 + 6.606, thigh, thigh, side,
        )
        shank = [capsule(0.06, (0, 0, -0.02), (0, -sy * 0.0626, -0.255))]
        b.chain(
            f"{side}_thigh", f"{side}_shank", (0, sy * 0.0615, -0.2901), [Dof("y", Y, -0.1745, 2.1817)],
            Drive(100, 3.142, KP, 5), "knee", 2.852, shank, shank, side,
        )
        foot = box((0.27, 0.15, 0.02), (0.022, 0, -0.1304))
        ankle_link = [sphere(0.05), capsule(0.04, (0, 0, 0), (0, 0, -0.10))]
        corners = [sphere(0.01, (0.022 + x, y, -0.1304)) for x in (-0.125, 0.125) for y in (-0.065, 0.065)]
        b.chain(
            f"{side}_shank", f"{side}_foot", (0, -sy * 0.0626, -0.2749),
            [Dof("y", Y, -1.3963, 0.5236), Dof("x", X, -0.5236, 0.5236)],
            Drive(50, 3.142, KP, 5), "ankle", 0.684 + 1.356, [foot, *ankle_link], corners, side,
        )

    standing = mirrored_pose(
        lambda side: {f"{side}_hip_y": -0.2, f"{side}_knee_y": 0.4, f"{side}_ankle_y": -0.2}
    )
    return b.build(
        key_bodies=key_bodies("torso", "torso", "head"),
        standing_pose=standing,
        notes="W4 masses; leg efforts raised to stand (est.); shapes estimated",
    )
