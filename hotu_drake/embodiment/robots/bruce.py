"""Westwood BRUCE: a 0.70 m, 4.65 kg biped with 5-DoF legs and 3-DoF arms (16 DoF).

Numbers from the facts sheet (B1-B3). At q = 0 the legs hang straight and
the arms are stretched sideways (T-pose). The files' -y pitch axes are
written as +y with converted limits, so that hip flexion is negative and
knee flexion positive as on every other embodiment. Leg limits, efforts,
speeds, gains and the line-contact feet are the sheet's estimates. BRUCE
has no fingers, so its `hands="none"` variant equals the full one.
"""

from __future__ import annotations

from hotu_drake.embodiment.builder import Dof, Drive, SpecBuilder, key_bodies, mirrored_pose, pick
from hotu_drake.embodiment.spec import SIDES, EmbodimentSpec, box, capsule, sphere

X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def build(hands: str = "full") -> EmbodimentSpec:
    b = SpecBuilder("bruce", "Westwood BRUCE", hands)
    base = [box((0.12, 0.16, 0.22), (0.02, 0, 0.07)), sphere(0.06, (0.03, 0, 0.22))]
    b.root("base", 1.317, "pelvis", base, base)
    # Sheet estimates (hips and knees 30 / 1, ankles 15 / 0.5) doubled: the
    # least measured to hold the standing pose with PD alone is 1.5x.
    leg = Drive(10.0, 15.0, 60.0, 2.0, armature=0.002)
    ankle = Drive(10.0, 15.0, 30.0, 1.0, armature=0.002)
    arm = Drive(3.0, 10.0, 5.0, 0.2, armature=0.001)
    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        b.chain(
            "base", f"{side}_hip_roll_link", (0.0292, sy * 0.0759, -0.0398),
            [Dof("z", Z, -0.6, 0.6), Dof("x", X, -0.5, 0.5)],
            leg, "hip", 0.05, [sphere(0.02)], [], side,
        )
        # The 0.638 kg hip yaw link houses the hip and knee drives; its mass
        # is carried by the thigh, which sits at the same point.
        thigh = [sphere(0.04, (0, 0, 0)), capsule(0.03, (0, 0, -0.02), (0, 0, -0.185))]
        b.chain(
            f"{side}_hip_roll_link", f"{side}_thigh", (0, 0, 0),
            [Dof("y", Y, -1.6, 0.6)], leg, "hip", 0.728 + 0.638, thigh, thigh[1:], side,
        )
        shank = [capsule(0.02, (0, 0, -0.01), (0, 0, -0.19))]
        b.chain(
            f"{side}_thigh", f"{side}_shank", (0, 0, -0.2049), [Dof("y", Y, 0.0, 2.3)],
            leg, "knee", 0.096, shank, shank, side,
        )
        foot = [capsule(0.01, (-0.05, 0, -0.025), (0.05, 0, -0.025))]
        line_contact = [sphere(0.01, (x, 0, -0.025)) for x in (-0.05, 0.05)]
        b.chain(
            f"{side}_shank", f"{side}_foot", (0, 0, -0.1999), [Dof("y", Y, -1.0, 1.0)],
            ankle, "ankle", 0.028, foot, line_contact, side,
        )
    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        b.chain(
            "base", f"{side}_shoulder_link", (0.0292, sy * 0.1238, 0.1530),
            [Dof("y", Y, -1.57, 1.57)], arm, "shoulder", 0.049, [sphere(0.02)], [], side,
        )
        upper_arm = [capsule(0.02, (0, 0, 0), (0.005, sy * 0.1146, 0.005))]
        b.chain(
            f"{side}_shoulder_link", f"{side}_upper_arm", (0, 0, 0),
            [Dof("x", X, -1.57, 1.57)], arm, "shoulder", pick(side, 0.024, 0.031), upper_arm, upper_arm, side,
        )
        forearm = [capsule(0.018, (0, 0, 0), (0, sy * 0.12, 0))]
        b.chain(
            f"{side}_upper_arm", f"{side}_hand", (0.005, sy * 0.1146, 0.005),
            [Dof("z", Z, -1.57, 1.57)], arm, "elbow", 0.052, forearm, forearm, side,
            prefix=f"{side}_elbow",
        )
    standing = mirrored_pose(
        lambda side: {
            f"{side}_hip_y": -0.35,
            f"{side}_knee_y": 0.7,
            f"{side}_ankle_y": -0.35,
            f"{side}_shoulder_x": pick(side, 1.4, -1.4),
        }
    )
    return b.build(
        key_bodies=key_bodies("base", "base", "base"),
        standing_pose=standing,
        notes="B2 masses; leg limits, drives and foot geometry estimated",
    )
