"""NAVIAI ("ZJU humanoid", 3N2-JUNE): 29 body DoF + 58 qb SoftHand fingers.

Kinematics from the facts sheet (N1, N3): the kinematic root is the upper
torso at shoulder level and the legs hang from a waist yaw joint. Pitch
joints use +y on both sides (the files flip some left axes; limits are
converted so that hip flexion is negative and knee flexion positive, as on
every other embodiment). Per-link masses are the sheet's estimates scaled to
the 25.9 kg CAD total. Gains are the sheet's estimates, doubled for the
legs and waist (ankles: est. 40 / 2, here 400 / 10) so that the PD alone
holds the standing pose with margin.
"""

from __future__ import annotations

import numpy as np

from hotu_drake.embodiment.builder import Dof, Drive, SpecBuilder, key_bodies, mirror_limits, mirrored_pose, pick
from hotu_drake.embodiment.hands import QBHAND_PALM_MASS, HandFrame, add_qbhand, qbhand_palm, register_hand
from hotu_drake.embodiment.spec import SIDES, EmbodimentSpec, box, capsule, sphere

X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
_HAND_FRAME = HandFrame(np.diag([-1.0, 1.0, -1.0]))


def build(hands: str = "full") -> EmbodimentSpec:
    b = SpecBuilder("naviai", "NAVIAI", hands)
    torso = box((0.20, 0.30, 0.42), (0, 0, -0.20))
    b.root("torso", 10.0, "torso", [torso], [torso])
    b.chain(
        "torso", "neck", (-0.0014, 0, 0.089), [Dof("z", (0, 0, -1), -0.785, 0.785)],
        Drive(7, 3.62, 10, 0.5), "neck", 0.3, [capsule(0.03, (0, 0, 0), (0, 0, 0.042))],
    )
    head = [sphere(0.10, (0, 0, 0.09))]
    b.chain(
        "neck", "head", (0, 0, 0.042), [Dof("y", (0, -1, 0), -0.174, 0.349)],
        Drive(7, 3.62, 10, 0.5), "neck", 1.2, head, head,
    )
    sacrum = box((0.15, 0.26, 0.12), (0, 0, -0.10))
    b.chain(
        "torso", "sacrum", (-0.0014, 0, -0.4121), [Dof("z", (0, 0, -1), -0.785, 0.785)],
        Drive(31.2, 7.85, 200, 8), "torso", 3.0, [sacrum], [sacrum],
    )
    shoulder = Drive(54.67, 4.58, 80, 3)
    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        b.chain(
            "torso", f"{side}_scapula", (-0.0014, sy * 0.1587, -0.0466),
            [Dof("y", (0, -sy * 0.940, -0.342), *pick(side, (-3.14, 1.22), (-1.22, 3.14)))],
            shoulder, "shoulder", 0.2, [sphere(0.04)], [], side,
        )
        b.chain(
            f"{side}_scapula", f"{side}_shoulder", (0, sy * 0.0707, 0.0257),
            [Dof("x", X, *mirror_limits(side, -2.26, 0.0))],
            shoulder, "shoulder", 0.2, [sphere(0.05)], [], side,
        )
        upper_arm = [capsule(0.04, (0, 0, -0.02), (0, 0, -0.13))]
        b.chain(
            f"{side}_shoulder", f"{side}_upper_arm", (0, 0, -0.0845), [Dof("z", Z, -2.09, 2.09)],
            shoulder, "shoulder", 0.6, upper_arm, upper_arm, side,
        )
        b.chain(
            f"{side}_upper_arm", f"{side}_elbow", (0, 0, -0.1455), [Dof("y", Y, -1.57, 0.0)],
            Drive(33, 7.17, 50, 2), "elbow", 0.1, [sphere(0.035)], [], side,
        )
        forearm = [capsule(0.035, (0, 0, 0), (0, 0, -0.19))]
        b.chain(
            f"{side}_elbow", f"{side}_forearm", (0, 0, -0.0684), [Dof("z", Z, -2.96, 2.96)],
            Drive(15, 4.58, 15, 0.5), "wrist", 0.4, forearm, forearm, side,
        )
        if hands == "full":
            hand_visuals, hand_collisions = qbhand_palm(side, _HAND_FRAME)
            hand_mass = QBHAND_PALM_MASS
        else:
            hand_visuals = hand_collisions = [box((0.08, 0.03, 0.10), (0, 0, -0.05))]
            hand_mass = 0.2
        b.chain(
            f"{side}_forearm", f"{side}_hand", (0, 0, -0.2016),
            [Dof("y", Y, -0.87, 0.87), Dof("x", X, *mirror_limits(side, -0.87, 1.57))],
            Drive(7, 3.62, 15, 0.5), "wrist", hand_mass, hand_visuals, hand_collisions, side,
        )
        register_hand(b, side, "qbhand", f"{side}_hand", _HAND_FRAME)
        if hands == "full":
            add_qbhand(b, side, f"{side}_hand", _HAND_FRAME)

    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        hip = Drive(72, 9.37, 300, 10)
        b.chain(
            "sacrum", f"{side}_ilium", (0, sy * 0.051, -0.1698), [Dof("z", Z, -0.209, 0.209)],
            hip, "hip", 0.4, [sphere(0.05)], [], side,
        )
        b.chain(
            f"{side}_ilium", f"{side}_ischium", (0, sy * 0.0375, 0), [Dof("x", (-1, 0, 0), -0.436, 0.436)],
            Drive(72, 8.37, 300, 10), "hip", 0.4, [sphere(0.045)], [], side,
        )
        thigh = [capsule(0.055, (0, 0, -0.02), (0, 0, -0.32))]
        b.chain(
            f"{side}_ischium", f"{side}_thigh", (0, sy * 0.043, 0), [Dof("y", Y, -2.443, 0.436)],
            Drive(31.2, 7.85, 300, 10), "hip", 1.6, thigh, thigh, side,
        )
        shank = [capsule(0.045, (0, 0, -0.02), (0, 0, -0.34))]
        b.chain(
            f"{side}_thigh", f"{side}_shank", (0, 0, -0.34), [Dof("y", Y, 0.0, 2.443)],
            hip, "knee", 1.0, shank, shank, side,
        )
        foot = box((0.22, 0.10, 0.05), (0.03, 0, -0.06))
        corners = [sphere(0.01, (x, y, -0.075)) for x in (-0.07, 0.13) for y in (-0.04, 0.04)]
        b.chain(
            f"{side}_shank", f"{side}_foot", (0, 0, -0.36),
            [
                Dof("y", Y, -0.698, 1.309, effort=13),
                Dof("x", (-1, 0, 0), -0.331, 0.331, effort=18),
            ],
            Drive(18, 10.26, 400, 10), "ankle", 0.6, [foot], corners, side,
        )

    standing = mirrored_pose(
        lambda side: {
            f"{side}_hip_y": -0.15,
            f"{side}_knee_y": 0.30,
            f"{side}_ankle_y": -0.15,
            f"{side}_shoulder_x": pick(side, -0.1, 0.1),
            f"{side}_elbow_y": -0.2,
        }
    )
    return b.build(
        key_bodies=key_bodies("sacrum", "torso", "head"),
        standing_pose=standing,
        notes="root is the upper torso; per-link masses estimated (25.9 kg total)",
    )
