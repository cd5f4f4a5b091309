"""Whether a robot could balance on a clip: its centre of pressure against
the support of its planted feet.

With the robot's own mass distribution (each link's mass, centre of mass
and inertia, as its `MultibodyPlant` has them), a clip's centre of mass c
and its angular momentum L about it give the centre of pressure on flat
ground that the motion asks of the feet (the zero-moment point):

    p_x = c_x - (c_z c''_x + L'_y / m) / (c''_z + g)
    p_y = c_y - (c_z c''_y - L'_x / m) / (c''_z + g)

A robot can only press where its planted soles are: `support_margin` is
the signed distance of p inside the convex hull of the planted soles'
contact points (negative: outside, where the robot would tip), over every
frame with a foot on the floor.

Where it is not inside, the balance pass of whole-clip retargeting
(`clip_programs.balance`) moves the body sideways by the ZMP filter here
(`balancing_shift`: one OSQP program over the whole clip, in which the
moved body's centre of pressure is linear in its shift). `TorqueDemand`
gives what each joint would have to exert, from Drake's inverse dynamics.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
import osqp
import scipy.sparse as sp

from hotu_drake.control.whole_body_qp import SOLVED
from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.landmarks import landmark_placements
from hotu_drake.motion.synthesis import gaussian_weights
from hotu_drake.retarget.contacts import Soles
from hotu_drake.retarget.targets import Landmarks
from hotu_drake.retarget.tree import Pose, Tree, cross

GRAVITY = 9.81
# s: the centre of mass and momentum are averaged over about this before being differentiated, by a Gaussian
# as spread as a box this wide (deviation SMOOTHING / sqrt(12), 29 ms) cut at three deviations. A box's side
# lobes pass a capture's frame-to-frame jitter, which two differences amplify: on the Qualisys walk the robots'
# centres of pressure jumped by 5-10 cm between frames, and 0.64-0.82 of them were inside (0.79-0.92 now).
SMOOTHING = 0.1
ON_FLOOR = 0.01  # m: a sole's contact point this close to the floor bears weight
# With one foot planted its ankle may hold the whole weight (the other foot's toes, still on the floor as its
# heel rises, may share it, but are not counted on), from half as far as two ankles sharing it (`ankle_reach`),
# and the support the balance pass keeps the pressure in reaches this share of that: the rest of the ankle's
# torque is left to the controller. NAVIAI's leg_stretch (13 N m ankles), with the controller holding the
# lunge's back foot on its toes: 4 of 4 starts stood at 0.8, 3 of 4 at 1.0, 1 of 4 with no single-foot limit.
ANKLE_ALONE = 0.8


class ClipBalance:
    """The centroidal quantities and the support of one embodiment's clips."""

    def __init__(self, emb: Embodiment):
        self.emb = emb
        self.tree = Tree(emb.spec)
        self.soles = Soles(emb.spec, self.tree)
        links = [emb.spec.link(name) for name in self.tree.link_names]
        properties = [link.mass_properties() for link in links]
        self.masses = np.array([link.mass for link in links])
        self.centers = np.array([com for com, _ in properties])  # (L, 3) in each link's frame
        self.inertias = np.array([inertia for _, inertia in properties])  # (L, 3, 3) about each link's centre
        self.mass = float(self.masses.sum())

    @cached_property
    def carried(self) -> float:
        """The share of a sideways shift of the body over planted feet that
        its centre of mass follows, from the standing pose: a link above the
        hips moves with the body, a leg's by its height's share of the hips'
        (a leg leaning about its ankle). H1 0.90, NAVIAI 0.88, BRUCE 0.87;
        measured after a first round of the balance pass, 0.89, 0.86, 0.89."""
        standing = self.emb.standing_pose
        pose = self.tree.forward(standing)
        floor = min(self.soles.lowest(pose, side) for side in self.soles.feet)
        hips = Landmarks(self.tree, landmark_placements(self.emb.spec)).all_positions(pose)
        height = 0.5 * (hips["left_hip"][2] + hips["right_hip"][2]) - floor
        centers = pose.positions + np.einsum("lij,lj->li", pose.rotations, self.centers)
        share = np.clip((centers[:, 2] - floor) / max(height, 1e-6), 0.0, 1.0)
        return float(self.masses @ share / self.mass)

    def poses(self, q: np.ndarray, rotations: np.ndarray, positions: np.ndarray) -> Pose:
        return self.tree.forward_frames(q, rotations, positions)

    def centroidal(self, poses: Pose, fps: float) -> tuple[np.ndarray, np.ndarray]:
        """The centre of mass (T, 3) and the centre of pressure p (T, 2) of a clip's poses."""
        dt = 1.0 / fps
        centers = poses.positions + np.einsum("tlij,lj->tli", poses.rotations, self.centers)  # (T, L, 3)
        com = np.einsum("l,tli->ti", self.masses, centers) / self.mass
        velocity = np.gradient(centers, dt, axis=0)
        omega = _angular_velocity(poses.rotations, dt)  # (T, L, 3)
        momentum = np.einsum("l,tli->ti", self.masses, cross(centers - com[:, None], velocity))
        # Each link's R I R' omega, as vectors (no (T, L, 3, 3) products).
        local = np.einsum("tlji,tlj->tli", poses.rotations, omega)
        momentum += np.einsum("tlij,tlj->ti", poses.rotations, np.einsum("lij,tlj->tli", self.inertias, local))
        acceleration = smoothed_rate(com, fps, 2)
        torque = smoothed_rate(momentum, fps, 1)  # L' about the centre of mass
        lift = acceleration[:, 2] + GRAVITY
        pressure = np.column_stack(
            (
                com[:, 0] - (com[:, 2] * acceleration[:, 0] + torque[:, 1] / self.mass) / lift,
                com[:, 1] - (com[:, 2] * acceleration[:, 1] - torque[:, 0] / self.mass) / lift,
            )
        )
        return com, pressure

    @cached_property
    def ankle_reach(self) -> float | None:
        """How far (m) ahead of and behind the ankles the two ankles' pitch
        torque limits can hold the robot's weight from, both feet down and
        sharing it (2 tau / m g): NAVIAI's 13 N m ankles 0.10 m (its soles
        reach 0.13 ahead), Walker's 0.14 (0.15); the UDH's, H1's and BRUCE's
        reach past their soles. None: no ankle pitch joint to limit it."""
        names = list(self.emb.joint_names)
        joints = [f"{side}_ankle_y" for side in self.soles.feet]
        if len(joints) != 2 or not set(joints) <= set(names):
            return None
        limit = min(self.emb.effort_limits[names.index(joint)] for joint in joints)
        return float(2.0 * limit / (self.mass * GRAVITY))

    def support(self, poses: Pose, contacts: dict[str, np.ndarray], ankles_hold: bool = False) -> Support:
        """The soles' contact points (T, K, 2), which of them bear weight
        (T, K): every point of a foot the clip has planted, and any point
        of a sole on the floor (within `ON_FLOOR`: a toe still down as its
        heel rises to push off), and the smallest contact radius (m). With
        `ankles_hold`, each planted sole reaches only as far ahead of and
        behind its ankle as the ankles can hold the body from: `ankle_reach`
        on frames with both feet planted, `ANKLE_ALONE` of half that on
        frames with one: the support the ankles can hold the body over, not
        only the soles'."""
        reach = self.ankle_reach if ankles_hold else None
        frames = len(poses.positions)
        planted = {
            side: np.zeros(frames, bool) if contacts.get(side) is None else np.asarray(contacts[side], bool)
            for side in self.soles.feet
        }
        both = np.logical_and.reduce(list(planted.values()))
        points, down, radii = [], [], []
        for side in self.soles.feet:
            world, radius = self.soles.points_frames(poses, side)
            if reach is not None:
                alone = planted[side] & ~both
                for held_reach, held_frames in ((reach, both), (ANKLE_ALONE * reach / 2.0, alone)):
                    if held_frames.any():
                        within = self._within_reach(poses, side, held_reach)
                        world = np.where(held_frames[:, None, None], within, world)
            points.append(world[..., :2])
            down.append(planted[side][:, None] | (world[..., 2] - radius < ON_FLOOR))
            radii.append(radius)
        return Support(np.concatenate(points, axis=1), np.concatenate(down, axis=1), float(np.concatenate(radii).min()))

    def _within_reach(self, poses: Pose, side: str, reach: float) -> np.ndarray:
        """The contact points (T, K, 3) of sole `side`, each kept within
        `reach` (m) ahead of and behind its ankle (the foot's origin)."""
        link, local, _ = self.soles.feet[side]
        held = local.copy()
        held[:, 0] = np.clip(held[:, 0], -reach, reach)
        return poses.positions[:, link, None, :] + np.einsum("tij,kj->tki", poses.rotations[:, link], held)

    def support_margin(self, poses: Pose, pressure: np.ndarray, contacts: dict[str, np.ndarray]) -> np.ndarray:
        """Per frame, how far (m) the centre of pressure lies inside the
        planted soles' support (negative: outside); NaN with no foot down."""
        return self.support(poses, contacts).margin(pressure)


@dataclass
class Support:
    """The planted soles of a clip: contact points (T, K, 2), which bear
    weight (T, K), and the smallest contact radius (m); the edges of each
    frame's convex hull are found once (`hull_edges`)."""

    points: np.ndarray
    down: np.ndarray
    radius: float

    @cached_property
    def edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return hull_edges(self.points, self.down)

    @cached_property
    def _hulls(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Each frame's hull edges alone (starts and directions (T, H, 2),
        which are real (T, H)), and the frames whose support has an inside."""
        a, edge, hull, _ = self.edges
        order = np.argsort(~hull, axis=1, kind="stable")[:, : max(1, int(hull.sum(axis=1).max(initial=0)))]
        return _take_edges(a, order), _take_edges(edge, order), _take_edges(hull, order), hull.any(axis=1)

    def margin(self, pressure: np.ndarray) -> np.ndarray:
        """Per frame, how far (m) `pressure` (T, 2) lies inside, the contact
        radius included (negative: outside; NaN with no foot down):
        `signed_distances` plus the radius, over each frame's hull edges only."""
        a, edge, real, has_inside = self._hulls
        out = np.full(len(pressure), np.nan)
        distance, left = _to_segments(pressure, a, edge)
        inside = np.all(np.where(real, left >= 0.0, True), axis=1)
        nearest = np.where(real, distance, np.inf).min(axis=1, initial=np.inf)
        out[has_inside] = np.where(inside, nearest, -nearest)[has_inside]
        rest = ~has_inside & self.down.any(axis=1)  # one point, or points on a line: no inside
        if rest.any():
            out[rest] = signed_distances(self.points[rest], self.down[rest], pressure[rest])
        return out + self.radius


def _take_edges(values: np.ndarray, order: np.ndarray) -> np.ndarray:
    """Per frame, the edges (T, E, ...) in `order` (T, H)."""
    return np.take_along_axis(values, order[..., None] if values.ndim == 3 else order, axis=1)


def _to_segments(p: np.ndarray, a: np.ndarray, edge: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each frame's `p` (T, 2) against segments from a (T, E, 2) along
    `edge` (T, E, 2): its distance to each (T, E), and which side of each
    line it is on (T, E; > 0: left)."""
    length = np.maximum(np.einsum("tei,tei->te", edge, edge), 1e-18)
    s = np.clip(np.einsum("tei,tei->te", p[:, None] - a, edge) / length, 0.0, 1.0)
    distance = np.linalg.norm(p[:, None] - (a + s[..., None] * edge), axis=-1)
    left = edge[..., 0] * (p[:, None, 1] - a[..., 1]) - edge[..., 1] * (p[:, None, 0] - a[..., 0])
    return distance, left


def shifted_pressure(com: np.ndarray, pressure: np.ndarray, shift: np.ndarray, fps: float) -> np.ndarray:
    """The centre of pressure (T, 2) of a clip whose every link is moved
    sideways by `shift` (T, 2): the angular momentum about the centre of
    mass is unchanged by a common translation, so only the centre of mass
    (T, 3) and its acceleration change (smoothed as `centroidal` smooths)."""
    return pressure + shift - pendulum_height(com, fps)[:, None] * smoothed_rate(shift, fps, 2)


def pendulum_height(com: np.ndarray, fps: float) -> np.ndarray:
    """c_z / (c_z'' + g) per frame (T,): how far a centre-of-mass
    acceleration moves the centre of pressure back (0 where the centre of
    mass is not finite; a lift near zero held at 1e-9)."""
    height = np.nan_to_num(com[:, 2])
    lift = smoothed_rate(height, fps, 2) + GRAVITY
    return np.where(np.isfinite(com[:, 2]), height / np.where(np.abs(lift) > 1e-9, lift, 1e-9), 0.0)


def smoothed_rate(values: np.ndarray, fps: float, order: int) -> np.ndarray:
    """The first or second time derivative (`order`) of `values` (T, ...)
    averaged first (`averaging_matrix`, about `SMOOTHING` wide): the
    centroidal figures' one way of differentiating a clip."""
    values = np.asarray(values, dtype=float)
    rate = (averaging_matrix(len(values), float(fps)) @ values.reshape(len(values), -1)).reshape(values.shape)
    for _ in range(order):
        rate = np.gradient(rate, 1.0 / fps, axis=0)
    return rate


def clear_of_flight(contacts: dict[str, np.ndarray], fps: float) -> np.ndarray:
    """Per frame (T,), whether the centroidal figures' window at it (the
    average over `smoothing_kernel`, then two central differences: `smoothed_rate`)
    holds no frame without a foot down (a jump's flight, or a gap between a
    capture's detected contacts): a centre of pressure estimated across one
    mixes the body's fall through the air (or what the contacts miss) into
    the push-off or landing beside it. `contacts`: each foot's flags (T,),
    one foot's at least."""
    airborne = ~np.any(np.stack([np.asarray(flags, bool) for flags in contacts.values()]), axis=0)
    reach = len(smoothing_kernel(fps)) // 2 + 2
    near = np.convolve(airborne.astype(float), np.ones(2 * reach + 1))[reach : reach + len(airborne)]
    return near == 0.0  # (a clip shorter than the window too)


def smoothing_kernel(fps: float) -> np.ndarray:
    """The centroidal figures' averaging weights over frames at `fps`: a
    Gaussian of deviation `SMOOTHING` / sqrt(12) (`synthesis.gaussian_weights`)."""
    return gaussian_weights(fps, SMOOTHING / np.sqrt(12.0))


@lru_cache(maxsize=16)
def averaging_matrix(frames: int, fps: float) -> sp.csr_matrix:
    """The centroidal figures' average as a sparse (T, T) matrix: the clip
    continued past its ends as it was going (`_continued`), then weighted by
    the centred `smoothing_kernel` (one matrix per clip length and rate,
    kept: `smoothed_rate` and the filter's program both take it)."""
    kernel = smoothing_kernel(fps)
    reach = len(kernel) // 2
    rows = np.repeat(np.arange(frames), len(kernel))
    columns = rows + np.tile(np.arange(len(kernel)), frames)  # into the continued clip
    convolution = sp.csr_matrix((np.tile(kernel, frames), (rows, columns)), shape=(frames, frames + 2 * reach))
    return (convolution @ _continued(frames, reach)).tocsr()


def _continued(frames: int, reach: int) -> sp.csr_matrix:
    """The (T + 2 reach, T) matrix that continues a clip `reach` frames past
    each end by reflecting it through its end frame (x_-k = 2 x_0 - x_k): a
    clip that ends moving goes on moving, where repeating the end frame
    would stop it at once (a deceleration it never had). Its acceleration
    at the end frame reads near zero: a push-off or landing in a clip's
    last 0.1 s is mostly not seen either."""
    at = np.arange(-reach, frames + reach)
    rows = np.arange(len(at))
    inside = (at >= 0) & (at < frames)
    end = np.where(at < 0, 0, frames - 1)[~inside]
    mirrored = np.clip(np.where(at < 0, -at, 2 * (frames - 1) - at), 0, frames - 1)[~inside]
    outside = rows[~inside]
    return sp.csr_matrix(
        (
            np.r_[np.ones(inside.sum()), np.full(len(outside), 2.0), np.full(len(outside), -1.0)],
            (np.r_[rows[inside], outside, outside], np.r_[at[inside], end, mirrored]),
        ),
        shape=(len(at), frames),
    )


def _angular_velocity(rotations: np.ndarray, dt: float) -> np.ndarray:
    """World angular velocities (T, L, 3) of rotations (T, L, 3, 3), by
    central differences: the skew part of R' R^T, only its three entries."""
    rate = np.gradient(rotations, dt, axis=0)

    def entry(i: int, j: int) -> np.ndarray:  # (R' R^T)_ij
        return np.einsum("tlk,tlk->tl", rate[..., i, :], rotations[..., j, :])

    return 0.5 * np.stack((entry(2, 1) - entry(1, 2), entry(0, 2) - entry(2, 0), entry(1, 0) - entry(0, 1)), -1)


def hull_edges(points: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The edges of each frame's convex hull of its valid points (T, K, 2),
    all frames at once: every ordered point pair's start (T, E, 2) and
    direction (T, E, 2), whether it is a hull edge, counter-clockwise
    (every other valid point on its left), and whether it joins two
    distinct valid points."""
    count = valid.shape[1]
    i, j = np.triu_indices(count, 1)
    i, j = np.concatenate([i, j]), np.concatenate([j, i])  # both directions of every pair
    a, edge = points[:, i], points[:, j] - points[:, i]
    side = edge[:, :, None, 0] * (points[:, None, :, 1] - a[:, :, None, 1]) - edge[:, :, None, 1] * (
        points[:, None, :, 0] - a[:, :, None, 0]
    )  # (T, E, K): > 0 where point k lies left of edge e
    others, tolerance = valid[:, None, :], 1e-9
    usable = valid[:, i] & valid[:, j] & (np.einsum("tei,tei->te", edge, edge) > tolerance**2)
    hull = usable & np.all((side >= -tolerance) | ~others, axis=2) & np.any((side > tolerance) & others, axis=2)
    return a, edge, hull, usable


def signed_distances(points: np.ndarray, valid: np.ndarray, p: np.ndarray) -> np.ndarray:
    """How far each frame's `p` (T, 2) lies inside the convex hull of its
    valid points (T, K, 2) (negative: outside; a hull of collinear points
    has no inside; NaN with no valid point)."""
    a, edge, hull, usable = hull_edges(points, valid)
    distance, left = _to_segments(p, a, edge)
    flat = ~hull.any(axis=1)  # one point, or all on a line: the distance to the points' segment, outside
    nearest_edge = np.where(hull, distance, np.inf).min(axis=1)
    inside = np.all(np.where(hull, left >= 0.0, True), axis=1) & ~flat
    nearest_any = np.where(usable, distance, np.inf).min(axis=1)
    single = np.where(valid, np.linalg.norm(points - p[:, None], axis=-1), np.inf).min(axis=1)
    outside = np.where(flat, np.minimum(nearest_any, single), nearest_edge)
    out = np.where(inside, nearest_edge, -outside)
    return np.where(valid.any(axis=1), out, np.nan)


MARGIN = 0.03  # m: how far inside the support the balance pass asks the centre of pressure to be
# m: the furthest the pass moves the body along either horizontal axis. At 0.15 NAVIAI's box carry (its
# UDH bridge not balanced first) was 0.82-0.86 inside, at 0.25 0.99; the UDH's library clips are as they were,
# its captures further inside (Qualisys 0.68 -> 0.75).
MOST_MOVED = 0.25
# The filter's program: its cost of the shift (per m^2), of the shift's speed (per (m/s)^2), and of a
# frame's centre of pressure falling short of MARGIN inside (per m, and per m^2). Measured on CMU 01_01
# and the library's box carry: shifts 500x cheaper balanced the capture no better and made its planted
# feet skate (0.44 m/s on H1, against 0.09); shortfall 5x cheaper left NAVIAI's box carry 0.77 inside.
SHIFT_COST = 2.0
SHIFT_SPEED_COST = 0.2
SHORTFALL_COST = (1.0, 10.0)
KNOT_SPACING = 0.05  # s between the shift's spline knots: half the centroidal figures' smoothing
# The frames the filter's program constrains, at most this many per second (the shift's knots are 0.05 s
# apart): every frame of a 200 fps capture. At 60 a second the Qualisys walk's frames between those checked
# left NAVIAI's centre of pressure 0.935 inside (0.985 with every frame checked).
CHECK_RATE = 240.0
FILTER_SETTINGS = {"verbose": False, "polishing": False, "eps_abs": 1e-2, "eps_rel": 1e-2, "rho": 1.0, "max_iter": 4000}


def second_rate_matrix(frames: int, fps: float) -> sp.csr_matrix:
    """`smoothed_rate(., fps, 2)` as a sparse (T, T) matrix (it is linear):
    `averaging_matrix`, then `np.gradient` twice (one-sided at the ends)."""
    average = averaging_matrix(frames, float(fps))
    gradient = _gradient_matrix(frames, fps)
    return (gradient @ gradient @ average).tocsr()


def _gradient_matrix(frames: int, fps: float) -> sp.csr_matrix:
    """`np.gradient(., 1 / fps)` along time as a sparse (T, T) matrix."""
    if frames < 2:
        return sp.csr_matrix((frames, frames))
    inner = np.arange(1, frames - 1)
    rows = np.r_[0, 0, inner, inner, frames - 1, frames - 1]
    columns = np.r_[1, 0, inner + 1, inner - 1, frames - 1, frames - 2]
    values = np.r_[1.0, -1.0, np.full(len(inner), 0.5), np.full(len(inner), -0.5), 1.0, -1.0] * fps
    return sp.csr_matrix((values, (rows, columns)), shape=(frames, frames))


def balancing_shift(
    support: Support, com: np.ndarray, pressure: np.ndarray, fps: float, moved: np.ndarray | None = None
) -> np.ndarray:
    """The ZMP filter, as one convex program: the sideways shift s (T, 2)
    of the whole body that brings the clip's centre of pressure `MARGIN`
    inside its `support`. A common translation leaves the angular momentum
    about the centre of mass alone, so the shifted body's centre of
    pressure is linear in s (`shifted_pressure`):

        p'_t = p_t + s_t - c_z,t / (c''_z,t + g) (R s)_t    (R: `second_rate_matrix`)

    and OSQP (the `osqp` package directly, as the clip programs use it)
    finds the least shift (a cubic spline, `_spline_basis`), and
    the least speed of what it adds, that puts the checked frames' p'
    `MARGIN` inside each edge of their support's hull (every supported
    frame, `CHECK_RATE` a second at most; within half the contact radius of
    a flat support: a foot of line contacts), a frame that cannot be paying
    for its shortfall. `moved`: the shift (T, 2) the body already has; the
    total is clipped to `MOST_MOVED` on each horizontal axis (the program
    bounds what it adds by as much). A failed solve leaves the body where it
    is. Frames without a finite centre of
    pressure (no lift: a fall) are left out."""
    frames = len(com)
    moved = np.zeros((frames, 2)) if moved is None else moved
    usable = np.isfinite(pressure).all(axis=1) & np.isfinite(com).all(axis=1) & support.down.any(axis=1)
    pressure = np.where(usable[:, None], pressure, 0.0)
    height = np.where(usable, pendulum_height(com, fps), 0.0)
    pressure_of_shift = (sp.identity(frames, format="csr") - sp.diags(height) @ second_rate_matrix(frames, fps)).tocsr()
    checked = usable & (np.arange(frames) % max(1, int(np.ceil(fps / CHECK_RATE))) == 0)
    rows, normals, bounds = _support_rows(support, pressure, checked)
    if not len(rows):
        return np.zeros((frames, 2))
    basis = _spline_basis(frames, fps)  # shift = basis @ knots: smooth between frames by construction
    knots = basis.shape[1]
    constrained, row_frame = np.unique(rows, return_inverse=True)
    count, shorts = len(rows), len(constrained)
    # Variables: the knots along x, along y, and each constrained frame's shortfall.
    along = (pressure_of_shift @ basis).tocsr()[rows]  # the change of p' - p per knot, at each row's frame
    inside = sp.hstack(
        [
            sp.diags(normals[:, 0]) @ along,
            sp.diags(normals[:, 1]) @ along,
            sp.csr_matrix((np.ones(count), (np.arange(count), row_frame)), shape=(count, shorts)),
        ]
    )
    # The total shift's cost and its increment's speed's (banded: each frame touches four knots).
    difference = _gradient_matrix(frames, fps) @ basis
    per_axis = 2.0 * (SHIFT_COST * basis.T @ basis + SHIFT_SPEED_COST * difference.T @ difference)
    linear, quadratic = SHORTFALL_COST
    hessian = sp.block_diag([per_axis, per_axis, sp.identity(shorts) * (2.0 * quadratic)], format="csc")
    shift_gradient = 2.0 * SHIFT_COST * (basis.T @ moved)  # (K, 2): the shift already there
    gradient = np.r_[shift_gradient[:, 0], shift_gradient[:, 1], np.full(shorts, linear)]
    # |shift| <= MOST_MOVED on each axis at the knots (the spline stays within its knots' hull); shortfalls >= 0.
    constraints = sp.csc_matrix(sp.vstack([inside, sp.identity(2 * knots + shorts)]))
    lower = np.r_[bounds, np.full(2 * knots, -MOST_MOVED), np.zeros(shorts)]
    upper = np.r_[np.full(count, np.inf), np.full(2 * knots, MOST_MOVED), np.full(shorts, np.inf)]
    solver = osqp.OSQP()
    solver.setup(P=sp.csc_matrix(sp.triu(hessian)), q=gradient, A=constraints, l=lower, u=upper, **FILTER_SETTINGS)
    result = solver.solve(raise_error=False)
    if result.info.status_val not in SOLVED:
        return np.zeros((frames, 2))
    return np.clip(basis @ result.x[: 2 * knots].reshape(2, knots).T, -MOST_MOVED - moved, MOST_MOVED - moved)


def _spline_basis(frames: int, fps: float) -> sp.csr_matrix:
    """The (T, K) values at each frame of uniform cubic B-splines with knots
    `KNOT_SPACING` apart, spanning the clip."""
    from scipy.interpolate import BSpline

    duration = max(frames - 1, 1) / fps
    pieces = max(1, int(np.ceil(duration / KNOT_SPACING)))
    knots = np.linspace(0.0, duration, pieces + 1)
    step = knots[1] - knots[0]
    knots = np.r_[knots[0] - 3 * step + np.arange(3) * step, knots, knots[-1] + step * np.arange(1, 4)]
    return BSpline.design_matrix(np.arange(frames) / fps, knots, 3).tocsr()


def _support_rows(support: Support, pressure: np.ndarray, usable: np.ndarray):
    """The filter's constraints n . (p'_t - p_t) + shortfall_t >= bound:
    one per hull edge of each usable frame (n inward, `MARGIN` inside), or,
    for a support without an inside, p' within half the contact radius of
    its longest segment (four, across and between its ends) or of its one
    point (four, a square). Returns the frames (C,), normals (C, 2) and bounds (C,)."""
    a, edge, hull, pairs = support.edges
    frames_of, edges_of = np.nonzero(hull & usable[:, None])
    inward = np.stack([-edge[frames_of, edges_of, 1], edge[frames_of, edges_of, 0]], -1)
    inward /= np.linalg.norm(inward, axis=1, keepdims=True)
    bound = MARGIN - support.radius - np.einsum("ci,ci->c", inward, pressure[frames_of] - a[frames_of, edges_of])
    out = [(frames_of, inward, bound)]
    half = 0.5 * support.radius
    flat = usable & ~hull.any(axis=1)
    line = np.flatnonzero(flat & pairs.any(axis=1))
    if len(line):
        longest = np.where(pairs[line], np.einsum("tei,tei->te", edge[line], edge[line]), -1.0).argmax(axis=1)
        origin, direction = a[line, longest], edge[line, longest]
        length = np.linalg.norm(direction, axis=1)
        along = direction / length[:, None]
        across = np.stack([-along[:, 1], along[:, 0]], -1)
        for normal, least in ((across, -half), (-across, -half), (along, np.zeros(len(line))), (-along, -length)):
            out.append((line, normal, least - np.einsum("ci,ci->c", normal, pressure[line] - origin)))
    point = np.flatnonzero(flat & ~pairs.any(axis=1))
    if len(point):
        where = support.points[point, support.down[point].argmax(axis=1)]
        for normal in np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]):
            normals = np.tile(normal, (len(point), 1))
            out.append((point, normals, -half - np.einsum("ci,ci->c", normals, pressure[point] - where)))
    return tuple(np.concatenate(parts) for parts in zip(*out))


def inside_share(margins: np.ndarray) -> float | None:
    """The share of the supported frames (a margin, not NaN) whose centre of pressure is inside; None with none."""
    supported = margins[~np.isnan(margins)]
    return float(np.mean(supported >= 0.0)) if supported.size else None


def shortfall(support: Support, pressure: np.ndarray) -> float:
    """How far (m, summed over the supported frames) the centre of pressure
    is from `MARGIN` inside the support, each frame counting `MOST_MOVED` at most."""
    return _shortfall(support.margin(pressure))


def _shortfall(margins: np.ndarray) -> float:
    return float(np.nansum(np.clip(MARGIN - margins, 0.0, MOST_MOVED)))


class TorqueDemand:
    """What each joint must exert to perform a clip: Drake's inverse
    dynamics of the robot's `MultibodyPlant` along the clip, the floating
    base's share carried by the planted feet (the least contact wrenches,
    at each sole's centre, that do so), compared with the effort limits."""

    def __init__(self, emb: Embodiment, plant=None, model=None):
        """On `plant` (a finalized `MultibodyPlant` holding `emb` as `model`,
        its only model: a controller's), or on a plant of its own."""
        from pydrake.multibody.plant import MultibodyPlant

        if (plant is None) != (model is None):
            raise ValueError("TorqueDemand: a plant and its model, or neither")
        self.emb = emb
        if plant is None:
            plant = MultibodyPlant(0.0)
            model = emb.add_to_plant(plant, builtin_pd=False)
            plant.Finalize()
        self.plant, self.model = plant, model
        self.context = plant.CreateDefaultContext()
        self.floating = emb.floating_base
        self.columns = [plant.GetJointByName(n, self.model).position_start() for n in emb.joint_names]
        self.velocity_columns = [plant.GetJointByName(n, self.model).velocity_start() for n in emb.joint_names]
        tree = Tree(emb.spec)
        soles = Soles(emb.spec, tree)
        self.feet = {
            side: (plant.GetBodyByName(tree.link_names[link], self.model).body_frame(), points.mean(axis=0))
            for side, (link, points, _) in soles.feet.items()
        }

    def ratios(self, clip, contacts: dict[str, np.ndarray]) -> np.ndarray:
        """|torque| over the effort limit (T, joints) along the clip."""
        from pydrake.multibody.tree import JacobianWrtVariable, MultibodyForces

        plant, context = self.plant, self.context
        index = [clip.joint_names.index(n) for n in self.emb.joint_names]
        q = np.tile(plant.GetPositions(context), (clip.num_frames, 1))
        q[:, self.columns] = clip.joint_positions[:, index]
        if self.floating:
            q[:, :4], q[:, 4:7] = clip.root_quaternion, clip.root_position
        dt = 1.0 / clip.fps
        velocities = np.zeros((clip.num_frames, plant.num_velocities()))
        velocities[:, self.velocity_columns] = np.gradient(clip.joint_positions[:, index], dt, axis=0)
        if self.floating:  # the free body's velocity: angular, then linear, in the world
            velocities[:, :3] = clip.root_angular_velocity
            velocities[:, 3:6] = np.gradient(clip.root_position, dt, axis=0)
        accelerations = np.gradient(velocities, dt, axis=0)
        forces = MultibodyForces(plant)
        effort = self.emb.effort_limits
        out = np.zeros((clip.num_frames, len(index)))
        world = plant.world_frame()
        for t in range(clip.num_frames):
            plant.SetPositions(context, q[t])
            plant.SetVelocities(context, velocities[t])
            plant.CalcForceElementsContribution(context, forces)  # gravity (and any other force element)
            tau = plant.CalcInverseDynamics(context, accelerations[t], forces)
            planted = [side for side in self.feet if contacts.get(side) is not None and contacts[side][t]]
            if self.floating and planted:
                jacobians = np.vstack(
                    [
                        plant.CalcJacobianSpatialVelocity(
                            context, JacobianWrtVariable.kV, self.feet[side][0], self.feet[side][1], world, world
                        )
                        for side in planted
                    ]
                )
                wrench = np.linalg.lstsq(jacobians[:, :6].T, tau[:6], rcond=None)[0]
                tau = tau - jacobians.T @ wrench
            out[t] = np.abs(tau[self.velocity_columns]) / effort
        return out
