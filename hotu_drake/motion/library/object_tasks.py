"""Human-object motions of the library: carrying a box, grasping a drill from a table."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hotu_drake.embodiment.spec import SIDES
from hotu_drake.motion.library.planning import (
    Base,
    Scene,
    arm_swing,
    plan_base,
    set_hand_shape,
    set_joints,
    stand,
    yaw_pose,
)
from hotu_drake.motion.synthesis import (
    Body,
    HandTarget,
    Plan,
    bezier_path,
    foot_tracks,
    hand_rotation,
    keyframes,
    path_steps,
    ramp,
)
from hotu_drake.objects import BOX_SIZE, DRILL_BASE, TABLE_TOP
from hotu_drake.rotations import rot_z


def _walk_to(sc: Scene, start_pose, end_pose, t0: float, count: int, first: str = "right"):
    """`count` footsteps from the stance at `start_pose` to the stance at `end_pose`."""
    step_time = 0.52 * sc.stretch
    path = bezier_path(start_pose, end_pose)
    return path_steps(path, first, t0, step_time, 0.78 * step_time, count, sc.width)


def _walking_arms(sc: Scene, base: Base, weight: np.ndarray) -> None:
    """Arm swing while walking, faded out where `weight` (T,) says the arms are busy."""
    arm_swing(base, 0.42 * sc.s)
    free = 1.0 - weight
    for name in ("left_shoulder_y", "right_shoulder_y", "torso_z"):
        base.plan.joints[name] = base.plan.joints[name] * free
    for name in ("left_elbow_y", "right_elbow_y"):
        base.plan.joints[name] = -0.25 + (base.plan.joints[name] + 0.25) * free


def _reach_target(
    base: Base, side: str, reach: np.ndarray, grasp: tuple, elbow, weight: np.ndarray, body: Body
) -> HandTarget:
    """A hand going from hanging beside the thigh (`reach` 0) to a grasp on
    an object (`reach` 1); `grasp` is (object positions (T, 3), object
    rotations (T, 3, 3), hand landmark, finger direction and palm normal in
    the object frame (each (T, 3) or (3,)))."""
    obj_pos, obj_rot, local, fingers, palm = grasp
    medial = -1.0 if side == "left" else 1.0
    r = reach[:, None]
    rest = base.point(body.rest_hand[side])
    on = obj_pos + np.einsum("tij,tj->ti", obj_rot, np.broadcast_to(local, obj_pos.shape))
    fingers = (1 - r) * base.vector([0.0, 0.0, -1.0]) + r * np.einsum("tij,j->ti", obj_rot, fingers)
    palm = (1 - r) * base.vector([0.0, medial, 0.0]) + r * np.einsum("tij,j->ti", obj_rot, palm)
    return HandTarget(rest + r * (on - rest), hand_rotation(side, fingers, palm), base.vector(elbow), weight)


def _grip_drill(
    sc: Scene,
    base: Base,
    drill_pos: np.ndarray,
    drill_yaw: np.ndarray,
    g: np.ndarray,
    lean: np.ndarray,
    st: float = 1.0,
) -> None:
    """The right hand reaching for the drill from `g[0]`, onto its grip by
    `g[1]`, closed by `g[2]`; the torso leaning with `lean` (T,). `st`
    stretches the reach's durations with the motion's."""
    t, plan = sc.t, base.plan
    busy = ramp(t, g[0], g[0] + 0.3 * st)
    _walking_arms(sc, base, busy)
    reach = ramp(t, g[0], g[1] - 0.25 * st)
    approach = ramp(t, g[1] - 0.3 * st, g[1])
    on_grip = np.array([-0.015, -0.045, 0.0])
    away = np.array([-0.1, -0.1, 0.06])
    local = away + approach[:, None] * (on_grip - away)
    grasp = (drill_pos, rot_z(drill_yaw), local, np.array([1.0, 0.0, -0.35]), np.array([0.0, 1.0, 0.0]))
    plan.hands["right"] = _reach_target(base, "right", reach, grasp, [-0.3, -0.6, -0.8], busy, sc.body)
    grip = ramp(t, g[1] - 0.05 * st, g[2])
    set_hand_shape(plan, "right", np.repeat((0.05 + 0.75 * grip)[:, None], 4, 1), 0.1 + 0.5 * grip, 0.2 + 0.5 * grip)
    plan.contacts["right_hand_drill"] = t >= g[1] + 0.05 * st
    set_joints(plan, torso_y=0.3 * lean, neck_y=-0.1 * lean + 0.25 * reach, torso_z=0.15 * lean)


def _grip_box_sides(
    sc: Scene,
    base: Base,
    box_pos: np.ndarray,
    box_yaw: np.ndarray,
    reach: np.ndarray,
    approach: np.ndarray,
    grip: np.ndarray,
    touching: np.ndarray,
    busy: np.ndarray,
    gap: float,
) -> None:
    """Both hands on the box's side faces: from beside the thighs (`reach`
    0) to beside the faces (1), then onto them (`approach` 1), the hand
    landmark `gap` from the face; fingers closing with `grip` (T,), in
    contact where `touching`."""
    half = BOX_SIZE / 2
    box_rot = rot_z(box_yaw)
    for side in SIDES:
        sign = 1.0 if side == "left" else -1.0
        on_face = np.array([-0.03, sign * (half + gap), 0.04])
        away = np.array([-0.03, sign * (half + 0.12), 0.14])
        local = away + approach[:, None] * (on_face - away)
        fingers = np.array([np.sin(0.5), 0.0, -np.cos(0.5)])
        grasp = (box_pos, box_rot, local, fingers, np.array([0.0, -sign, 0.0]))
        base.plan.hands[side] = _reach_target(base, side, reach, grasp, [-0.4, sign * 0.6, -0.7], busy, sc.body)
        set_hand_shape(base.plan, side, np.repeat((0.05 + 0.45 * grip)[:, None], 4, 1), 0.1 + 0.3 * grip, 0.3 * grip)
        base.plan.contacts[f"{side}_hand_box"] = touching


def box_carry(sc: Scene) -> Plan:
    """Walk to a box on the floor, squat, grip it by its sides, lift, carry it
    along a turning path, set it down at its target pose, stand up."""
    t, s, rng = sc.t, sc.s, sc.rng
    half = BOX_SIZE / 2
    reach_offset = 0.38 * s + half  # ankle line to box centre when grasping: clear of the knees
    box_yaw0 = 0.1 * rng.uniform(-1, 1)
    box0 = np.array([1.55 * s * sc.jitter(0.05), 0.08 * rng.uniform(-1, 1), half])
    # The target is a quarter turn to the left along an arc of radius `turn`.
    turn = 1.2 * s * sc.jitter(0.08)
    box_yaw1 = box_yaw0 + 0.5 * np.pi
    box1 = box0 + rot_z(box_yaw0) @ np.array([turn - reach_offset, turn + reach_offset, 0.0])
    pick = (*(box0[:2] - reach_offset * np.array([np.cos(box_yaw0), np.sin(box_yaw0)])), box_yaw0)
    place = (*(box1[:2] - reach_offset * np.array([np.cos(box_yaw1), np.sin(box_yaw1)])), box_yaw1)
    st = sc.stretch
    walk1, arrive = _walk_to(sc, (0.0, 0.0, 0.0), pick, 0.4 * st, 4)
    g = arrive + np.array([0.1, 1.0, 1.3, 1.55, 1.85, 2.8]) * st  # squat, hands in, grip, lift, stand
    walk2, arrive2 = _walk_to(sc, pick, place, g[5] + 0.05 * st, 7, first="left")
    p = arrive2 + np.array([0.1, 1.1, 1.3, 1.45, 1.7, 2.6]) * st  # squat + lower, release, out, stand
    feet = foot_tracks(t, sc.body, stand(sc), walk1 + walk2)
    crouch = keyframes(t, [g[0], g[1], g[4], g[5], p[0], p[1], p[4], p[5]], [0, 1, 1, 0, 0, 1, 1, 0])
    base = plan_base(
        sc,
        feet,
        drop=0.42 * s * crouch,
        shift=np.column_stack([-0.12 * s * crouch, 0 * crouch]),
        pitch=0.45 * crouch + 0.04,
        sway=0.02,
        sigma=0.2,
    )
    plan = base.plan
    # The box: on the floor, lifted into the carry pose (fixed in the body's
    # heading frame), carried, lowered onto its target pose.
    carried = base.point(np.array([0.38 * s, 0.0, 0.07 * s]))
    lift, lower = ramp(t, g[3], g[5]), ramp(t, p[0], p[1])
    held = lift * (1 - lower)
    target_pos = np.where((t >= p[0])[:, None], box1, box0)
    box_pos = target_pos + held[:, None] * (carried - target_pos)
    box_yaw = np.where(t >= p[0], box_yaw1, box_yaw0)
    box_yaw = box_yaw + held * (base.heading - box_yaw)
    plan.objects["box"] = yaw_pose(box_pos, box_yaw)
    # Hands: joint-space swing while walking; then from beside the thighs
    # to beside the box faces, onto the faces, and back the same way.
    busy = keyframes(t, [g[0], g[0] + 0.3 * st, p[5] - 0.3 * st, p[5]], [0, 1, 1, 0])
    _walking_arms(sc, base, busy)
    reach = keyframes(t, [g[0] + 0.35 * st, g[1], p[4], p[5] - 0.35 * st], [0, 1, 1, 0])
    approach = keyframes(t, [g[1], g[2], p[3], p[4]], [0, 1, 1, 0])
    touching = (t >= g[2]) & (t < p[3])
    grip = keyframes(t, [g[2] - 0.1 * st, g[3], p[2], p[3]], [0, 1, 1, 0])
    _grip_box_sides(sc, base, box_pos, box_yaw, reach, approach, grip, touching, busy, gap=0.02)
    set_joints(plan, torso_y=0.75 * crouch, neck_y=-0.55 * crouch)
    return plan


def drill_grasp(sc: Scene) -> Plan:
    """Walk to a table, reach for the drill on it, close the hand on its grip, lift it."""
    t, s, rng = sc.t, sc.s, sc.rng
    st = sc.stretch
    table_height = TABLE_TOP * s
    drill_yaw = 0.15 * rng.uniform(-1, 1)
    stance = (1.2 * s * sc.jitter(0.08), 0.1 * rng.uniform(-1, 1), 0.0)
    walk, arrive = _walk_to(sc, (0.0, 0.0, 0.0), stance, 0.4 * st, 4)
    heading0 = stance[2]
    forward = np.array([np.cos(heading0), np.sin(heading0), 0.0])
    left = np.array([-np.sin(heading0), np.cos(heading0), 0.0])
    grip0 = np.array([*stance[:2], table_height + DRILL_BASE]) + 0.4 * s * forward - 0.2 * s * left
    table = np.array([*stance[:2], table_height]) + (0.4 * s + 0.12) * forward - 0.2 * s * left
    g = arrive + np.array([0.1, 1.0, 1.25, 1.6, 2.6]) * st  # lean + reach, close, lift
    feet = foot_tracks(t, sc.body, stand(sc), walk)
    lean = keyframes(t, [g[0], g[1], g[3], g[4]], [0, 1, 1, 0.3])
    base = plan_base(sc, feet, drop=0.06 * s * lean, pitch=0.2 * lean + 0.04, sway=0.02, sigma=0.2)
    plan = base.plan
    carried = base.point(np.array([0.36 * s, -0.17 * s, 0.28 * s]))
    lift = ramp(t, g[2] + 0.1 * st, g[4])
    drill_pos = grip0 + lift[:, None] * (carried - grip0)
    drill_yaw = drill_yaw + lift * (base.heading - drill_yaw)
    plan.objects["drill"] = yaw_pose(drill_pos, drill_yaw)
    plan.objects["table"] = yaw_pose(np.tile(table, (len(t), 1)), np.full(len(t), heading0))
    _grip_drill(sc, base, drill_pos, drill_yaw, g, lean, st)
    return plan


# The box carry as a task (`BoxCarry-v0`): the box floats in front of the person, to be carried to a
# target anywhere around. The ranges are stated here once; the environment draws its tasks from them
# and the library its demonstrations (`box_carry_task@<seed>`), so D_I learns the interaction the task asks.
BOX_CARRY_RANGES: dict[str, tuple[float, float]] = {
    "start_distance": (0.5, 0.8),  # m ahead of the person (its ankles' midpoint)
    "start_bearing": (-0.3, 0.3),  # rad from straight ahead
    "start_height": (0.75, 1.0),  # m, the box's centre
    "target_distance": (1.0, 3.0),
    "target_bearing": (-np.pi, np.pi),
    "target_height": (0.6, 1.0),
}
BOX_YAW_SPREAD = 0.3  # rad: the box's yaw about its bearing
# m: the UDH palm's half thickness (its 3 cm palm box): the hand landmark this far from a face it presses on.
PALM_HALF_THICKNESS = 0.015
LOWEST_STANDING_HOLD = 0.8  # m (for a 1.75 m person): a box centre lower than this is held with bent knees


@dataclass(frozen=True)
class ObjectTask:
    """One instance of an object task: the object's start (x, y, z) and yaw, and its target (x, y, z)."""

    start: tuple[float, float, float]
    start_yaw: float
    target: tuple[float, float, float]


def sample_box_carry(rng: np.random.Generator, ranges: dict[str, tuple[float, float]] = BOX_CARRY_RANGES) -> ObjectTask:
    """A box carry drawn from `ranges` (the environment's draw, in its order)."""
    d, bearing = rng.uniform(*ranges["start_distance"]), rng.uniform(*ranges["start_bearing"])
    start = (d * np.cos(bearing), d * np.sin(bearing), rng.uniform(*ranges["start_height"]))
    yaw = bearing + rng.uniform(-BOX_YAW_SPREAD, BOX_YAW_SPREAD)
    d, bearing = rng.uniform(*ranges["target_distance"]), rng.uniform(*ranges["target_bearing"])
    target = (d * np.cos(bearing), d * np.sin(bearing), rng.uniform(*ranges["target_height"]))
    return ObjectTask(tuple(float(x) for x in start), float(yaw), tuple(float(x) for x in target))


def box_carry_task(sc: Scene) -> Plan:
    """One box carry of the task's distribution (drawn from the scene's seed):
    step up to the box floating ahead, grip it by its sides, walk it to the
    target, turning to face it, bring it to the target and hold it there."""
    return carry_box(sc, sample_box_carry(sc.rng))


def carry_box(sc: Scene, task: ObjectTask) -> Plan:
    """The box carry of `task` (see `box_carry_task`)."""
    t, s = sc.t, sc.s
    half = BOX_SIZE / 2
    box0, box1 = np.array(task.start), np.array(task.target)
    yaw0 = task.start_yaw
    reach = 0.36 * s + half  # ankle line to the box's centre when gripping it at chest height
    ahead = 0.38 * s  # ankle line to the carried box's centre
    pick = (*(box0[:2] - reach * np.array([np.cos(yaw0), np.sin(yaw0)])), yaw0)
    toward = box1[:2] - np.asarray(pick[:2])
    heading1 = float(np.arctan2(toward[1], toward[0]))
    heading1 = yaw0 + float(np.angle(np.exp(1j * (heading1 - yaw0))))  # the shorter way round
    place = (*(box1[:2] - ahead * np.array([np.cos(heading1), np.sin(heading1)])), heading1)
    walk1, arrive = _walk_to(sc, (0.0, 0.0, 0.0), pick, 0.3, 2)
    g = arrive + np.array([0.1, 0.6, 0.85, 1.3])  # hands in, onto the faces, grip, into the carry
    distance = float(np.linalg.norm(np.asarray(place[:2]) - np.asarray(pick[:2])))
    count = max(3, int(distance / 0.4) + 2 + int(abs(heading1 - yaw0) / 1.2))
    walk2, arrive2 = _walk_to(sc, pick, place, g[3] + 0.05, count, first="left")
    p = arrive2 + np.array([0.1, 0.9])  # the box to its target, then held there
    feet = foot_tracks(t, sc.body, stand(sc), walk1 + walk2)
    # A box below the standing hands' reach: knees bent (and a lean) to grip it, and to hold it at its target.
    low0, low1 = (max(0.0, LOWEST_STANDING_HOLD * s - z) for z in (box0[2], box1[2]))
    bend = low0 * keyframes(t, [g[0], g[1], g[3], g[3] + 0.4], [0, 1, 1, 0]) + low1 * ramp(t, p[0], p[1])
    base = plan_base(sc, feet, drop=bend, pitch=0.04 + 1.5 * bend, sigma=0.2, balanced=True)
    plan = base.plan
    # The box: floating at its start, gripped, into the carry pose (fixed in the heading frame),
    # carried, brought to its target, held.
    carried = base.point(np.array([ahead, 0.0, 0.0]))
    carried[:, 2] = 0.5 * (box0[2] + box1[2])
    lift, settle = ramp(t, g[2], g[3]), ramp(t, p[0], p[1])
    held = lift * (1 - settle)
    box_pos = np.where((t >= p[0])[:, None], box1, box0)
    box_pos = box_pos + held[:, None] * (carried - box_pos)
    box_yaw = np.where(t >= p[0], heading1, yaw0) + held * (base.heading - np.where(t >= p[0], heading1, yaw0))
    plan.objects["box"] = yaw_pose(box_pos, box_yaw)
    busy = ramp(t, g[0], g[0] + 0.3)
    _walking_arms(sc, base, busy)
    reach_in, approach = ramp(t, g[0], g[1]), ramp(t, g[1], g[2] - 0.05)
    grip, touching = ramp(t, g[1], g[2]), t >= g[2] - 0.05
    _grip_box_sides(sc, base, box_pos, box_yaw, reach_in, approach, grip, touching, busy, gap=PALM_HALF_THICKNESS)
    return plan


# The drill grasp as a task (`DrillGrasp-v0`): a table within reach ahead, the drill on it, to be lifted.
# Stated here once; the environment draws its tasks from these, the library its demonstrations
# (`drill_grasp_task@<seed>`).
DRILL_GRASP_RANGES: dict[str, tuple[float, float]] = {
    "drill_offset": (-0.15, 0.15),  # m to the side of straight ahead
    "drill_yaw": (-0.5, 0.5),  # rad
    "lift_height": (0.15, 0.35),  # m above its resting height
}
TABLE_DISTANCE = 0.65  # m: the drill's grip ahead of the person; the table's top centre 0.15 m further
LIFT_TOWARDS = 0.15  # m: the drill's target is this much nearer the person than its start


def sample_drill_grasp(
    rng: np.random.Generator,
    ranges: dict[str, tuple[float, float]] = DRILL_GRASP_RANGES,
    table_distance: float = TABLE_DISTANCE,
) -> ObjectTask:
    """A drill grasp drawn from `ranges` (the environment's draw, in its order)."""
    y = rng.uniform(*ranges["drill_offset"])
    height = TABLE_TOP + DRILL_BASE + 0.002
    yaw = rng.uniform(*ranges["drill_yaw"])
    target = (table_distance - LIFT_TOWARDS, y, height + rng.uniform(*ranges["lift_height"]))
    return ObjectTask((float(table_distance), float(y), float(height)), float(yaw), tuple(float(x) for x in target))


def drill_grasp_task(sc: Scene) -> Plan:
    """One drill grasp of the task's distribution (drawn from the scene's
    seed): standing at the table, lean, close the right hand on the drill's
    grip, lift it to its target and hold it there."""
    return grasp_drill(sc, sample_drill_grasp(sc.rng))


def grasp_drill(sc: Scene, task: ObjectTask) -> Plan:
    """The drill grasp of `task` (see `drill_grasp_task`)."""
    t = sc.t
    start, target = np.array(task.start), np.array(task.target)
    g = np.array([0.3, 1.2, 1.45, 1.6, 2.6])  # lean + reach, close, lift, held
    feet = foot_tracks(t, sc.body, stand(sc), [])
    lean = keyframes(t, [g[0], g[1], g[3], g[4]], [0, 1, 1, 0.3])
    base = plan_base(sc, feet, drop=0.06 * sc.s * lean, pitch=0.2 * lean + 0.04, sigma=0.2)
    plan = base.plan
    lift = ramp(t, g[3], g[4])
    drill_pos = start + lift[:, None] * (target - start)
    drill_yaw = np.full(len(t), task.start_yaw)
    plan.objects["drill"] = yaw_pose(drill_pos, drill_yaw)
    table = np.array([start[0] + 0.15, 0.0, TABLE_TOP])
    plan.objects["table"] = yaw_pose(np.tile(table, (len(t), 1)), np.zeros(len(t)))
    _grip_drill(sc, base, drill_pos, drill_yaw, g, lean)
    return plan
