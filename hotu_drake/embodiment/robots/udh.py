"""The unified digital human (UDH): 34 body DoF + 2 x 29 qb SoftHand fingers.

Numbers from the facts sheet (sources R1, R2): a 1.61 m, about 51 kg
human. `height` scales every length; mass scales with height cubed unless
given; efforts and gains scale with mass x length so a taller UDH stands
the same way.

PD gains are R1's for the arms, neck and wrists. R1's stance gains (torso
600 / 60, hip and knee 300 / 30, ankle 200 / 20) are tuned for a balancing
policy in Isaac Gym; here torso, hips and knees are doubled and the ankles
quadrupled (800 / 80): with ankles at 2x the UDH falls after the 0.1 m
drop with PD alone.
"""

from __future__ import annotations

import numpy as np

from hotu_drake.embodiment.builder import Dof, Drive, SpecBuilder, key_bodies, mirror_limits, mirrored_pose, pick
from hotu_drake.embodiment.hands import QBHAND_PALM_MASS, HandFrame, add_qbhand, qbhand_palm, register_hand
from hotu_drake.embodiment.spec import SIDES, EmbodimentSpec, box, capsule, sphere

NOMINAL_HEIGHT = 1.61
NOMINAL_MASS = 48.9  # body without hands (calc from R1 densities)
X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
# qb SoftHand mounted at the wrist, turned so the fingers point down (-z)
# and the palm faces the body.
_HAND_FRAME = HandFrame(np.diag([-1.0, 1.0, -1.0]))


def build(hands: str = "full", height: float = NOMINAL_HEIGHT, mass: float | None = None) -> EmbodimentSpec:
    """The UDH sized to `height` metres (and `mass` kg of body, no hands)."""
    if not 0.5 <= height <= 2.5:
        raise ValueError(f"UDH height must be within 0.5-2.5 m, got {height}")
    s = height / NOMINAL_HEIGHT
    body_mass = NOMINAL_MASS * s**3 if mass is None else mass
    if body_mass <= 0:
        raise ValueError("UDH mass must be positive")
    m = body_mass / NOMINAL_MASS  # mass scale
    k = m * s  # torque scale

    def L(*v: float) -> tuple[float, ...]:
        return tuple(s * x for x in v)

    def drive(effort: float, kp: float, kd: float, armature: float) -> Drive:
        return Drive(effort=effort * k, velocity=10.0, kp=kp * k, kd=kd * k, armature=armature * k)

    b = SpecBuilder("udh", "Unified digital human", hands)
    b.root(
        "pelvis",
        10.0 * m,
        "pelvis",
        [sphere(0.09 * s, L(0, 0, 0.07)), sphere(0.07 * s, L(0, 0, 0.205))],
        [sphere(0.09 * s, L(0, 0, 0.07))],
    )
    torso_shapes = [
        sphere(0.11 * s, L(0, 0, 0.12)),
        capsule(0.045 * s, L(-0.01, 0.03, 0.24), L(-0.024, 0.12, 0.2435)),
        capsule(0.045 * s, L(-0.01, -0.03, 0.24), L(-0.024, -0.12, 0.2435)),
    ]
    b.chain(
        "pelvis", "torso", L(0, 0, 0.2362),
        [Dof("x", X, -1.047, 1.047), Dof("y", Y, -1.047, 1.571), Dof("z", Z, -0.873, 0.873)],
        drive(125, 1200, 120, 0.025), "torso", 12.01 * m, torso_shapes, torso_shapes[:1],
    )
    head = [sphere(0.095 * s, L(0, 0, 0.175))]
    b.chain(
        "torso", "head", L(0, 0, 0.2239),
        [Dof("x", X, -0.873, 0.873), Dof("y", Y, -0.698, 1.047), Dof("z", Z, -0.785, 0.785)],
        drive(20, 50, 5, 0.017), "neck", 3.88 * m, head, head,
    )
    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        upper_arm = [capsule(0.045 * s, L(0, 0, -0.05), L(0, 0, -0.23))]
        b.chain(
            "torso", f"{side}_upper_arm", L(-0.0241, sy * 0.1831, 0.2435),
            [
                Dof("x", X, *mirror_limits(side, -3.142, 0.785)),
                Dof("y", Y, -3.142, 1.047),
                Dof("z", Z, *mirror_limits(side, -1.571, 1.571)),
            ],
            drive(70, 200, 20, 0.02), "shoulder", 1.5 * m, upper_arm, upper_arm, side,
        )
        forearm = [capsule(0.04 * s, L(0, 0, -0.0525), L(0, 0, -0.1875))]
        b.chain(
            f"{side}_upper_arm", f"{side}_forearm", L(0, 0, -0.2748),
            [Dof("y", Y, -2.793, 0.0)], drive(60, 150, 15, 0.015),
            "elbow", 1.0 * m, forearm, forearm, side,
        )
        if hands == "full":
            hand_visuals, hand_collisions = qbhand_palm(side, _HAND_FRAME)
            hand_mass = QBHAND_PALM_MASS
        else:
            hand_visuals = hand_collisions = [sphere(0.04 * s, L(0, 0, -0.04))]
            hand_mass = 0.5 * m
        b.chain(
            f"{side}_forearm", f"{side}_hand", L(0, 0, -0.2589),
            [Dof("x", X, -1.571, 1.571), Dof("y", Y, -1.571, 1.571), Dof("z", Z, -1.571, 1.571)],
            drive(50, 100, 10, 0.003), "wrist", hand_mass, hand_visuals, hand_collisions, side,
        )
        register_hand(b, side, "qbhand", f"{side}_hand", _HAND_FRAME)
        if hands == "full":
            add_qbhand(b, side, f"{side}_hand", _HAND_FRAME)

    for side in SIDES:
        sy = 1.0 if side == "left" else -1.0
        thigh = [capsule(0.055 * s, L(0, 0, -0.06), L(0, 0, -0.36))]
        b.chain(
            "pelvis", f"{side}_thigh", L(0, sy * 0.0849, 0),
            [
                Dof("x", X, *mirror_limits(side, -1.047, 0.262)),
                Dof("y", Y, -2.443, 1.047),
                Dof("z", Z, *mirror_limits(side, -1.047, 0.611)),
            ],
            drive(125, 600, 60, 0.02), "hip", 4.5 * m, thigh, thigh, side,
        )
        shin = [capsule(0.05 * s, L(0, 0, -0.045), L(0, 0, -0.355))]
        b.chain(
            f"{side}_thigh", f"{side}_shin", L(0, 0, -0.4215),
            [Dof("y", Y, 0.0, 2.793)], drive(100, 600, 60, 0.02), "knee", 3.0 * m, shin, shin, side,
        )
        foot_box = box(L(0.177, 0.09, 0.055), L(0.045, 0, -0.0225))
        corners = [
            sphere(0.01 * s, L(x, y, -0.04))
            for x in (-0.033, 0.123)
            for y in (-0.035, 0.035)
        ]
        b.chain(
            f"{side}_shin", f"{side}_foot", L(0, 0, -0.4099),
            [Dof("x", X, -0.524, 0.524), Dof("y", Y, -0.960, 0.960), Dof("z", Z, -0.698, 0.698)],
            drive(50, 800, 80, 0.01), "ankle", 1.0 * m, [foot_box], corners, side,
        )

    standing = mirrored_pose(
        lambda side: {
            f"{side}_hip_y": -0.15,
            f"{side}_knee_y": 0.30,
            f"{side}_ankle_y": -0.15,
            f"{side}_shoulder_x": pick(side, -0.12, 0.12),
            f"{side}_elbow_y": -0.25,
        }
    )
    return b.build(
        key_bodies=key_bodies("pelvis", "torso", "head"),
        standing_pose=standing,
        notes=f"height {height:.3f} m, body mass {body_mass:.2f} kg (no hands)",
    )
