"""Building blocks for synthesising whole-body UDH motion in task space.

The procedural library plans where the pelvis, the ankles and the hands go
(`Plan`) and turns that into joint angles with closed-form limb inverse
kinematics (`realize`). Planning in task space is what keeps a planted
foot exactly still and puts a hand exactly on a box face; the joint angles
follow. Everything is vectorised over the frames.

Conventions (those of the UDH spec): link frames are world-aligned at
q = 0, x forward, y left, z up; hip flexion is negative `hip_y`, knee
flexion positive `knee_y`, elbow flexion negative `elbow_y`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.kinematics import batch_link_poses
from hotu_drake.embodiment.landmarks import landmark_placements
from hotu_drake.embodiment.spec import FINGERS, SIDES
from hotu_drake.rotations import euler_xyz_within_limits, heading_yaw, normalize, rot_x, rot_y, rot_z, wrap

GRAVITY = 9.81  # m/s^2, for ballistic phases (jumps)
ZMP_TRACKING = 1e-4  # the ZMP planner's cost of acceleration against centre-of-pressure error (Drake's: 0.1)
_EY = np.array([0.0, 1.0, 0.0])


# --- time profiles ---------------------------------------------------------------


def ease(x: np.ndarray) -> np.ndarray:
    """Minimum-jerk ramp from 0 to 1 over x in [0, 1] (clamped outside)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)


def ramp(t: np.ndarray, start: float, end: float) -> np.ndarray:
    """Smooth 0 -> 1 transition between times `start` and `end`."""
    return ease((t - start) / max(end - start, 1e-9))


def keyframes(t: np.ndarray, times, values) -> np.ndarray:
    """Pose-to-pose interpolation: minimum-jerk between consecutive keys.

    `values` is (K, ...) for the K increasing `times`; the result is
    (T, ...), held constant before the first and after the last key. Every
    key is reached at rest, which is how gestures and strikes look.
    """
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    span = np.maximum(times[i + 1] - times[i], 1e-9)
    w = ease((t - times[i]) / span).reshape((-1,) + (1,) * (values.ndim - 1))
    return values[i] + w * (values[i + 1] - values[i])


def hermite(t: np.ndarray, times, values, slopes) -> np.ndarray:
    """Piecewise cubic through (time, value, slope) knots, held outside them."""
    times, values, slopes = (np.asarray(a, dtype=float) for a in (times, values, slopes))
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    h = times[i + 1] - times[i]
    s = np.clip((t - times[i]) / h, 0.0, 1.0)
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * values[i] + h10 * h * slopes[i] + h01 * values[i + 1] + h11 * h * slopes[i + 1]


def gaussian_weights(fps: float, sigma: float) -> np.ndarray:
    """The weights (odd in length, centred, summing to 1) of a Gaussian of
    `sigma` s over frames at `fps`, cut at three deviations (one weight of 1
    below a third of a frame)."""
    radius = int(np.ceil(3.0 * sigma * fps))
    if radius < 1:
        return np.ones(1)
    k = np.exp(-0.5 * (np.arange(-radius, radius + 1) / (sigma * fps)) ** 2)
    return k / k.sum()


def smooth(x: np.ndarray, fps: float, sigma: float) -> np.ndarray:
    """Gaussian low-pass along time (axis 0), edges padded with the end values."""
    x = np.asarray(x, dtype=float)
    k = gaussian_weights(fps, sigma)
    radius = len(k) // 2
    if radius < 1:
        return x.copy()
    flat = x.reshape(len(x), -1)
    padded = np.concatenate([np.repeat(flat[:1], radius, 0), flat, np.repeat(flat[-1:], radius, 0)])
    out = np.stack([np.convolve(padded[:, j], k, mode="valid") for j in range(flat.shape[1])], axis=1)
    return out.reshape(x.shape)


# --- rotations -------------------------------------------------------------------


def hand_rotation(side: str, fingers: np.ndarray, palm: np.ndarray) -> np.ndarray:
    """World rotation of a UDH hand link whose fingers point along `fingers`
    and whose palm faces `palm` (made perpendicular to the fingers).

    At q = 0 a UDH hand hangs with the fingers down (-z), the palm facing the
    body (+y for the right hand, -y for the left) and the thumb forward.
    """
    f = normalize(np.asarray(fingers, dtype=float))
    p = np.asarray(palm, dtype=float)
    p = normalize(p - np.sum(p * f, -1, keepdims=True) * f)
    y = p if side == "right" else -p
    z = -f
    return np.stack([np.cross(y, z), y, z], axis=-1)


def limb_rotation(direction: np.ndarray, plane_axis: np.ndarray, local: np.ndarray) -> np.ndarray:
    """Rotation taking the limb-local vector `local` (in the x-z plane) to
    world `direction`, and the limb's y axis to `plane_axis`."""
    d = normalize(direction)
    y = normalize(plane_axis)
    v = normalize(local)
    world = np.stack([d, y, np.cross(d, y)], axis=-1)
    body = np.stack([v, np.broadcast_to(_EY, v.shape), np.cross(v, _EY)], axis=-1)
    return world @ np.swapaxes(body, -1, -2)


# --- the body --------------------------------------------------------------------


@dataclass(frozen=True)
class Body:
    """The UDH's segment offsets that the planner and the limb IK need."""

    scale: float
    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    standing: np.ndarray
    offsets: dict[str, np.ndarray]  # joint -> offset from its parent link (world axes at q = 0)
    sole: float  # ankle height above the sole with a flat foot
    foot_points: np.ndarray  # foot contact sphere centres in the foot frame (k, 3)
    foot_radius: float
    hand_offset: dict[str, np.ndarray]  # hand landmark in the hand link frame, per side
    rest_hand: dict[str, np.ndarray]  # hand landmark relative to the pelvis when standing

    @classmethod
    def of(cls, udh: Embodiment) -> Body:
        spec = udh.spec
        offsets = {j.name: np.asarray(j.offset, dtype=float) for j in spec.joints}
        foot = spec.link(udh.key_bodies["left_foot"])
        points = np.array([g.position for g in foot.collisions], dtype=float)
        radius = float(min(g.size[0] for g in foot.collisions))
        placements = landmark_placements(spec)
        hand_offset = {side: np.asarray(placements[f"{side}_hand"][1], dtype=float) for side in SIDES}
        standing = batch_link_poses(spec, udh.joint_names, udh.standing_pose[None])
        rest = {
            side: (standing[f"{side}_hand"][1] + standing[f"{side}_hand"][0] @ hand_offset[side])[0] for side in SIDES
        }
        return cls(
            scale=float(np.linalg.norm(offsets["left_knee_y"]) / 0.4215),
            joint_names=tuple(udh.joint_names),
            lower=udh.position_lower.copy(),
            upper=udh.position_upper.copy(),
            standing=udh.standing_pose.copy(),
            offsets=offsets,
            sole=float(radius - points[:, 2].min()),
            foot_points=points,
            foot_radius=radius,
            hand_offset=hand_offset,
            rest_hand=rest,
        )

    def index(self, name: str) -> int:
        return self.joint_names.index(name)

    def limits(self, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
        idx = [self.index(n) for n in names]
        return self.lower[idx], self.upper[idx]

    @property
    def thigh(self) -> float:
        return float(np.linalg.norm(self.offsets["left_knee_y"]))

    @property
    def shin(self) -> float:
        return float(np.linalg.norm(self.offsets["left_ankle_x"]))

    @property
    def upper_arm(self) -> float:
        return float(np.linalg.norm(self.offsets["left_elbow_y"]))

    @property
    def forearm(self) -> float:
        return float(np.linalg.norm(self.offsets["left_wrist_x"]))

    @property
    def hip_width(self) -> float:
        """Lateral distance of each hip joint from the pelvis origin."""
        return float(abs(self.offsets["left_hip_x"][1]))

    @property
    def ball(self) -> np.ndarray:
        """The point a foot rolls over (the centre of its front contact spheres)."""
        front = self.foot_points[:, 0].max()
        return np.array([front, 0.0, self.foot_points[self.foot_points[:, 0] == front, 2].mean()])

    def leg_length(self, knee: float) -> float:
        """Hip-to-ankle distance with the knee bent by `knee` radians."""
        a, b = self.thigh, self.shin
        return float(np.sqrt(a * a + b * b + 2 * a * b * np.cos(knee)))


# --- limb inverse kinematics -----------------------------------------------------


def _two_link(distance: np.ndarray, a: float, b: float, min_bend: float, max_bend: float):
    """Bend angle (>= 0) putting the chain's end `distance` from its root."""
    cos_bend = (distance**2 - a * a - b * b) / (2 * a * b)
    return np.arccos(np.clip(cos_bend, np.cos(max_bend), np.cos(min_bend)))


def _joint_angles(body: Body, names: list[str], r: np.ndarray) -> np.ndarray:
    lo, hi = body.limits(names)
    return np.clip(euler_xyz_within_limits(r, lo, hi), lo, hi)


def _euler_matrix(angles: np.ndarray) -> np.ndarray:
    return rot_x(angles[:, 0]) @ rot_y(angles[:, 1]) @ rot_z(angles[:, 2])


def leg_ik(
    body: Body, side: str, hip: np.ndarray, pelvis_rot: np.ndarray, ankle: np.ndarray, foot_rot: np.ndarray
) -> dict[str, np.ndarray]:
    """Hip, knee and ankle angles putting the ankle at `ankle` with the foot
    oriented `foot_rot`; the knee points along the foot's forward axis."""
    d = ankle - hip
    knee = _two_link(np.linalg.norm(d, axis=-1), body.thigh, body.shin, 0.02, 2.7)
    local = np.stack([-body.shin * np.sin(knee), 0 * knee, -body.thigh - body.shin * np.cos(knee)], -1)
    forward = foot_rot[:, :, 0]
    thigh_rot = limb_rotation(d, np.cross(forward, normalize(d)), local)
    names = [f"{side}_hip_{a}" for a in "xyz"]
    hip_q = _joint_angles(body, names, np.swapaxes(pelvis_rot, -1, -2) @ thigh_rot)
    shin_rot = pelvis_rot @ _euler_matrix(hip_q) @ rot_y(knee)
    ankle_names = [f"{side}_ankle_{a}" for a in "xyz"]
    ankle_q = _joint_angles(body, ankle_names, np.swapaxes(shin_rot, -1, -2) @ foot_rot)
    out = dict(zip(names, hip_q.T))
    out[f"{side}_knee_y"] = knee
    out.update(zip(ankle_names, ankle_q.T))
    return out


def arm_ik(
    body: Body,
    side: str,
    shoulder: np.ndarray,
    torso_rot: np.ndarray,
    hand: np.ndarray,
    hand_rot: np.ndarray,
    elbow_dir: np.ndarray,
) -> dict[str, np.ndarray]:
    """Shoulder, elbow and wrist angles putting the hand landmark at `hand`
    with the hand oriented `hand_rot`; the elbow points along `elbow_dir`."""
    wrist = hand - np.einsum("tij,j->ti", hand_rot, body.hand_offset[side])
    d = wrist - shoulder
    bend = _two_link(np.linalg.norm(d, axis=-1), body.upper_arm, body.forearm, 0.05, 2.7)
    elbow = -bend
    local = np.stack([body.forearm * np.sin(bend), 0 * bend, -body.upper_arm - body.forearm * np.cos(bend)], -1)
    plane = np.cross(normalize(d), normalize(np.asarray(elbow_dir, dtype=float)))
    upper_rot = limb_rotation(d, plane, local)
    names = [f"{side}_shoulder_{a}" for a in "xyz"]
    shoulder_q = _joint_angles(body, names, np.swapaxes(torso_rot, -1, -2) @ upper_rot)
    forearm_rot = torso_rot @ _euler_matrix(shoulder_q) @ rot_y(elbow)
    wrist_names = [f"{side}_wrist_{a}" for a in "xyz"]
    wrist_q = _joint_angles(body, wrist_names, np.swapaxes(forearm_rot, -1, -2) @ hand_rot)
    out = dict(zip(names, shoulder_q.T))
    out[f"{side}_elbow_y"] = elbow
    out.update(zip(wrist_names, wrist_q.T))
    return out


# --- gait ------------------------------------------------------------------------


@dataclass(frozen=True)
class Step:
    """One foot swing: lift-off at `start`, touch-down at `end` on `pose`
    (ankle x, y, yaw), clearing the floor by `height` metres. With `heel`
    > 0 the heel rises by that angle (rad) in the `heel_time` seconds
    before lift-off and a little after, the foot rolling over its ball as in
    a walking push-off."""

    side: str
    start: float
    end: float
    pose: tuple[float, float, float]
    height: float = 0.07
    heel: float = 0.0
    heel_time: float = 0.15


def foot_tracks(
    t: np.ndarray, body: Body, start: dict[str, tuple[float, float, float]], steps: list[Step]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Ankle positions (T, 3) and foot rotations (T, 3, 3) of both feet.

    A foot is still except during its steps; it lifts before it moves
    forward and lands before it stops moving down, so it never scuffs.
    """
    ball = body.ball
    out = {}
    for side in SIDES:
        x, y, yaw = (np.full(len(t), v, dtype=float) for v in start[side])
        z, pitch = np.full(len(t), body.sole), np.zeros(len(t))
        for step in sorted((s for s in steps if s.side == side), key=lambda s: s.start):
            s = np.clip((t - step.start) / (step.end - step.start), 0.0, 1.0)
            moving = t >= step.start
            if not moving.any():
                continue
            travel = ease((s - 0.12) / 0.76)
            x0, y0, yaw0 = x[moving][0], y[moving][0], yaw[moving][0]
            x[moving] = x0 + (step.pose[0] - x0) * travel[moving]
            y[moving] = y0 + (step.pose[1] - y0) * travel[moving]
            yaw[moving] = yaw0 + wrap(step.pose[2] - yaw0) * travel[moving]
            z[moving] = body.sole + step.height * np.sin(np.pi * s[moving]) ** 2
            # The heel rises until just after lift-off (the toe pushes off),
            # and the foot is flat again before mid-swing.
            peak = step.start + 0.15 * (step.end - step.start)
            rise = ease((t - step.start + step.heel_time) / (peak - step.start + step.heel_time))
            fall = ease((t - peak) / (0.45 * (step.end - step.start)))
            pitch = np.maximum(pitch, step.heel * rise * (1.0 - fall))
        # Pitching the foot about its ball: the ankle moves with it.
        flat = rot_z(yaw)
        rot = flat @ rot_y(pitch)
        ankle = np.stack([x, y, z], -1) + np.einsum("tij,j->ti", flat, ball) - np.einsum("tij,j->ti", rot, ball)
        out[side] = (ankle, rot)
    return out


def heel_raise(track: tuple[np.ndarray, np.ndarray], angle: np.ndarray, body: Body):
    """A foot track pivoted about the ball of the foot by `angle` (T,) radians,
    heel up: the back foot of a lunge, which cannot stay flat."""
    pos, rot = track
    pivot = body.ball
    ball = pos + np.einsum("tij,j->ti", rot, pivot)
    raised = rot @ rot_y(angle)
    return ball - np.einsum("tij,j->ti", raised, pivot), raised


def path_steps(
    path: np.ndarray, first: str, t0: float, step_time: float, swing: float, count: int, width: float, heel: float = 0.3
) -> tuple[list[Step], float]:
    """`count` footsteps along a planar path of (N, 3) poses (x, y, heading).

    Feet start beside the path's first pose and end beside its last one:
    `count - 1` footholds of alternating feet equally spaced along the path,
    then the trailing foot steps up beside the leading one. Returns the
    steps and the time the last one lands.
    """
    seg = np.linalg.norm(np.diff(path[:, :2], axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(1, count - 1)
    stations = np.append(np.linspace(0.0, arc[-1], n + 1)[1:], arc[-1])
    steps, side = [], first
    for i, s in enumerate(stations):
        x, y = np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])
        heading = np.interp(s, arc, np.unwrap(path[:, 2]))
        lateral = width if side == "left" else -width
        pose = (x - lateral * np.sin(heading), y + lateral * np.cos(heading), heading)
        start = t0 + i * step_time
        steps.append(Step(side, start, start + swing, pose, heel=heel if i else 0.0, heel_time=0.3 * step_time))
        side = "right" if side == "left" else "left"
    return steps, steps[-1].end


def stance_pose(x: float, y: float, heading: float, width: float) -> dict[str, tuple[float, float, float]]:
    """Both ankles beside the point (x, y) facing `heading`."""
    c, s = np.cos(heading), np.sin(heading)
    return {side: (x - w * s, y + w * c, heading) for side, w in (("left", width), ("right", -width))}


def bezier_path(start, end, n: int = 200) -> np.ndarray:
    """(n, 3) poses along a cubic Bezier from pose `start` to pose `end`
    (x, y, heading), tangent to both headings, heading along the curve."""
    p0, p3 = np.asarray(start[:2], float), np.asarray(end[:2], float)
    reach = np.linalg.norm(p3 - p0) / 3.0
    p1 = p0 + reach * np.array([np.cos(start[2]), np.sin(start[2])])
    p2 = p3 - reach * np.array([np.cos(end[2]), np.sin(end[2])])
    u = np.linspace(0.0, 1.0, n)[:, None]
    xy = (1 - u) ** 3 * p0 + 3 * (1 - u) ** 2 * u * p1 + 3 * (1 - u) * u**2 * p2 + u**3 * p3
    d = 3 * (1 - u) ** 2 * (p1 - p0) + 6 * (1 - u) * u * (p2 - p1) + 3 * u**2 * (p3 - p2)
    return np.column_stack([xy, np.unwrap(np.arctan2(d[:, 1], d[:, 0]))])


# --- the plan --------------------------------------------------------------------


@dataclass
class HandTarget:
    """Where a hand landmark goes, how the hand is turned, where the elbow
    points, and how much this overrides the joint-space arm (0..1)."""

    position: np.ndarray  # (T, 3)
    rotation: np.ndarray  # (T, 3, 3)
    elbow: np.ndarray  # (T, 3) or (3,)
    weight: np.ndarray  # (T,)


@dataclass
class Plan:
    """A whole-body motion in task space, sampled at `fps`."""

    fps: float
    pelvis: np.ndarray  # (T, 3)
    pelvis_rot: np.ndarray  # (T, 3, 3)
    feet: dict[str, tuple[np.ndarray, np.ndarray]]  # side -> ankle (T, 3), rotation (T, 3, 3)
    joints: dict[str, np.ndarray] = field(default_factory=dict)  # direct joint trajectories
    hands: dict[str, HandTarget] = field(default_factory=dict)
    objects: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (T, 7) xyz + wxyz
    contacts: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (T,) bool
    # A foot is down on every frame (a walk, not a run or a jump): a foot pushing off stays in contact
    # until the other is down (`generate`'s contacts; `planning.stepping`, which every walk plans with, sets it).
    grounded: bool = False
    # The centre of mass kept over the middle of the feet (`generate`): the pelvis moved back as the upper body
    # leans forward, as a person bending over a table pushes the hips back (a standing motion's plan).
    centred: bool = False

    @property
    def num_frames(self) -> int:
        return len(self.pelvis)


def heading_of(feet: dict[str, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """(T,) heading: the mean yaw of the two feet."""
    return np.unwrap(heading_yaw(feet["left"][1] + feet["right"][1]))


def pelvis_over_feet(
    feet: dict[str, tuple[np.ndarray, np.ndarray]], body: Body, fps: float, sigma: float, sway: float
) -> tuple[np.ndarray, np.ndarray]:
    """Planar pelvis path (T, 2) and heading (T,) that follow the feet.

    The pelvis rides over the middle of the feet (low-passed, so it moves
    steadily through the steps) and sways towards the supporting foot.
    """
    heading = smooth(heading_of(feet), fps, sigma)
    ahead = 0.04 * body.scale  # the balanced stance has the hips over the mid-foot
    centre = 0.5 * (feet["left"][0][:, :2] + feet["right"][0][:, :2])
    forward = np.column_stack([np.cos(heading), np.sin(heading)])
    left = np.column_stack([-np.sin(heading), np.cos(heading)])
    xy = smooth(centre, fps, sigma) + ahead * forward
    lifted = {s: feet[s][0][:, 2] > body.sole + 0.004 for s in SIDES}
    support = lifted["right"].astype(float) - lifted["left"].astype(float)
    xy += sway * smooth(support, fps, sigma)[:, None] * left
    return xy, heading


def balanced_pelvis_path(
    feet: dict[str, tuple[np.ndarray, np.ndarray]], body: Body, fps: float, heading: np.ndarray
) -> np.ndarray:
    """Planar pelvis path (T, 2) that keeps the centre of pressure on the
    feet: the centre of pressure planned over the planted feet (the
    mid-foot of the one planted, between both when both are, shifted
    smoothly at each change), and the centre of mass that puts it there by
    Drake's `ZmpPlanner` (a linear inverted pendulum at the standing pelvis
    height, with its preview of the whole motion, from rest). The pelvis
    is taken to carry the centre of mass, as a standing person's does."""
    forward = np.column_stack([np.cos(heading), np.sin(heading)])
    middle = {s: feet[s][0][:, :2] + 0.04 * body.scale * forward for s in SIDES}  # the mid-foot, ahead of the ankle
    planted = np.column_stack([feet[s][0][:, 2] <= body.sole + 0.004 for s in SIDES]).astype(float)
    planted[planted.sum(axis=1) == 0] = 1.0  # airborne: between the feet
    weights = smooth(planted, fps, 0.05)
    weights /= weights.sum(axis=1, keepdims=True)
    pressure = sum(weights[:, i, None] * middle[s] for i, s in enumerate(SIDES))
    return centre_of_mass_path(pressure, fps, body.leg_length(0.0))  # the pendulum's height: soles to hips


def centre_of_mass_path(pressure: np.ndarray, fps: float, height: float) -> np.ndarray:
    """The centre of mass path (T, 2) that puts the centre of pressure on
    `pressure` (T, 2, one per frame): Drake's `ZmpPlanner`, a linear inverted
    pendulum at `height` with its preview of the whole path, from rest over
    the first pressure."""
    from pydrake.planning import ZmpPlanner
    from pydrake.trajectories import PiecewisePolynomial

    times = np.arange(len(pressure)) / fps
    start = np.concatenate([pressure[0], np.zeros(2)])
    # Held for a second at its end: the planner wants a reference that ends at rest.
    reference = PiecewisePolynomial.FirstOrderHold(np.append(times, times[-1] + 1.0), np.c_[pressure.T, pressure[-1]])
    planner = ZmpPlanner()
    planner.Plan(reference, start, height, GRAVITY, np.eye(2), ZMP_TRACKING * np.eye(2))
    return planner.get_nominal_com().vector_values(times).T


def smooth_under(limit: np.ndarray, fps: float, window: float = 0.12, sigma: float = 0.06) -> np.ndarray:
    """A smooth path (T,) under `limit` (T,): the limit's lowest within
    +-`window` seconds, low-passed over `sigma`, so a dip of the limit is
    met by a gentle descent rather than a drop of several centimetres in a
    frame (which would ask the feet for a large, brief change of force)."""
    half = max(1, int(round(window * fps)))
    padded = np.concatenate([np.repeat(limit[:1], half), limit, np.repeat(limit[-1:], half)])
    lowest = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1).min(axis=1)
    return np.minimum(smooth(lowest, fps, sigma), limit)


def reachable_height(
    xy: np.ndarray, pelvis_rot: np.ndarray, feet: dict, body: Body, knee: float, fps: float
) -> np.ndarray:
    """Highest pelvis height (T,) at which both legs reach their ankles with
    at least `knee` radians of knee bend (smoothed, so it never kinks)."""
    reach = body.leg_length(knee)
    limits = []
    for side in SIDES:
        hip = np.einsum("tij,j->ti", pelvis_rot, body.offsets[f"{side}_hip_x"])
        ankle = feet[side][0]
        horizontal = np.linalg.norm(xy + hip[:, :2] - ankle[:, :2], axis=1)
        limits.append(ankle[:, 2] - hip[:, 2] + np.sqrt(np.maximum(reach**2 - horizontal**2, 0.0)))
    lowest = np.minimum(*limits)
    # Smoothing may overshoot the limit at its kinks by a few millimetres;
    # the knee then straightens a little more than `knee`, which it can.
    return np.minimum(smooth(lowest, fps, 0.04), lowest + 0.003 * body.scale)


def torso_frame(body: Body, plan: Plan, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Torso rotation (T, 3, 3) and origin (T, 3) for joint positions `q`."""
    angles = q[:, [body.index(f"torso_{a}") for a in "xyz"]]
    rot = plan.pelvis_rot @ _euler_matrix(angles)
    origin = plan.pelvis + np.einsum("tij,j->ti", plan.pelvis_rot, body.offsets["torso_x"])
    return rot, origin


def realize(body: Body, plan: Plan) -> np.ndarray:
    """Joint positions (T, n) for a plan, within the joint limits.

    Direct joint trajectories first (standing pose elsewhere), then the legs
    by IK to the planned ankles, then the arms: IK to the hand targets,
    blended with the joint-space arm by each target's weight.
    """
    frames = plan.num_frames
    q = np.tile(body.standing, (frames, 1))
    for name, values in plan.joints.items():
        q[:, body.index(name)] = values
    for side in SIDES:
        hip = plan.pelvis + np.einsum("tij,j->ti", plan.pelvis_rot, body.offsets[f"{side}_hip_x"])
        ankle, foot_rot = plan.feet[side]
        for name, values in leg_ik(body, side, hip, plan.pelvis_rot, ankle, foot_rot).items():
            q[:, body.index(name)] = values
    torso_rot, torso_origin = torso_frame(body, plan, q)
    for side, target in plan.hands.items():
        shoulder = torso_origin + np.einsum("tij,j->ti", torso_rot, body.offsets[f"{side}_shoulder_x"])
        elbow = np.broadcast_to(np.asarray(target.elbow, dtype=float), (frames, 3))
        solved = arm_ik(body, side, shoulder, torso_rot, target.position, target.rotation, elbow)
        w = np.asarray(target.weight, dtype=float)
        for name, values in solved.items():
            i = body.index(name)
            q[:, i] = (1.0 - w) * q[:, i] + w * values
    return np.clip(q, body.lower, body.upper)


def finger_joints(side: str, grip: np.ndarray, thumb_flex: np.ndarray, opposition: np.ndarray) -> dict:
    """qb SoftHand joint trajectories: finger flexion `grip` (T, 4: index,
    middle, ring, little) as fractions of the range, the thumb's flexion
    and opposition as fractions too."""
    out = {f"{side}_thumb_0": 1.571 * np.asarray(opposition, dtype=float)}
    for j in range(1, 5):
        out[f"{side}_thumb_{j}"] = 0.785 * np.asarray(thumb_flex, dtype=float)
    grip = np.asarray(grip, dtype=float)
    for k, finger in enumerate(FINGERS[1:]):
        for j in range(6):
            out[f"{side}_{finger}_{j}"] = 0.785 * grip[:, k]
    return out
