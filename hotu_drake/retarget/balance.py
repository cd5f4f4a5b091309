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
(`balancing_shift`: Drake's `ZmpPlanner` on how far the centre of
pressure is to move). `TorqueDemand` gives what each joint would have to
exert, from Drake's inverse dynamics.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.motion.synthesis import centre_of_mass_path
from hotu_drake.retarget.contacts import Soles
from hotu_drake.retarget.tree import Pose, Tree

GRAVITY = 9.81
SMOOTHING = 0.1  # s: the centre of mass and momentum are averaged over this before being differentiated
ON_FLOOR = 0.01  # m: a sole's contact point this close to the floor bears weight


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

    def poses(self, q: np.ndarray, rotations: np.ndarray, positions: np.ndarray) -> Pose:
        return self.tree.forward_frames(q, rotations, positions)

    def centroidal(self, poses: Pose, fps: float) -> tuple[np.ndarray, np.ndarray]:
        """The centre of mass (T, 3) and the centre of pressure p (T, 2) of a clip's poses."""
        dt = 1.0 / fps
        centers = poses.positions + np.einsum("tlij,lj->tli", poses.rotations, self.centers)  # (T, L, 3)
        com = np.einsum("l,tli->ti", self.masses, centers) / self.mass
        velocity = np.gradient(centers, dt, axis=0)
        omega = _angular_velocity(poses.rotations, dt)  # (T, L, 3)
        world_inertia = poses.rotations @ self.inertias @ np.swapaxes(poses.rotations, -1, -2)
        momentum = np.einsum("l,tli->ti", self.masses, np.cross(centers - com[:, None], velocity))
        momentum += np.einsum("tlij,tlj->ti", world_inertia, omega)
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

    def sole_points(self, poses: Pose, side: str) -> tuple[np.ndarray, np.ndarray]:
        """A sole's contact points in the world (T, K, 3) and their radii (K,)."""
        link, points, radii = self.soles.feet[side]
        world = poses.positions[:, link, None, :] + np.einsum("tij,kj->tki", poses.rotations[:, link], points)
        return world, radii

    def support(self, poses: Pose, contacts: dict[str, np.ndarray]) -> Support:
        """The soles' contact points (T, K, 2), which of them bear weight
        (T, K): every point of a foot the clip has planted, and any point
        of a sole on the floor (within `ON_FLOOR`: a toe still down as its
        heel rises to push off), and the smallest contact radius (m)."""
        points, down, radii = [], [], []
        for side in self.soles.feet:
            world, radius = self.sole_points(poses, side)
            planted = contacts.get(side)
            planted = np.zeros(len(world), bool) if planted is None else np.asarray(planted, bool)
            points.append(world[..., :2])
            down.append(planted[:, None] | (world[..., 2] - radius < ON_FLOOR))
            radii.append(radius)
        return Support(np.concatenate(points, axis=1), np.concatenate(down, axis=1), float(np.concatenate(radii).min()))

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
    lift = smoothed_rate(com[:, 2], fps, 2) + GRAVITY
    return pressure + shift - com[:, 2:3] * smoothed_rate(shift, fps, 2) / lift[:, None]


def smoothed_rate(values: np.ndarray, fps: float, order: int) -> np.ndarray:
    """The first or second time derivative (`order`) of `values` (T, ...)
    averaged over `SMOOTHING` first: the centroidal figures' one way of
    differentiating a clip."""
    rate = smooth(values, max(1, int(round(SMOOTHING * fps))))
    for _ in range(order):
        rate = np.gradient(rate, 1.0 / fps, axis=0)
    return rate


def smooth(values: np.ndarray, window: int) -> np.ndarray:
    """A centred moving average over `window` frames (the ends averaged over what there is)."""
    if window <= 1:
        return values
    kernel = np.ones(window)
    padded = np.concatenate([np.repeat(values[:1], window, axis=0), values, np.repeat(values[-1:], window, axis=0)])
    summed = np.apply_along_axis(lambda column: np.convolve(column, kernel, mode="same"), 0, padded)
    return summed[window:-window] / window


def _angular_velocity(rotations: np.ndarray, dt: float) -> np.ndarray:
    """World angular velocities (T, L, 3) of rotations (T, L, 3, 3), by central differences."""
    rate = np.gradient(rotations, dt, axis=0)
    skew = rate @ np.swapaxes(rotations, -1, -2)
    return 0.5 * np.stack(
        (skew[..., 2, 1] - skew[..., 1, 2], skew[..., 0, 2] - skew[..., 2, 0], skew[..., 1, 0] - skew[..., 0, 1]), -1
    )


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
MOST_MOVED = 0.15  # m: the furthest the pass moves a frame's centre of pressure, or its body (a fall: only this far)
TRACKING = 1e-4  # the planner's cost of centre-of-mass acceleration against centre-of-pressure error (Drake: 0.1)
# The filter's passes when called alone (the balance pass sets its own per round, `clip_programs.BALANCE_ROUNDS`):
# the planner's pendulum is not the clip's (its height varies, its pressure is smoothed); passes take up the rest.
PASSES = 12
STEP_FRACTIONS = (1.0, 0.5, 0.25)  # of the planner's shift, tried in turn until one helps
SETTLED = 1e-3  # m: the passes stop once no frame's centre of pressure is to move further than this


def desired_pressure(
    support: Support, pressure: np.ndarray, margin: float = MARGIN, known: np.ndarray | None = None
) -> np.ndarray:
    """The centre of pressure (T, 2) brought `margin` inside the planted
    soles' `support` where it was not: moved from p towards the soles'
    centre c just as far as needed (the first point of the segment c -> p,
    from p's end, inside every hull edge by `margin`), by at most
    `MOST_MOVED`; unchanged with no foot down. `known`: the pressure's
    `Support.margin`, when already found."""
    points, down, radius = support.points, support.down, support.radius
    out = pressure.copy()
    margins = support.margin(pressure) if known is None else known
    needed = np.flatnonzero(margins < margin)  # NaN compares False
    if not len(needed):
        return out
    points, down, pressure = points[needed], down[needed], pressure[needed]
    centre = np.einsum("tki,tk->ti", points, down) / np.maximum(down.sum(axis=1), 1)[:, None]
    a, edge, hull, _ = (part[needed] for part in support.edges)
    inward = np.stack([-edge[..., 1], edge[..., 0]], -1) / np.maximum(np.linalg.norm(edge, axis=-1), 1e-12)[..., None]
    clearance = np.einsum("tei,tei->te", inward, centre[:, None] - a) - (margin - radius)  # c's room inside each edge
    approach = np.einsum("tei,ti->te", inward, pressure - centre)  # < 0: going from c towards p leaves that edge
    reach = np.where(hull & (approach < -1e-12), clearance / np.maximum(-approach, 1e-12), np.inf).min(axis=1)
    reach[~hull.any(axis=1)] = 0.0  # a flat support (one foot of line contacts) has no inside: its centre
    step = np.clip(reach, 0.0, 1.0)
    moved = centre + step[:, None] * (pressure - centre) - pressure
    out[needed] = pressure + capped(moved, MOST_MOVED)
    return out


def centre_of_mass_shift(com: np.ndarray, pressure: np.ndarray, desired: np.ndarray, fps: float) -> np.ndarray:
    """The horizontal shift (T, 2) of the centre of mass that moves the
    centre of pressure from `pressure` to `desired`: Drake's `ZmpPlanner` on
    the difference (`synthesis.centre_of_mass_path`: a linear inverted
    pendulum at the clip's mean height, with its preview of the whole
    clip), from rest."""
    change = desired - pressure
    if not np.any(np.abs(change) > 1e-9):
        return np.zeros((len(com), 2))
    return centre_of_mass_path(change, fps, float(np.mean(com[:, 2])), start=np.zeros(4), tracking=TRACKING)


def balancing_shift(
    support: Support, com: np.ndarray, pressure: np.ndarray, fps: float, passes: int = PASSES
) -> np.ndarray:
    """The ZMP filter: the sideways shift (T, 2) of the whole body that
    brings the clip's centre of pressure `MARGIN` inside its `support`.
    Each pass asks `ZmpPlanner` for the shift that moves the centre of
    pressure where `desired_pressure` wants it, on the body as the passes
    so far have moved it (`shifted_pressure`), and takes it (or half, or a
    quarter) if that leaves less `shortfall`: the planner's pendulum is not
    the clip's, and on a noisy capture a whole step can make things worse.
    At most `passes` passes; fewer once nothing is left to move or no step
    helps. No frame is moved further than `MOST_MOVED`; frames without a
    finite centre of pressure are left out."""
    shift = np.zeros((len(com), 2))
    usable = np.isfinite(pressure).all(axis=1) & np.isfinite(com).all(axis=1)
    if not usable.all():  # a frame without a centre of pressure (a fall: no lift) is not the filter's to move
        support = Support(support.points, support.down & usable[:, None], support.radius)
        com = np.where(usable[:, None], com, np.nan_to_num(com))
        pressure = np.where(usable[:, None], pressure, com[:, :2])
    moved, margins = pressure, support.margin(pressure)
    left = _shortfall(margins)
    for _ in range(passes):
        desired = desired_pressure(support, moved, known=margins)
        if np.max(np.abs(desired - moved), initial=0.0) < SETTLED:
            break
        step = centre_of_mass_shift(com, moved, desired, fps)
        for fraction in STEP_FRACTIONS:
            trial = capped(shift + fraction * step, MOST_MOVED)
            trial_pressure = shifted_pressure(com, pressure, trial, fps)
            trial_margins = support.margin(trial_pressure)
            trial_left = _shortfall(trial_margins)
            if trial_left < left and np.isfinite(trial).all():
                shift, moved, margins, left = trial, trial_pressure, trial_margins, trial_left
                break
        else:
            break
    return shift


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


def capped(vectors: np.ndarray, longest: float) -> np.ndarray:
    """Vectors (T, 2) shortened to at most `longest`."""
    return vectors * np.minimum(1.0, longest / np.maximum(np.linalg.norm(vectors, axis=1), 1e-12))[:, None]


class TorqueDemand:
    """What each joint must exert to perform a clip: Drake's inverse
    dynamics of the robot's `MultibodyPlant` along the clip, the floating
    base's share carried by the planted feet (the least contact wrenches,
    at each sole's centre, that do so), compared with the effort limits."""

    def __init__(self, emb: Embodiment):
        from pydrake.multibody.plant import MultibodyPlant

        self.emb = emb
        self.plant = plant = MultibodyPlant(0.0)
        self.model = emb.add_to_plant(plant, builtin_pd=False)
        plant.Finalize()
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
