"""The procedural demonstration library: the method's motion vocabulary,
generated on the unified digital human, so demos and tests need no download.

Each motion is planned in task space (pelvis, ankles, hand landmarks,
objects; see `hotu_drake.motion.synthesis`) and solved into UDH joint
angles with closed-form limb IK, so planted feet stay still and hands sit
on the objects they hold. `generate_udh` returns the UDH clip, `generate`
the human clip (its landmarks), `generate_library` writes `.npz` files.

Objects (poses x y z + w x y z, world frame):

- ``box``: a 0.3 m cube, pose of its centre, axes along its faces.
- ``drill``: pose of the centre of its grip (handle); x along the barrel,
  z up the handle; the grip centre sits 0.11 m above the resting surface.
- ``table`` (drill clip only, static): centre of the table top, 0.6 m deep
  (x) by 0.8 m wide (y); its height scales with the UDH (0.72 m nominal).

Contacts: ``left_foot`` and ``right_foot`` (sole within 1 cm of the floor
and the foot slower than 0.1 m/s) in every clip, plus hand-object contacts
(``left_hand_box``, ``right_hand_box``, ``right_hand_drill``) while held.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from hotu_drake import embodiment
from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.kinematics import batch_link_poses
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import human_clip
from hotu_drake.motion.rotations import finite_difference, matrix_to_quat
from hotu_drake.motion.synthesis import (
    GRAVITY,
    SIDES,
    Body,
    HandTarget,
    Plan,
    Step,
    bezier_path,
    finger_joints,
    foot_tracks,
    hand_rotation,
    heel_raise,
    hermite,
    keyframes,
    path_steps,
    pelvis_over_feet,
    ramp,
    reachable_height,
    realize,
    rot_x,
    rot_y,
    rot_z,
    stance_pose,
)
from hotu_drake.motion.udh_skeleton import udh_landmarks

MOTIONS: tuple[str, ...] = (
    "walk",
    "jump",
    "squat",
    "leg_stretch",
    "boxing",
    "finger_motions",
    "handshake",
    "kungfu",
    "wave",
    "slap",
    "thumbs_up",
    "box_carry",
    "drill_grasp",
)
# Nominal durations (s); `duration=` stretches or shortens a motion.
DURATIONS: dict[str, float] = {
    "walk": 4.4,
    "jump": 2.6,
    "squat": 4.6,
    "leg_stretch": 7.0,
    "boxing": 4.6,
    "finger_motions": 6.0,
    "handshake": 4.2,
    "kungfu": 7.4,
    "wave": 4.0,
    "slap": 3.0,
    "thumbs_up": 3.6,
    "box_carry": 11.8,
    "drill_grasp": 5.4,
}
BOX_SIZE = 0.3
DRILL_GRIP_HEIGHT = 0.11
CONTACT_HEIGHT = 0.01  # m: a sole this close to the floor ...
CONTACT_SPEED = 0.1  # m/s: ... and moving this slowly is in contact
_KNEE = 0.2  # knee bend (rad) of a straight-ish supporting leg


@lru_cache(maxsize=1)
def _default_udh() -> Embodiment:
    return embodiment.load("udh", hands="full")


@dataclass
class _Scene:
    """What every motion planner gets: the body, the time grid, a seeded RNG."""

    body: Body
    fps: float
    duration: float
    stretch: float  # duration / nominal duration: key times are multiplied by it
    rng: np.random.Generator

    @cached_property
    def t(self) -> np.ndarray:
        """Sample times (s)."""
        return np.arange(int(round(self.duration * self.fps)) + 1) / self.fps

    @property
    def s(self) -> float:
        return self.body.scale

    @property
    def width(self) -> float:
        """Half the distance between the ankles in a normal stance."""
        return self.body.hip_width

    def jitter(self, amount: float) -> float:
        """A factor 1 +- `amount`, drawn from the scene's seeded RNG."""
        return 1.0 + amount * self.rng.uniform(-1.0, 1.0)

    def times(self, *keys: float) -> np.ndarray:
        return np.asarray(keys, dtype=float) * self.stretch


# --- shared planning helpers -----------------------------------------------------


def _stand(sc: _Scene) -> dict:
    """Both feet side by side at the origin, facing +x."""
    return stance_pose(0.0, 0.0, 0.0, sc.width)


def _heading_frame(heading: np.ndarray, local: np.ndarray) -> np.ndarray:
    """World vectors (T, 3) of `local` (T, 3) or (3,) given in the heading frame."""
    return np.einsum("tij,tj->ti", rot_z(heading), np.broadcast_to(local, (len(heading), 3)))


@dataclass
class _Base:
    """A plan's lower body and pelvis, before arms, hands and objects."""

    plan: Plan
    heading: np.ndarray  # (T,) heading of the body (no pelvis twist)

    def point(self, local: np.ndarray) -> np.ndarray:
        """World (T, 3) of points given relative to the pelvis in the heading frame."""
        return self.plan.pelvis + _heading_frame(self.heading, local)

    def vector(self, local: np.ndarray) -> np.ndarray:
        return _heading_frame(self.heading, np.asarray(local, dtype=float))


def _base(
    sc: _Scene,
    feet: dict,
    *,
    drop: np.ndarray | float = 0.0,
    shift: np.ndarray | None = None,
    pitch: np.ndarray | float = 0.0,
    twist: np.ndarray | float = 0.0,
    roll: np.ndarray | float = 0.0,
    sway: float = 0.0,
    sigma: float = 0.15,
) -> _Base:
    """Pelvis over the feet: `drop` metres below the highest comfortable
    height, `shift` (T, 2) in the heading frame, tilted by `pitch`, `roll`
    and turned by `twist` relative to the heading."""
    n = len(sc.t)
    xy, heading = pelvis_over_feet(feet, sc.body, sc.fps, sigma, sway * sc.s)
    if shift is not None:
        xy = xy + _heading_frame(heading, np.column_stack([shift, np.zeros(n)]))[:, :2]
    rot = rot_z(heading + twist) @ rot_y(np.broadcast_to(pitch, n)) @ rot_x(np.broadcast_to(roll, n))
    z = reachable_height(xy, rot, feet, sc.body, _KNEE, sc.fps) - drop
    plan = Plan(fps=sc.fps, pelvis=np.column_stack([xy, z]), pelvis_rot=rot, feet=feet)
    return _Base(plan, heading)


def _set_hand_shape(plan: Plan, side: str, grip, thumb_flex, opposition) -> None:
    """Finger trajectories from closure fractions (see `finger_joints`)."""
    n = plan.num_frames
    grip = np.broadcast_to(np.asarray(grip, dtype=float).reshape(n, -1), (n, 4))
    plan.joints.update(finger_joints(side, grip, np.broadcast_to(thumb_flex, n), np.broadcast_to(opposition, n)))


def _set(plan: Plan, **joints) -> None:
    """Direct joint trajectories (scalars are broadcast)."""
    n = plan.num_frames
    for name, values in joints.items():
        plan.joints[name] = np.broadcast_to(np.asarray(values, dtype=float), (n,)).copy()


def _arm_swing(base: _Base, step: float) -> None:
    """Arms swinging opposite to the legs, shoulders counter-rotating the pelvis."""
    feet = base.plan.feet
    forward = np.column_stack([np.cos(base.heading), np.sin(base.heading)])
    lead = np.sum((feet["left"][0][:, :2] - feet["right"][0][:, :2]) * forward, axis=1) / step
    swing = 0.4 * lead
    _set(
        base.plan,
        left_shoulder_y=swing,
        right_shoulder_y=-swing,
        left_elbow_y=-0.3 - 0.35 * np.maximum(-swing, 0.0),
        right_elbow_y=-0.3 - 0.35 * np.maximum(swing, 0.0),
        torso_z=0.1 * lead,
    )


def _hand_target(base: _Base, side: str, local_pos, fingers, palm, elbow, weight=1.0) -> HandTarget:
    """A hand target given in the pelvis-heading frame (arrays (T, 3) or (3,))."""
    n = base.plan.num_frames
    return HandTarget(
        position=base.point(np.broadcast_to(local_pos, (n, 3))),
        rotation=hand_rotation(side, base.vector(np.broadcast_to(fingers, (n, 3))), base.vector(palm)),
        elbow=base.vector(np.broadcast_to(elbow, (n, 3))),
        weight=np.broadcast_to(np.asarray(weight, dtype=float), (n,)),
    )


def _yaw_pose(position: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(T, 7) object poses from positions and yaw angles."""
    yaw = np.broadcast_to(yaw, (len(position),))
    quat = np.column_stack([np.cos(yaw / 2), np.zeros((len(yaw), 2)), np.sin(yaw / 2)])
    return np.column_stack([position, quat])


def _fist(plan: Plan, side: str, amount=1.0) -> None:
    """Close a hand into a fist by `amount` (0..1, scalar or (T,))."""
    amount = np.asarray(amount, dtype=float)
    _set_hand_shape(plan, side, np.repeat(np.atleast_1d(0.95 * amount)[:, None], 4, 1), 0.6 * amount, 0.7 * amount)


# --- locomotion ------------------------------------------------------------------


def _walk(sc: _Scene) -> Plan:
    """Straight walk: alternating steps (six in 4.4 s), pelvis bobbing, arms swinging."""
    step = 0.45 * sc.s * sc.jitter(0.06)
    step_time = 0.55 * sc.jitter(0.05)
    count = max(4, int((sc.duration - 1.0) / step_time + 0.22))
    path = np.array([[0.0, 0.0, 0.0], [(count - 1) * step, 0.0, 0.0]])
    steps, _ = path_steps(path, "right", 0.4, step_time, 0.78 * step_time, count, sc.width)
    feet = foot_tracks(sc.t, sc.body, _stand(sc), steps)
    base = _base(sc, feet, sway=0.025, sigma=0.4 * step_time, pitch=0.04)
    _arm_swing(base, step)
    _set(base.plan, neck_y=-0.04)
    return base.plan


def _jump(sc: _Scene) -> Plan:
    """Forward jump: crouch with the arms back, swing them up, fly, land, stand."""
    s, t, body = sc.s, sc.t, sc.body
    flight = 0.42 * sc.jitter(0.05)  # ballistic: a longer clip does not fly longer
    distance = 0.3 * s * sc.jitter(0.15)
    k = sc.times(0.0, 0.45, 1.05, 1.3)
    take_off, land = k[3], k[3] + flight
    settle, up = land + 0.3 * sc.stretch, land + 0.85 * sc.stretch
    stand_z = body.sole + body.leg_length(_KNEE) - 0.004 * s
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
    _set(
        plan,
        left_shoulder_y=shoulder,
        right_shoulder_y=shoulder,
        left_elbow_y=keyframes(t, arm_keys, [-0.25, -0.25, -0.15, -0.3, -0.3, -0.5, -0.6, -0.25]),
        right_elbow_y=keyframes(t, arm_keys, [-0.25, -0.25, -0.15, -0.3, -0.3, -0.5, -0.6, -0.25]),
        torso_y=keyframes(t, arm_keys, [0, 0, 0.35, 0.0, -0.05, 0.1, 0.3, 0]),
        neck_y=keyframes(t, arm_keys, [0, 0, -0.3, 0.0, 0.0, -0.1, -0.3, 0]),
    )
    return plan


def _squat(sc: _Scene) -> Plan:
    """Two deep squats, arms raised forward for balance, heels down."""
    t, s = sc.t, sc.s
    depth = 0.36 * s * sc.jitter(0.08)
    d = keyframes(t, sc.times(0.0, 0.4, 1.4, 1.8, 2.7, 3.0, 4.0, 4.4), [0, 0, 1, 1, 0, 0, 1, 1])
    feet = foot_tracks(t, sc.body, _stand(sc), [])
    base = _base(sc, feet, drop=depth * d, shift=np.column_stack([-0.15 * s * d, 0 * d]), pitch=0.3 * d)
    _set(
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


def _leg_stretch(sc: _Scene) -> Plan:
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
    feet = foot_tracks(t, sc.body, _stand(sc), steps)
    fwd = keyframes(t, [k[2], k[3], k[4], k[5]], [0, 1, 1, 0])
    lat = keyframes(t, [k[9], k[10], k[11], k[12]], [0, 1, 1, 0])
    feet["left"] = heel_raise(feet["left"], 0.55 * fwd, sc.body)
    base = _base(
        sc,
        feet,
        drop=0.2 * s * fwd + 0.16 * s * lat,
        shift=np.column_stack([0 * lat, 0.3 * side * lat]),
        pitch=-0.05 * fwd + 0.2 * lat,
        sway=0.02,
        sigma=0.12,
    )
    _set(
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


# --- gestures ----------------------------------------------------------------------


def _boxing(sc: _Scene) -> Plan:
    """Orthodox guard; alternating jabs and crosses, the torso turning into each."""
    t, s, w = sc.t, sc.s, sc.width
    steps = [
        Step("left", *sc.times(0.2, 0.6), (0.17 * s, w + 0.02 * s, 0.35), 0.05),
        Step("right", *sc.times(0.55, 0.95), (-0.13 * s, -w - 0.03 * s, 0.45), 0.05),
    ]
    feet = foot_tracks(t, sc.body, _stand(sc), steps)
    bounce = 0.012 * s * (1 - np.cos(2 * np.pi * 2.2 * t)) * ramp(t, *sc.times(0.9, 1.2))
    base = _base(sc, feet, drop=0.05 * s + bounce, twist=-0.1)
    guard = ramp(t, *sc.times(0.2, 0.9))
    punches = []
    spacing = max(0.55 * sc.stretch, 0.5)  # a punch takes 0.46 s, however long the clip
    n = max(2, int((sc.duration - 1.1 * sc.stretch - 0.6) / spacing) + 1)
    for i in range(n):
        start = 1.1 * sc.stretch + spacing * i + 0.04 * sc.rng.uniform(-1, 1)
        punches.append(("left" if i % 2 == 0 else "right", start))
    plan = base.plan
    twist = np.zeros_like(t)
    for hand in SIDES:
        out = np.zeros_like(t)
        for side, start in punches:
            if side == hand:
                out = np.maximum(out, keyframes(t, [start, start + 0.16, start + 0.23, start + 0.46], [0, 1, 1, 0]))
        sign = 1.0 if hand == "left" else -1.0
        twist += -sign * (0.12 if hand == "left" else 0.3) * out
        rest = sc.body.rest_hand[hand]
        on_guard = np.array([0.28, sign * 0.13, 0.43]) * s
        strike = np.array([0.6, sign * 0.06, 0.33]) * s
        pos = (1 - guard)[:, None] * rest + guard[:, None] * (on_guard + out[:, None] * (strike - on_guard))
        up = guard * (1 - out)
        fingers = (1 - guard)[:, None] * np.array([0.0, 0.0, -1.0]) + up[:, None] * np.array([0.6, -sign * 0.2, 0.8])
        fingers = fingers + out[:, None] * np.array([1.0, 0.0, -0.2])
        palm = (1 - out)[:, None] * np.array([0.0, -sign * 1.0, 0.0]) + out[:, None] * np.array([0.0, 0.0, -1.0])
        elbow = (1 - out)[:, None] * np.array([-0.2, sign * 0.4, -1.0]) + out[:, None] * np.array([0.0, sign, -0.3])
        plan.hands[hand] = _hand_target(base, hand, pos, fingers, palm, elbow, guard)
        _fist(plan, hand, guard)
    _set(plan, torso_z=0.3 * guard + twist, neck_z=-0.3 * guard - 0.8 * twist, neck_y=0.1 * guard, torso_y=0.1 * guard)
    return plan


def _finger_motions(sc: _Scene) -> Plan:
    """Hands raised in front; each finger curls and straightens in turn, then fists."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, _stand(sc), [])
    base = _base(sc, feet)
    plan = base.plan
    up = keyframes(t, sc.times(0.0, 0.3, 0.9, 5.3, 5.9), [0, 0, 1, 1, 0])
    for side in SIDES:
        sign = 1.0 if side == "left" else -1.0
        lag = 0.12 * sc.stretch * sc.jitter(0.5) if side == "right" else 0.0
        curls = []
        for i in range(5):  # thumb, index, middle, ring, little
            start = (1.0 + 0.55 * i) * sc.stretch + lag
            curls.append(keyframes(t, [start, start + 0.3, start + 0.4, start + 0.7], [0, 1, 1, 0]))
        fist = keyframes(t, sc.times(3.9, 4.2, 4.4, 4.7, 4.9, 5.2) + lag, [0, 1, 1, 0.1, 1, 0])
        grip = np.maximum(np.stack(curls[1:], 1), fist[:, None])
        _set_hand_shape(plan, side, grip, np.maximum(curls[0], 0.8 * fist), np.maximum(curls[0], 0.6 * fist) * 0.9)
        pos = np.array([0.3 * sc.jitter(0.05), sign * 0.2, 0.45 * sc.jitter(0.04)]) * s
        plan.hands[side] = _hand_target(base, side, pos, [1.0, 0.0, 1.0], [-1.0, -sign, 0.0], [0.0, 0.0, -1.0], up)
    _set(plan, neck_y=0.35 * up)
    return plan


def _handshake(sc: _Scene) -> Plan:
    """Right hand out, grip, three pumps, release, back."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, _stand(sc), [])
    base = _base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.2, 1.5, 2.8, 3.1, 4.0)
    reach = keyframes(t, [k[0], k[1], k[4], k[5]], [0, 1, 1, 0])
    grip = keyframes(t, [k[1], k[2], k[3], k[4]], [0, 1, 1, 0])
    pump_phase = np.clip((t - k[2]) / (k[3] - k[2]), 0.0, 1.0)
    pump = 0.04 * s * sc.jitter(0.2) * np.sin(2 * np.pi * 3 * pump_phase) * np.sin(np.pi * pump_phase)
    reach_to = np.array([0.42 * sc.jitter(0.05), -0.1 * sc.jitter(0.2), 0.16 * sc.jitter(0.15)]) * s
    pos = reach_to + np.column_stack([0 * t, 0 * t, pump])
    plan.hands["right"] = _hand_target(
        base, "right", pos, [1.0, 0.0, -0.25], [0.0, 1.0, 0.0], [-0.3, -0.3, -1.0], reach
    )
    _set_hand_shape(plan, "right", np.repeat((0.05 + 0.55 * grip)[:, None], 4, 1), 0.1 + 0.4 * grip, 0.2 + 0.3 * grip)
    _set(plan, torso_y=0.08 * reach, neck_y=0.1 * reach, torso_z=0.1 * reach)
    return plan


def _kungfu(sc: _Scene) -> Plan:
    """Horse stance with chambered fists, three punches, then a front push kick."""
    t, s, w, body = sc.t, sc.s, sc.width, sc.body
    wide = 0.22 * s * sc.jitter(0.1)
    k = sc.times(0.3, 0.8, 4.0, 4.5, 5.0, 5.4, 5.8, 6.1, 6.6)
    steps = [Step("left", k[0], k[1], (0.0, w + wide, 0.0), 0.06), Step("left", k[2], k[3], (0.0, w, 0.0), 0.06)]
    feet = foot_tracks(t, body, _stand(sc), steps)
    stance = keyframes(t, [k[0], k[1], k[2], k[3]], [0, 1, 1, 0])
    kick = keyframes(t, [k[4] - 0.35 * sc.stretch, k[4], k[8], k[8] + 0.35 * sc.stretch], [0, 1, 1, 0])
    # Weight over the left foot before the right one leaves the floor.
    shift = np.column_stack([-0.02 * s * kick, (w + 0.02 * s) * kick])
    base = _base(sc, feet, drop=0.16 * s * stance + 0.03 * s * kick, shift=shift, pitch=-0.25 * kick, sigma=0.12)
    plan = base.plan
    # The kick: chamber, extend (heel first, toes up), chamber, set down.
    kick_keys = [k[4], k[5], k[6], k[7], k[8]]
    ax = keyframes(t, kick_keys, [0.0, 0.2 * s, 0.7 * s, 0.2 * s, 0.0])
    az = keyframes(t, kick_keys, [0.0, 0.26 * s, 0.4 * s, 0.26 * s, 0.0])
    ap = keyframes(t, kick_keys, [0.0, 0.25, -0.35, 0.25, 0.0])
    right, rot = feet["right"]
    plan.feet["right"] = (right + np.column_stack([ax, 0 * ax, az]), rot @ rot_y(ap))
    strikes = {"right": [1.5, 3.1], "left": [2.3]}
    twist = np.zeros_like(t)
    for side in SIDES:
        sign = 1.0 if side == "left" else -1.0
        out = np.zeros_like(t)
        for start in strikes[side]:
            start = start * sc.stretch
            out = np.maximum(out, keyframes(t, [start, start + 0.2, start + 0.38, start + 0.75], [0, 1, 1, 0]))
        twist += -sign * 0.35 * out
        chamber = np.array([0.12, sign * 0.2, 0.22]) * s
        strike = np.array([0.62, sign * 0.04, 0.33]) * s
        pos = chamber + out[:, None] * (strike - chamber)
        fingers = np.array([1.0, 0.0, -0.2])
        palm = (1 - out)[:, None] * np.array([0.0, -sign, 1.0]) + out[:, None] * np.array([0.0, 0.0, -1.0])
        elbow = (1 - out)[:, None] * np.array([-1.0, 0.0, -0.3]) + out[:, None] * np.array([0.0, sign, -0.3])
        plan.hands[side] = _hand_target(base, side, pos, fingers, palm, elbow, stance)
        _fist(plan, side, np.maximum(stance, 0.3 * kick))
    _set(
        plan,
        torso_z=twist,
        neck_z=-twist,
        left_shoulder_x=0.12 + 0.5 * kick,
        right_shoulder_x=-0.12 - 0.4 * kick,
        left_elbow_y=-0.25 - 1.2 * kick,
        right_elbow_y=-0.25 - 1.2 * kick,
        torso_y=0.12 * kick,
    )
    return plan


def _wave(sc: _Scene) -> Plan:
    """Right forearm up, palm forward, hand swinging side to side."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, _stand(sc), [])
    base = _base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.0, 3.2, 3.9)
    raised = keyframes(t, k, [0, 1, 1, 0])
    cycles = 4 + int(sc.rng.integers(0, 2))
    phase = np.clip((t - k[1]) / (k[2] - k[1]), 0.0, 1.0)
    angle = 0.35 * np.sin(2 * np.pi * cycles * phase) * np.sin(np.pi * phase) ** 0.5
    elbow_point = np.array([0.06, -0.42, 0.42]) * s
    reach = 0.39 * s
    direction = np.column_stack([0.12 + 0 * angle, -np.sin(angle), np.cos(angle)])
    pos = elbow_point + reach * direction / np.linalg.norm(direction, axis=1, keepdims=True)
    plan.hands["right"] = _hand_target(base, "right", pos, direction, [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], raised)
    _set_hand_shape(plan, "right", np.full((len(t), 4), 0.05), 0.05, 0.1)
    _set(plan, torso_x=0.06 * raised, neck_z=-0.15 * raised)
    return plan


# Slap keys (pelvis-heading frame): hand landmark / scale (the first and last
# are the hanging arm's), finger direction, palm normal.
_SLAP = np.array(
    [
        [[0.02, -0.21, -0.02], [0.2, -0.2, -1.0], [0.0, 1.0, 0.0]],  # arm down
        [[0.05, -0.5, 0.52], [0.3, -0.3, 1.0], [0.3, 1.0, 0.0]],  # wound up beside the head
        [[-0.02, -0.52, 0.55], [0.3, -0.3, 1.0], [0.3, 1.0, 0.0]],  # cocked back
        [[0.45, -0.08, 0.5], [0.8, 0.1, 0.6], [-0.3, 1.0, 0.0]],  # impact, palm first
        [[0.3, 0.25, 0.4], [0.6, 0.6, 0.3], [-0.8, 0.6, 0.0]],  # follow through
        [[0.25, 0.1, 0.2], [0.5, 0.3, -0.6], [-0.5, 0.6, 0.0]],  # recover
        [[0.02, -0.21, -0.02], [0.2, -0.2, -1.0], [0.0, 1.0, 0.0]],  # arm down
    ]
)


def _slap(sc: _Scene) -> Plan:
    """Wind up to the right, a fast open-hand swing across, follow through."""
    t, s = sc.t, sc.s
    step = Step("left", *sc.times(0.25, 0.6), (0.12 * s, sc.width, 0.1), 0.04)
    feet = foot_tracks(t, sc.body, _stand(sc), [step])
    base = _base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.0, 1.3, 1.45, 1.65, 2.3, 2.9)
    keys = _SLAP[:, 0] * s * np.array([1.0, 1.0, sc.jitter(0.08)])
    keys[[0, -1]] = sc.body.rest_hand["right"]
    pos = keyframes(t, k, keys)
    fingers, palm = keyframes(t, k, _SLAP[:, 1]), keyframes(t, k, _SLAP[:, 2])
    weight = keyframes(t, [k[0], k[1], k[5], k[6]], [0, 1, 1, 0])
    plan.hands["right"] = _hand_target(base, "right", pos, fingers, palm, [-0.3, -0.5, -1.0], weight)
    _set_hand_shape(plan, "right", np.full((len(t), 4), 0.05), 0.05, 0.05)
    twist = keyframes(t, k, [0, -0.35, -0.4, 0.1, 0.35, 0.15, 0])
    _set(plan, torso_z=twist, neck_z=-0.8 * twist)
    return plan


def _thumbs_up(sc: _Scene) -> Plan:
    """Right fist forward at chest height, thumb up, a short push, back."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, _stand(sc), [])
    base = _base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.0, 1.4, 1.7, 2.6, 3.3)
    raised = keyframes(t, [k[0], k[1], k[4], k[5]], [0, 1, 1, 0])
    push = keyframes(t, [k[1], k[2], k[3], k[4]], [0, 1, 1, 0.6])
    height = 0.36 * sc.jitter(0.08)
    pos = np.column_stack([(0.32 + 0.08 * push) * s, np.full_like(t, -0.14 * s), (height + 0.03 * push) * s])
    plan.hands["right"] = _hand_target(
        base, "right", pos, [1.0, 0.0, -0.1], [0.0, 1.0, 0.0], [-0.3, -0.4, -1.0], raised
    )
    _set_hand_shape(plan, "right", np.repeat((0.98 * raised)[:, None], 4, 1), np.zeros_like(t), 0.05 * raised)
    _set(plan, neck_y=0.05 * raised, torso_z=0.1 * raised)
    return plan


# --- human-object motions ----------------------------------------------------------


def _walk_to(sc: _Scene, start_pose, end_pose, t0: float, count: int, first: str = "right"):
    """`count` footsteps from the stance at `start_pose` to the stance at `end_pose`."""
    step_time = 0.52 * sc.stretch
    path = bezier_path(start_pose, end_pose)
    return path_steps(path, first, t0, step_time, 0.78 * step_time, count, sc.width)


def _walking_arms(sc: _Scene, base: _Base, weight: np.ndarray) -> None:
    """Arm swing while walking, faded out where `weight` (T,) says the arms are busy."""
    _arm_swing(base, 0.42 * sc.s)
    free = 1.0 - weight
    for name in ("left_shoulder_y", "right_shoulder_y", "torso_z"):
        base.plan.joints[name] = base.plan.joints[name] * free
    for name in ("left_elbow_y", "right_elbow_y"):
        base.plan.joints[name] = -0.25 + (base.plan.joints[name] + 0.25) * free


def _reach_target(
    base: _Base, side: str, reach: np.ndarray, grasp: tuple, elbow, weight: np.ndarray, body: Body
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


def _box_carry(sc: _Scene) -> Plan:
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
    feet = foot_tracks(t, sc.body, _stand(sc), walk1 + walk2)
    crouch = keyframes(t, [g[0], g[1], g[4], g[5], p[0], p[1], p[4], p[5]], [0, 1, 1, 0, 0, 1, 1, 0])
    base = _base(
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
    plan.objects["box"] = _yaw_pose(box_pos, box_yaw)
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
        _set_hand_shape(plan, side, np.repeat((0.05 + 0.45 * grip)[:, None], 4, 1), 0.1 + 0.3 * grip, 0.3 * grip)
        plan.contacts[f"{side}_hand_box"] = touching
    _set(plan, torso_y=0.75 * crouch, neck_y=-0.55 * crouch)
    return plan


def _drill_grasp(sc: _Scene) -> Plan:
    """Walk to a table, reach for the drill on it, close the hand on its grip, lift it."""
    t, s, rng = sc.t, sc.s, sc.rng
    st = sc.stretch
    table_height = 0.72 * s
    drill_yaw = 0.15 * rng.uniform(-1, 1)
    stance = (1.2 * s * sc.jitter(0.08), 0.1 * rng.uniform(-1, 1), 0.0)
    walk, arrive = _walk_to(sc, (0.0, 0.0, 0.0), stance, 0.4 * st, 4)
    heading0 = stance[2]
    forward = np.array([np.cos(heading0), np.sin(heading0), 0.0])
    left = np.array([-np.sin(heading0), np.cos(heading0), 0.0])
    grip0 = np.array([*stance[:2], table_height + DRILL_GRIP_HEIGHT]) + 0.4 * s * forward - 0.2 * s * left
    table = np.array([*stance[:2], table_height]) + (0.4 * s + 0.12) * forward - 0.2 * s * left
    g = arrive + np.array([0.1, 1.0, 1.25, 1.6, 2.6]) * st  # lean + reach, close, lift
    feet = foot_tracks(t, sc.body, _stand(sc), walk)
    lean = keyframes(t, [g[0], g[1], g[3], g[4]], [0, 1, 1, 0.3])
    base = _base(sc, feet, drop=0.06 * s * lean, pitch=0.2 * lean + 0.04, sway=0.02, sigma=0.2)
    plan = base.plan
    carried = base.point(np.array([0.36 * s, -0.17 * s, 0.28 * s]))
    lift = ramp(t, g[2] + 0.1 * st, g[4])
    drill_pos = grip0 + lift[:, None] * (carried - grip0)
    drill_yaw = drill_yaw + lift * (base.heading - drill_yaw)
    plan.objects["drill"] = _yaw_pose(drill_pos, drill_yaw)
    plan.objects["table"] = _yaw_pose(np.tile(table, (len(t), 1)), np.full(len(t), heading0))
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
    _set_hand_shape(plan, "right", np.repeat((0.05 + 0.75 * grip)[:, None], 4, 1), 0.1 + 0.5 * grip, 0.2 + 0.5 * grip)
    plan.contacts["right_hand_drill"] = t >= g[1] + 0.05 * st
    _set(plan, torso_y=0.3 * lean, neck_y=-0.1 * lean + 0.25 * reach, torso_z=0.15 * lean)
    return plan


_PLANNERS: dict[str, Callable[[_Scene], Plan]] = {
    "walk": _walk,
    "jump": _jump,
    "squat": _squat,
    "leg_stretch": _leg_stretch,
    "boxing": _boxing,
    "finger_motions": _finger_motions,
    "handshake": _handshake,
    "kungfu": _kungfu,
    "wave": _wave,
    "slap": _slap,
    "thumbs_up": _thumbs_up,
    "box_carry": _box_carry,
    "drill_grasp": _drill_grasp,
}


# --- clips -------------------------------------------------------------------------


def _foot_contacts(udh: Embodiment, body: Body, poses: dict, fps: float) -> dict[str, np.ndarray]:
    """Floor contact per foot: sole within 1 cm of the floor and the foot
    (its link origin, the ankle) moving slowly, so a foot rolling onto its
    toes to push off is already out of contact."""
    out = {}
    for side in SIDES:
        rot, pos = poses[udh.key_bodies[f"{side}_foot"]]
        points = pos[:, None, :] + np.einsum("tij,kj->tki", rot, body.foot_points)
        height = points[..., 2].min(axis=1) - body.foot_radius
        speed = np.linalg.norm(finite_difference(pos, fps), axis=1)
        out[f"{side}_foot"] = (height < CONTACT_HEIGHT) & (speed < CONTACT_SPEED)
    return out


def _to_clip(udh: Embodiment, body: Body, plan: Plan, name: str) -> MotionClip:
    q = realize(body, plan)
    fps = plan.fps
    quat = matrix_to_quat(plan.pelvis_rot)
    poses = batch_link_poses(udh.spec, udh.joint_names, q, plan.pelvis_rot, plan.pelvis)
    key_links = list(udh.key_bodies.values())
    contacts = _foot_contacts(udh, body, poses, fps) | plan.contacts
    objects = list(plan.objects)
    return MotionClip.from_positions(
        "udh",
        f"hotu_drake/library/{name}",
        fps,
        udh.joint_names,
        q,
        plan.pelvis.copy(),
        quat,
        key_links,
        np.stack([poses[link][1] for link in key_links], axis=1),
        part_index={part: list(joints) for part, joints in udh.parts.items()},
        object_names=objects,
        object_poses=np.stack([plan.objects[o] for o in objects], axis=1) if objects else None,
        contact_names=list(contacts),
        contacts=np.stack(list(contacts.values()), axis=1),
    )


def generate_udh(
    name: str, *, seed: int = 0, fps: float = 30.0, duration: float | None = None, udh: Embodiment | None = None
) -> MotionClip:
    """The library motion `name` on the UDH (92 joints with full hands).

    `seed` varies step lengths, timings and object placements (the same
    seed gives identical arrays); `duration` (s) stretches the motion.
    """
    if name not in _PLANNERS:
        raise ValueError(f"unknown motion {name!r}; choose from {', '.join(MOTIONS)}")
    if fps <= 0:
        raise ValueError("fps must be positive")
    nominal = DURATIONS[name]
    duration = nominal if duration is None else float(duration)
    if not 0.5 * nominal <= duration <= 3.0 * nominal:
        raise ValueError(f"{name}: duration must be within {0.5 * nominal:.1f}-{3 * nominal:.1f} s")
    udh = _default_udh() if udh is None else udh
    if udh.name != "udh":
        raise ValueError("the library is generated on the UDH")
    body = Body.of(udh)
    scene = _Scene(body, float(fps), duration, duration / nominal, np.random.default_rng(seed))
    return _to_clip(udh, body, _PLANNERS[name](scene), name)


def generate(name: str, *, seed: int = 0, fps: float = 30.0, duration: float | None = None) -> MotionClip:
    """The library motion `name` as a human demonstration (landmarks, objects, contacts)."""
    udh = _default_udh()
    clip = generate_udh(name, seed=seed, fps=fps, duration=duration, udh=udh)
    return human_clip(
        udh_landmarks(udh, clip),
        clip.fps,
        source=f"hotu_drake/library/{name}",
        object_names=clip.object_names,
        object_poses=clip.object_poses,
        contact_names=clip.contact_names,
        contacts=clip.contacts,
    )


def generate_library(out_dir: str | Path, names: Iterable[str] = MOTIONS, seed: int = 0) -> list[Path]:
    """Write `<name>.npz` human clips for `names` into `out_dir`; returns the paths."""
    out_dir = Path(out_dir)
    return [generate(name, seed=seed).save(out_dir / f"{name}.npz") for name in names]
