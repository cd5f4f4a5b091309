"""Unitree H1: 25 body DoF (torso yaw and Rofunc's 3-DoF wrists included) + 58 fingers.

Numbers from the facts sheet (sources H1a-H1d): 1.8 m, 51.4 kg (H1a
masses). At q = 0 the legs are straight, arms down and forearms point
forward; the qb SoftHands continue the forearms (fingers along +x).

PD gains are H1d's for the arms. H1d's leg gains (hip 150 / 2, knee
200 / 4, ankle 40 / 2, torso 300 / 6) are tuned for a balancing policy; here
they are doubled, and the ankles raised to 800 / 20, the least measured to
hold the standing pose with PD alone (with 2x margin on hips and knees).
"""

from __future__ import annotations

import numpy as np

from hotu_drake.embodiment.builder import Dof, Drive, SpecBuilder, key_bodies, mirror_limits, mirrored_pose
from hotu_drake.embodiment.hands import QBHAND_PALM_MASS, HandFrame, add_qbhand, qbhand_palm, register_hand
from hotu_drake.embodiment.spec import SIDES, EmbodimentSpec, box, capsule, cylinder, sphere

X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
# Hand frame z (fingers) -> world +x, palm normal +y, thumb on top.
_HAND_FRAME = HandFrame(np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]))


def _drive(effort: float, velocity: float, kp: float, kd: float) -> Drive:
    # H1a: joint damping 1, armature 0.1 on every body joint.
    return Drive(effort, velocity, kp, kd, armature=0.1, damping=1.0)


def build(hands: str = "full") -> EmbodimentSpec:
    b = SpecBuilder("h1", "Unitree H1", hands)
    pelvis = capsule(0.05, (0, -0.10, -0.05), (0, 0.10, -0.05))
    b.root("pelvis", 5.39, "pelvis", [pelvis], [pelvis])
    torso_visuals = [
        box((0.14, 0.20, 0.44), (0, 0, 0.25)),
        capsule(0.06, (0.05, 0, 0.60), (0.05, 0, 0.68)),
        sphere(0.073, (0.045, 0, 0.68)),
    ]
    b.chain(
        "pelvis", "torso", (0, 0, 0), [Dof("z", Z, -2.35, 2.35)],
        _drive(200, 23, 600, 12), "torso", 17.789, torso_visuals, [torso_visuals[0], torso_visuals[2]],
    )
    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        b.chain(
            "torso", f"{side}_shoulder_pitch_link", (0.0055, sy * 0.1554, 0.43),
            [Dof("y", (0.0, 0.906, sy * 0.423), -2.87, 2.87)],
            _drive(40, 9, 150, 2), "shoulder", 1.033, [sphere(0.045)], [], side,
        )
        roll = [capsule(0.04, (0, 0, 0), (0, 0, -0.09))]
        b.chain(
            f"{side}_shoulder_pitch_link", f"{side}_shoulder_roll_link", (-0.0055, sy * 0.0582, 0.0089),
            [Dof("x", X, *mirror_limits(side, -3.11, 0.34))],
            _drive(40, 9, 150, 2), "shoulder", 0.793, roll, [], side,
        )
        upper_arm = [capsule(0.03, (0, 0, 0.0), (0.0185, 0, -0.198))]
        b.chain(
            f"{side}_shoulder_roll_link", f"{side}_upper_arm", (0, 0, -0.1343),
            [Dof("z", Z, *mirror_limits(side, -4.45, 1.3))],
            _drive(18, 20, 150, 2), "shoulder", 0.839, upper_arm, upper_arm, side,
        )
        forearm = [capsule(0.025, (0, 0, 0), (0.28, 0, -0.015)), sphere(0.033, (0.28, 0, -0.015))]
        b.chain(
            f"{side}_upper_arm", f"{side}_forearm", (0.0185, 0, -0.198),
            [Dof("y", Y, -1.25, 2.61)], _drive(18, 20, 100, 2), "elbow", 0.669, forearm, forearm[:1], side,
        )
        if hands == "full":
            hand_visuals, hand_collisions = qbhand_palm(side, _HAND_FRAME)
            hand_mass = QBHAND_PALM_MASS
        else:  # the real H1 ends in a small rubber hand (est.)
            hand_visuals = hand_collisions = [sphere(0.035, (0.03, 0, 0))]
            hand_mass = 0.3
        b.chain(
            f"{side}_forearm", f"{side}_hand", (0.30, 0, -0.02),
            [
                Dof("x", X, -1.57, 1.57),
                Dof("y", Y, -1.57, 1.57),
                Dof("z", Z, -1.57, 1.57),
            ],
            Drive(50, 10, 100, 10, armature=0.01), "wrist", hand_mass, hand_visuals, hand_collisions, side,
        )
        register_hand(b, side, "qbhand", f"{side}_hand", _HAND_FRAME)
        if hands == "full":
            add_qbhand(b, side, f"{side}_hand", _HAND_FRAME)

    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        b.chain(
            "pelvis", f"{side}_hip_yaw_link", (0, sy * 0.0875, -0.1742),
            [Dof("z", Z, -0.43, 0.43)], _drive(200, 23, 300, 4), "hip", 2.244,
            [cylinder(0.06, 0.07, (-0.067, 0, 0), Z)], [], side,
        )
        b.chain(
            f"{side}_hip_yaw_link", f"{side}_hip_roll_link", (0.0395, 0, 0),
            [Dof("x", X, -0.43, 0.43)], _drive(200, 23, 300, 4), "hip", 2.232,
            [cylinder(0.05, 0.06, (0, 0, 0), X)], [], side,
        )
        thigh = [capsule(0.05, (0, 0, -0.03), (0, 0, -0.37))]
        b.chain(
            f"{side}_hip_roll_link", f"{side}_thigh", (0, sy * 0.1154, 0),
            [Dof("y", Y, -1.57, 1.57)], _drive(200, 23, 300, 4), "hip", 4.152, thigh, thigh, side,
        )
        shank = [capsule(0.025, (0.02, 0, 0), (0.02, 0, -0.40)), sphere(0.05, (0, 0, -0.115))]
        b.chain(
            f"{side}_thigh", f"{side}_shank", (0, 0, -0.4),
            [Dof("y", Y, -0.26, 2.05)], _drive(300, 14, 400, 8), "knee", 1.721, shank, shank[:1], side,
        )
        foot_visuals = [
            capsule(0.014, (-0.035, 0, -0.056), (0.02, 0, -0.045)),
            capsule(0.014, (0.02, 0, -0.045), (0.115, 0, -0.056)),
            capsule(0.014, (0.14, -0.03, -0.056), (0.14, 0.03, -0.056)),
        ]
        corners = [sphere(0.014, (x, y, -0.056)) for x in (-0.035, 0.14) for y in (-0.03, 0.03)]
        b.chain(
            f"{side}_shank", f"{side}_foot", (0, 0, -0.4),
            [Dof("y", Y, -0.87, 0.52)], _drive(40, 9, 800, 20), "ankle", 0.446, foot_visuals, corners, side,
        )

    standing = mirrored_pose(
        lambda side: {f"{side}_hip_y": -0.1, f"{side}_knee_y": 0.3, f"{side}_ankle_y": -0.2}
    )
    return b.build(
        key_bodies=key_bodies("pelvis", "torso", "torso"),
        standing_pose=standing,
        notes="H1a masses; wrist joints and qb SoftHands as in Rofunc's H1 (H1c)",
    )
