"""CURI: a holonomic mobile base, 3-DoF torso, 2-DoF head and two Panda arms.

19 body DoF + 58 qb SoftHand fingers = 77, plus the base (x, y, yaw) which is
actuated but not counted as a body part. Numbers from the facts sheet
(C1, F1). The base is a planar joint chain to the world (the mecanum wheels
are drawn, not simulated), so the base follows commanded planar motion.
Simplification: the torso's two parallelogram mimic joints are not
modelled, so the two torso pitch joints tilt the upper body.
"""

from __future__ import annotations

import math

import numpy as np

from hotu_drake.embodiment.builder import Dof, Drive, SpecBuilder, key_bodies, mirror_axis, mirror_point, mirrored_pose
from hotu_drake.embodiment.hands import QBHAND_PALM_MASS, HandFrame, add_qbhand, qbhand_palm, register_hand
from hotu_drake.embodiment.spec import BASE_PART, SIDES, EmbodimentSpec, box, capsule, cylinder, sphere
from hotu_drake.rotations import rot_x

X, Y, Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
TORSO_END = np.array([0.4875, 0.0, 1.0026])
_M = np.diag([1.0, -1.0, 1.0])

# Panda (C1): per joint the offset in the previous frame, the rotation about
# x applied before the joint (deg), limits, effort, speed, kp, kd (F1), mass.
_PANDA = (
    ((0, 0, 0.333), 0, -2.8973, 2.8973, 87, 2.175, 600, 50, 4.971),
    ((0, 0, 0), -90, -1.7628, 1.7628, 87, 2.175, 600, 50, 0.647),
    ((0, -0.316, 0), 90, -2.8973, 2.8973, 87, 2.175, 600, 50, 3.229),
    ((0.0825, 0, 0), 90, -3.0718, -0.0698, 87, 2.175, 600, 50, 3.588),
    ((-0.0825, 0.384, 0), -90, -2.8973, 2.8973, 12, 2.61, 250, 30, 1.226),
    ((0, 0, 0), 90, -0.0175, 3.7525, 12, 2.61, 150, 25, 1.667),
    ((0.088, 0, 0), 90, -2.8973, 2.8973, 12, 2.61, 50, 15, 0.736),
)
_PANDA_PARTS = ("shoulder", "shoulder", "shoulder", "elbow", "wrist", "wrist", "wrist")
_PANDA_RADII = (0.06, 0.06, 0.06, 0.06, 0.05, 0.05, 0.05)
_FLANGE = 0.107


def left_panda_frames() -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray, np.ndarray]:
    """World joint positions, joint axes, flange position and rotation of the left arm."""
    z0 = np.array([0.255, 0.966, 0.045])
    z0 /= np.linalg.norm(z0)
    y0 = np.array([-0.737, 0.224, -0.638])  # the j2 axis at zero (facts, calc)
    y0 -= (y0 @ z0) * z0
    y0 /= np.linalg.norm(y0)
    rotation = np.column_stack([np.cross(y0, z0), y0, z0])
    position = TORSO_END + np.array([0.0284, 0.1122, 0.1900])
    points, axes = [], []
    for offset, rot_deg, *_ in _PANDA:
        position = position + rotation @ np.asarray(offset, dtype=float)
        rotation = rotation @ rot_x(np.radians(rot_deg))
        points.append(position)
        axes.append(rotation[:, 2].copy())
    flange = position + rotation @ np.array([0.0, 0.0, _FLANGE])
    return points, axes, flange, rotation


def build(hands: str = "full") -> EmbodimentSpec:
    b = SpecBuilder("curi", "CURI", hands)
    # Holonomic base: x, y, yaw joints from the world (est. drives).
    wheels = [
        cylinder(0.127, 0.087, (x, y, 0.127), Y) for x in (-0.2225, 0.2225) for y in (-0.2045, 0.2045)
    ]
    chassis = box((0.70, 0.50, 0.24), (0, 0, 0.137))
    control_box = box((0.55, 0.45, 0.40), (-0.05, 0, 0.457))
    column = box((0.15, 0.15, 0.24), (0.2375, 0, 0.6326))
    b.chain(
        "world", "base_y_link", (0, 0, 0),
        [
            Dof("x", X, -50.0, 50.0, kind="prismatic"),
            Dof("y", Y, -50.0, 50.0, kind="prismatic"),
        ],
        Drive(3000.0, 2.0, 1.0e4, 3.0e3), BASE_PART, 1.0, [sphere(0.02)], [], prefix="base",
    )
    b.chain(
        "base_y_link", "base", (0, 0, 0), [Dof("yaw", Z, -math.inf, math.inf)],
        Drive(1500.0, 2.0, 5.0e3, 1.5e3), BASE_PART, 125 + 26 + 37.81 + 1.18,
        [chassis, control_box, column, *wheels], [chassis, control_box],
        prefix="base",
    )
    # Without the parallelogram links the two pitch joints carry the upper
    # body's moment; the sheet's est. 2000 / 200 lets it sag 0.1 rad.
    torso = Drive(300.0, 0.3, 10000.0, 1000.0)
    b.chain(
        "base", "torso_base", (0.2375, 0, 0.7526), [Dof("z", Z, -1.57, 1.57)],
        torso, "torso", 35.66, [cylinder(0.09, 0.2, (0, 0, -0.1), Z)], [],
    )
    lift = [capsule(0.06, (0, 0, 0), (0, 0, 0.25))]
    b.chain(
        "torso_base", "torso_lift", (0, 0, 0), [Dof("y", Y, -1.2, 0.5)],
        torso, "torso", 2.698 + 1.319 + 2.688, lift, lift,
    )
    chest = [capsule(0.06, (0, 0, 0), (0.25, 0, 0)), box((0.16, 0.34, 0.30), (0.27, 0, 0.13))]
    b.chain(
        "torso_lift", "torso_end", (0, 0, 0.25), [Dof("y2", Y, -0.9, 0.9)],
        torso, "torso", 2.40 + 2.148 + 12.083 + 0.803 + 2 * 0.630, chest, chest[1:],
    )
    # The torso_end link's origin is the torso_y2 joint; the sheet's torso end
    # frame lies 0.25 m ahead of it, and the head base 0.0147 m further.
    neck = Drive(30.0, 1.0, 20.0, 1.0)
    b.chain(
        "torso_end", "head_pan_link", (0.25 + 0.0147, 0, 0.2775 + 0.045), [Dof("z", Z, -1.57, 1.57)],
        neck, "neck", 0.534, [cylinder(0.04, 0.043, (0, 0, 0.0215), Z)],
    )
    head = [sphere(0.10, (0, 0, 0.08))]
    b.chain(
        "head_pan_link", "head", (0, 0, 0.043), [Dof("y", Y, -0.82, 0.52)],
        neck, "neck", 1.346, head, head,
    )

    points, axes, flange, flange_rotation = left_panda_frames()
    hand_frame = HandFrame(_M @ flange_rotation @ _M)  # right-hand frame
    for side in SIDES:
        def world(p: np.ndarray, side: str = side) -> np.ndarray:
            return p if side == "left" else mirror_point(p)

        parent = "torso_end"
        ends = [*points[1:], flange]
        counters: dict[str, int] = {}
        for i, (row, part) in enumerate(zip(_PANDA, _PANDA_PARTS)):
            _, _, lo, hi, effort, velocity, kp, kd, mass = row
            index = counters.get(part, 0)
            counters[part] = index + 1
            start, end = world(points[i]), world(ends[i])
            axis = axes[i] if side == "left" else mirror_axis(axes[i])
            length = float(np.linalg.norm(end - start))
            shape = (
                capsule(_PANDA_RADII[i], (0, 0, 0), tuple(end - start))
                if length > 1e-3
                else sphere(_PANDA_RADII[i])
            )
            last = i == len(_PANDA) - 1
            child = f"{side}_hand" if last else f"{side}_panda_link{i + 1}"
            visuals, collisions = [shape], [shape]
            if last and hands == "full":
                hand_v, hand_c = qbhand_palm(side, hand_frame, at=end - start)
                visuals, collisions = visuals + hand_v, collisions + hand_c
                mass += QBHAND_PALM_MASS
            b.chain(
                parent, child, tuple(start - b.origin(parent)),
                [Dof(str(index), tuple(axis), lo, hi)],
                Drive(effort, velocity, kp, kd), part, mass, visuals, collisions, side,
            )
            parent = child
        register_hand(b, side, "qbhand", f"{side}_hand", hand_frame, mount=world(flange))
        if hands == "full":
            add_qbhand(b, side, f"{side}_hand", hand_frame, mount=world(flange))

    standing = mirrored_pose(
        lambda side: {
            f"{side}_shoulder_1": 0.4,
            f"{side}_elbow_0": -1.6,
            f"{side}_wrist_1": 1.6,
            f"{side}_wrist_2": 0.785,
        }
    )
    return b.build(
        key_bodies=key_bodies("base", "torso_end", "head", legs=False),
        standing_pose=standing,
        floating_base=False,
        notes="planar base (x, y, yaw); torso parallelogram mimics not modelled",
    )

