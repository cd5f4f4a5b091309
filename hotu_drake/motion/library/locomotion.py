"""Locomotion of the library: walk, jump, squat, leg stretch."""

from __future__ import annotations

import numpy as np

from hotu_drake.motion.library.planning import (
    KNEE,
    Scene,
    plan_base,
    set_joints,
    stand,
    walk_along,
)
from hotu_drake.motion.synthesis import (
    GRAVITY,
    Plan,
    Step,
    foot_tracks,
    heel_raise,
    hermite,
    keyframes,
    ramp,
)
from hotu_drake.rotations import rot_y, rot_z


def walk(sc: Scene) -> Plan:
    """Straight walk: alternating steps (six in 4.4 s), the pelvis path planned for balance, arms swinging."""
    step = 0.45 * sc.s * sc.jitter(0.06)
    step_time = 0.55 * sc.jitter(0.05)
    count = max(4, int((sc.duration - 1.0) / step_time + 0.22))
    return walk_along(sc, np.array([[0.0, 0.0, 0.0], [(count - 1) * step, 0.0, 0.0]]), step, step_time, count)


def jump(sc: Scene) -> Plan:
    """Forward jump: crouch with the arms back, swing them up, fly, land, stand."""
    s, t, body = sc.s, sc.t, sc.body
    flight = 0.42 * sc.jitter(0.05)  # ballistic: a longer clip does not fly longer
    distance = 0.3 * s * sc.jitter(0.15)
    k = sc.times(0.0, 0.45, 1.05, 1.3)
    take_off, land = k[3], k[3] + flight
    settle, up = land + 0.3 * sc.stretch, land + 0.85 * sc.stretch
    stand_z = body.sole + body.leg_length(KNEE) - 0.004 * s
    ahead = 0.04 * s
    # Pelvis x: back in the crouch, over the toes at take-off, behind the feet at landing.
    x_off, x_land = ahead + 0.07 * s, ahead + distance - 0.05 * s
    vx = (x_land - x_off) / flight
    x = hermite(
        t,
        [0, k[1], k[2], take_off, land, settle, up],
        [ahead, ahead, ahead - 0.03 * s, x_off, x_land, ahead + distance - 0.02 * s, ahead + distance],
        [0, 0, 0, vx, vx, 0, 0],
    )
    z_off = body.sole + np.sqrt(body.leg_length(0.16) ** 2 - (x_off + 0.01 * s) ** 2)
    v0 = 0.5 * GRAVITY * flight
    z = hermite(
        t,
        [0, k[1], k[2], take_off, land, settle, up],
        [stand_z, stand_z, stand_z - 0.2 * s, z_off, z_off, stand_z - 0.15 * s, stand_z],
        [0, 0, 0, v0, -v0, 0, 0],
    )
    airborne = (t > take_off) & (t < land)
    tau = t - take_off
    z = np.where(airborne, z_off + v0 * tau - 0.5 * GRAVITY * tau**2, z)
    # Feet: planted, then carried under the pelvis (legs tucked mid-air), planted again.
    phase = np.clip((t - take_off) / flight, 0.0, 1.0)
    tuck = 0.14 * s * np.sin(np.pi * phase) ** 2
    foot_z = np.where(airborne, z - (z_off - body.sole) + tuck, body.sole)
    foot_x = distance * ramp(t, take_off, land)
    feet = {}
    for side, w in (("left", sc.width), ("right", -sc.width)):
        feet[side] = (np.column_stack([foot_x, np.full_like(t, w), foot_z]), rot_z(np.zeros_like(t)))
    pitch = keyframes(t, [0, k[1], k[2], take_off, land, settle, up], [0, 0, 0.3, 0.05, 0.1, 0.25, 0])
    plan = Plan(fps=sc.fps, pelvis=np.column_stack([x, np.zeros_like(t), z]), pelvis_rot=rot_y(pitch), feet=feet)
    arm_keys = [
        0,
        k[1],
        k[2] - 0.15 * sc.stretch,
        take_off + 0.05 * sc.stretch,
        take_off + 0.25 * sc.stretch,
        land,
        settle,
        up,
    ]
    shoulder = keyframes(t, arm_keys, [0, 0, 0.8, -1.6, -2.2, -1.2, -0.5, 0])
    set_joints(
        plan,
        left_shoulder_y=shoulder,
        right_shoulder_y=shoulder,
        left_elbow_y=keyframes(t, arm_keys, [-0.25, -0.25, -0.15, -0.3, -0.3, -0.5, -0.6, -0.25]),
        right_elbow_y=keyframes(t, arm_keys, [-0.25, -0.25, -0.15, -0.3, -0.3, -0.5, -0.6, -0.25]),
        torso_y=keyframes(t, arm_keys, [0, 0, 0.35, 0.0, -0.05, 0.1, 0.3, 0]),
        neck_y=keyframes(t, arm_keys, [0, 0, -0.3, 0.0, 0.0, -0.1, -0.3, 0]),
    )
    return plan


def squat(sc: Scene) -> Plan:
    """Two deep squats, arms raised forward for balance, heels down."""
    t, s = sc.t, sc.s
    depth = 0.36 * s * sc.jitter(0.08)
    d = keyframes(t, sc.times(0.0, 0.4, 1.4, 1.8, 2.7, 3.0, 4.0, 4.4), [0, 0, 1, 1, 0, 0, 1, 1])
    feet = foot_tracks(t, sc.body, stand(sc), [])
    base = plan_base(sc, feet, drop=depth * d, shift=np.column_stack([-0.15 * s * d, 0 * d]), pitch=0.3 * d)
    set_joints(
        base.plan,
        torso_y=0.25 * d,
        neck_y=-0.45 * d,
        left_shoulder_y=-1.45 * d,
        right_shoulder_y=-1.45 * d,
        left_shoulder_x=0.12 - 0.05 * d,
        right_shoulder_x=-0.12 + 0.05 * d,
        left_elbow_y=-0.25 + 0.15 * d,
        right_elbow_y=-0.25 + 0.15 * d,
    )
    return base.plan


def leg_stretch(sc: Scene) -> Plan:
    """A forward lunge on the right leg, then a side lunge to the left."""
    t, s, w = sc.t, sc.s, sc.width
    lunge = 0.62 * s * sc.jitter(0.06)
    side = 0.3 * s * sc.jitter(0.08)
    k = sc.times(0.3, 0.9, 1.0, 1.9, 2.5, 3.2, 3.3, 3.9, 4.0, 4.6, 5.3, 5.8, 6.4, 6.5, 7.0)
    steps = [
        Step("right", k[0], k[1], (lunge, -w, 0.0), 0.06),
        Step("right", k[5], k[7], (0.0, -w, 0.0), 0.06),
        Step("left", k[8], k[9], (0.0, w + side, 0.0), 0.05),
        Step("left", k[12], k[14], (0.0, w, 0.0), 0.05),
    ]
    feet = foot_tracks(t, sc.body, stand(sc), steps)
    fwd = keyframes(t, [k[2], k[3], k[4], k[5]], [0, 1, 1, 0])
    lat = keyframes(t, [k[9], k[10], k[11], k[12]], [0, 1, 1, 0])
    feet["left"] = heel_raise(feet["left"], 0.55 * fwd, sc.body)
    base = plan_base(
        sc,
        feet,
        drop=0.2 * s * fwd + 0.16 * s * lat,
        shift=np.column_stack([0 * lat, 0.3 * side * lat]),
        pitch=-0.05 * fwd + 0.2 * lat,
        sway=0.02,
        sigma=0.12,
    )
    set_joints(
        base.plan,
        torso_x=-0.2 * lat,
        torso_y=-0.05 * fwd + 0.1 * lat,
        left_shoulder_y=-2.9 * fwd,
        right_shoulder_y=-2.9 * fwd,
        left_shoulder_x=0.12 + 1.3 * lat,
        right_shoulder_x=-0.12 - 1.3 * lat,
        left_elbow_y=-0.25 + 0.15 * (fwd + lat),
        right_elbow_y=-0.25 + 0.15 * (fwd + lat),
        neck_y=-0.15 * fwd,
    )
    return base.plan
