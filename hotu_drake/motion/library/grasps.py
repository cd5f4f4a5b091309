"""The grasp set: the right hand taking an object off a table, holding it up and putting it back.

The method pre-trains its hand group on hand-only grasp data before the
whole body learns (its section III-C, DAIL's partial datasets). This is
that data, generated: `hand_grasp@<seed>` draws one object of the grasp set
(`objects.GRASP_OBJECTS`: boxes, cans and balls at YCB sizes, and the drill)
and where it stands on the table, then plans the reach, the approach along
the palm's normal, the fingers closing around it, the lift, the hold, the
lowering and the release. Boxes, cans and balls are taken from above (palm
down, fingers round the front, the thumb round the back: from the side, a
tall thin box was tipped over by the fingers pressing low and the thumb
high, 0 of 6 held), the drill by its grip. The whole body moves (a lean over the table, the
hips back to keep the weight over the feet), so the same clips serve a
whole-body controller (`bench grasps`); a hand group trained on them sees
only the fingers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hotu_drake.motion.library.planning import Base, Scene, plan_base, set_hand_shape, set_joints, stand, yaw_pose
from hotu_drake.motion.synthesis import HandTarget, Plan, foot_tracks, hand_rotation, keyframes, ramp
from hotu_drake.objects import GRASP_OBJECTS, TABLE_TOP, resting_height
from hotu_drake.rotations import rot_z

# Where the grasp set's objects stand and how far they go up. Stated once: the library draws its clips
# from these and the grasp evaluation the same objects and poses.
GRASP_RANGES: dict[str, tuple[float, float]] = {
    "distance": (0.30, 0.40),  # m ahead of the ankles: the object's centre
    "offset": (-0.22, -0.10),  # m to the side (the right hand's)
    "yaw": (-0.4, 0.4),  # rad about the vertical, from facing the person
    "lift": (0.10, 0.20),  # m the object is lifted
}
# The table's top centre (x, y; m): one place for every grasp, so that an environment welds it once. Its near
# edge 0.24 m ahead of the ankles, 6-16 cm short of the objects' centres.
GRASP_TABLE = (0.54, -0.16)
# The qb SoftHand closed round an object, from its forward kinematics in the hand landmark's frame (the middle
# knuckle; along the fingers, out of the palm, across from the index to the little finger): at (0.6, 0.5, 0.7)
# of grip, thumb flexion and opposition the fingertips reach (+1.4, +5.0) cm along and out, the thumb's tip
# (-3.3, +6.7) cm, 3.2 cm to the index side; the palm's face is 2.5 cm out. An object centred 1 cm behind the
# knuckles, its near face on the palm, lies between them: the fingers press it from the front, the thumb from
# behind. The closure the hand is sent to is past that (`GRASP_CLOSURE`), so that its PD presses.
PALM_FACE = 0.025  # m
CENTRE_ALONG = -0.01  # m along the fingers, from the knuckles to the object's centre (behind them)
# m across, the same: between the thumb's tip and the fingers (the thumb closes 3.2 cm to
# the index side of the middle finger, and a golf ball under the middle finger was rolled off by the fingers alone)
CENTRE_ACROSS = -0.016
GRASP_CLOSURE = (0.85, 0.8, 0.8)  # grip, thumb flexion, opposition (fractions of their ranges)
# Key times (s, nominal): reach from `REACH` to the pre-grasp at `APPROACH`, on the object at `CLOSE`, closed
# at `LIFT`, lifted by `HOLD`, held until `LOWER`, down at `OPEN`, open at `RETREAT`, back at `DONE`.
REACH, APPROACH, CLOSE, LIFT, HOLD, LOWER, OPEN, RETREAT, DONE = 0.3, 1.3, 1.7, 2.3, 3.0, 4.0, 4.7, 5.1, 5.7
APPROACH_DISTANCE = 0.08  # m the hand comes in from, along its palm's normal ...
# ... and from this far above: the reach from beside the thigh comes over the table's edge (hanging fingers swept
# into it from 2 cm above: the whole-body controller's hand stopped 14 cm short, a finger pressed on the table).
APPROACH_HEIGHT = 0.08
TURN_SHARE = 0.35  # the hand has turned its fingers from hanging to the grasp's in this share of the reach ...
REACH_ARC = 0.25  # m ... and its path bends toward a point this high above the table, over the hanging hand


@dataclass(frozen=True)
class GraspTask:
    """One grasp of the set: the object (`objects.GRASP_OBJECTS`), its centre
    on the table (x, y, z; for the drill its grip's centre), its yaw and how
    high it is lifted (m)."""

    kind: str
    position: tuple[float, float, float]
    yaw: float
    lift: float


@dataclass(frozen=True)
class GraspShape:
    """How the right hand takes an object, in the object's frame turned by its
    yaw (x away from the person, z up): the hand landmark's position, the
    fingers' direction, the palm's normal and the fingers' closure (of their range)."""

    landmark: np.ndarray
    fingers: np.ndarray
    palm: np.ndarray
    grip: float
    thumb_flex: float
    opposition: float


def sample_grasp(rng: np.random.Generator, ranges: dict[str, tuple[float, float]] = GRASP_RANGES) -> GraspTask:
    """A grasp drawn from `ranges`: the object (uniformly from the set), then its place, yaw and lift."""
    kind = GRASP_OBJECTS[int(rng.integers(len(GRASP_OBJECTS)))]
    x, y = rng.uniform(*ranges["distance"]), rng.uniform(*ranges["offset"])
    yaw, lift = rng.uniform(*ranges["yaw"]), rng.uniform(*ranges["lift"])
    z = TABLE_TOP + resting_height(kind) + 0.002
    return GraspTask(kind, (float(x), float(y), float(z)), float(yaw), float(lift))


def grasp_shape(kind: str) -> GraspShape:
    """How the right hand takes `kind` (see `GraspShape`): from above, palm
    down, fingers forward round its front, the thumb round its back; a box
    across its thinnest side (its x). The drill by its grip."""
    if kind == "drill":  # its grip (a 2 cm radius cylinder at the frame), fingers forward round it
        return GraspShape(
            np.array([-0.015, -0.045, 0.0]), np.array([1.0, 0.0, -0.35]), np.array([0.0, 1.0, 0.0]), 0.8, 0.6, 0.7
        )
    grip, thumb_flex, opposition = GRASP_CLOSURE
    return GraspShape(
        np.array([-CENTRE_ALONG, CENTRE_ACROSS, resting_height(kind) + PALM_FACE]),  # (across: -y, palm down)
        np.array([1.0, 0.0, 0.0]),
        np.array([0.0, 0.0, -1.0]),
        grip,
        thumb_flex,
        opposition,
    )


def hand_grasp(sc: Scene) -> Plan:
    """One grasp of the set (drawn from the scene's seed): lean over the
    table, take the object, lift it, hold it, put it back, let go."""
    return grasp_object(sc, sample_grasp(sc.rng))


def grasp_object(sc: Scene, task: GraspTask) -> Plan:
    """The grasp of `task` (see the module)."""
    t, st = sc.t, sc.stretch
    reach_at, approach_at, close_at, lift_at, hold_at, lower_at, open_at, retreat_at, done_at = (
        np.array([REACH, APPROACH, CLOSE, LIFT, HOLD, LOWER, OPEN, RETREAT, DONE]) * st
    )
    start = np.array(task.position)
    shape = grasp_shape(task.kind)
    feet = foot_tracks(t, sc.body, stand(sc), [])
    # The lean over the table: more for a far or low object (the hand landmark's height below the shoulder's reach).
    depth = float(np.clip(0.7 + (start[0] - 0.30) / 0.2 + (0.80 - start[2]) / 0.2, 0.5, 1.2))
    lean = depth * keyframes(t, [reach_at, approach_at, retreat_at, done_at], [0, 1, 1, 0])
    base = plan_base(sc, feet, drop=0.03 * sc.s * lean, pitch=0.25 * lean + 0.03, sigma=0.2)
    plan = base.plan
    plan.centred = True
    # The object: on the table, lifted with the hand, held, put back where it was.
    up = ramp(t, lift_at, hold_at) * (1.0 - ramp(t, lower_at, open_at))
    position = start + up[:, None] * np.array([0.0, 0.0, task.lift])
    plan.objects[task.kind] = yaw_pose(position, np.full(len(t), task.yaw))
    table = np.array([*GRASP_TABLE, TABLE_TOP])
    plan.objects["table"] = yaw_pose(np.tile(table, (len(t), 1)), np.zeros(len(t)))
    plan.hands["right"] = _grasping_hand(sc, base, task, shape, position, t)
    # The fingers: open as the hand reaches, closed on the object, opened as it is let go.
    closed = ramp(t, close_at, lift_at) * (1.0 - ramp(t, open_at, retreat_at))
    set_hand_shape(
        plan,
        "right",
        np.repeat((0.05 + (shape.grip - 0.05) * closed)[:, None], 4, 1),
        0.1 + (shape.thumb_flex - 0.1) * closed,
        0.2 + (shape.opposition - 0.2) * closed,
    )
    plan.contacts[f"right_hand_{task.kind}"] = (t >= close_at + 0.1 * st) & (t <= open_at)
    set_joints(plan, torso_y=0.35 * lean, neck_y=-0.1 * lean + 0.3 * ramp(t, reach_at, approach_at))
    return plan


def _grasping_hand(
    sc: Scene, base: Base, task: GraspTask, shape: GraspShape, position: np.ndarray, t: np.ndarray
) -> HandTarget:
    """The right hand: from hanging beside the thigh to the pre-grasp (back
    along the palm's normal and a little above), in to the object, with it
    while it is held, and back out the way it came."""
    st = sc.stretch
    turn = rot_z(np.full(len(t), task.yaw))
    on = position + np.einsum("tij,j->ti", turn, shape.landmark)
    clear = -APPROACH_DISTANCE * shape.palm + np.array([0.0, 0.0, APPROACH_HEIGHT])
    away = on + np.einsum("tij,j->ti", turn, clear)
    reach = ramp(t, REACH * st, APPROACH * st) * (1.0 - ramp(t, RETREAT * st, DONE * st))
    # The hand turns its fingers forward in the first part of the reach (back down in the last part of the
    # return), the arm given over to the hand's target as fast, and arcs up over the table's edge (a hanging
    # hand swept into it: the fingers hit its edge).
    early = (REACH + TURN_SHARE * (APPROACH - REACH)) * st
    turned = ramp(t, REACH * st, early) * (1.0 - ramp(t, DONE * st - (early - REACH * st), DONE * st))
    inside = ramp(t, APPROACH * st, CLOSE * st) * (1.0 - ramp(t, OPEN * st, RETREAT * st))
    rest = base.point(sc.body.rest_hand["right"])
    goal = away + inside[:, None] * (on - away)
    r, w = reach[:, None], turned[:, None]
    fingers = (1 - w) * base.vector([0.0, 0.0, -1.0]) + w * np.einsum("tij,j->ti", turn, shape.fingers)
    palm = (1 - w) * base.vector([0.0, 1.0, 0.0]) + w * np.einsum("tij,j->ti", turn, shape.palm)
    # A quadratic Bezier from beside the thigh to the pre-grasp, its control point high over the table's edge.
    over = 0.5 * (rest + away)
    over[:, 0], over[:, 2] = rest[:, 0], TABLE_TOP + REACH_ARC
    elbow = base.vector([-0.3, -0.6, -0.8])
    return HandTarget(
        (1 - r) ** 2 * rest + 2 * r * (1 - r) * over + r**2 * goal, hand_rotation("right", fingers, palm), elbow, turned
    )
