"""Human-object motions of the library: carrying a box, grasping a drill from a table."""

from __future__ import annotations

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
    box_rot = rot_z(box_yaw)
    for side in SIDES:
        sign = 1.0 if side == "left" else -1.0
        on_face = np.array([-0.03, sign * (half + 0.02), 0.04])
        away = np.array([-0.03, sign * (half + 0.12), 0.14])
        local = away + approach[:, None] * (on_face - away)
        fingers = np.array([np.sin(0.5), 0.0, -np.cos(0.5)])
        grasp = (box_pos, box_rot, local, fingers, np.array([0.0, -sign, 0.0]))
        plan.hands[side] = _reach_target(base, side, reach, grasp, [-0.4, sign * 0.6, -0.7], busy, sc.body)
        grip = keyframes(t, [g[2] - 0.1 * st, g[3], p[2], p[3]], [0, 1, 1, 0])
        set_hand_shape(plan, side, np.repeat((0.05 + 0.45 * grip)[:, None], 4, 1), 0.1 + 0.3 * grip, 0.3 * grip)
        plan.contacts[f"{side}_hand_box"] = touching
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
    return plan
