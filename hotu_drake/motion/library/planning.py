"""Shared planning for the library's motions: the scene every planner gets
(body, time grid, seeded RNG) and the helpers that place the pelvis over
the feet, swing the arms, aim the hands and shape the fingers."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from hotu_drake.motion.synthesis import (
    Body,
    HandTarget,
    Plan,
    Step,
    balanced_pelvis_path,
    finger_joints,
    foot_tracks,
    hand_rotation,
    path_steps,
    pelvis_over_feet,
    reachable_height,
    smooth_under,
    stance_pose,
)
from hotu_drake.rotations import rot_x, rot_y, rot_z

KNEE = 0.2  # knee bend (rad) of a straight-ish supporting leg


@dataclass
class Scene:
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


def stand(sc: Scene) -> dict:
    """Both feet side by side at the origin, facing +x."""
    return stance_pose(0.0, 0.0, 0.0, sc.width)


def heading_frame(heading: np.ndarray, local: np.ndarray) -> np.ndarray:
    """World vectors (T, 3) of `local` (T, 3) or (3,) given in the heading frame."""
    return np.einsum("tij,tj->ti", rot_z(heading), np.broadcast_to(local, (len(heading), 3)))


@dataclass
class Base:
    """A plan's lower body and pelvis, before arms, hands and objects."""

    plan: Plan
    heading: np.ndarray  # (T,) heading of the body (no pelvis twist)

    def point(self, local: np.ndarray) -> np.ndarray:
        """World (T, 3) of points given relative to the pelvis in the heading frame."""
        return self.plan.pelvis + heading_frame(self.heading, local)

    def vector(self, local: np.ndarray) -> np.ndarray:
        return heading_frame(self.heading, np.asarray(local, dtype=float))


def plan_base(
    sc: Scene,
    feet: dict,
    *,
    drop: np.ndarray | float = 0.0,
    shift: np.ndarray | None = None,
    pitch: np.ndarray | float = 0.0,
    twist: np.ndarray | float = 0.0,
    roll: np.ndarray | float = 0.0,
    sway: float = 0.0,
    sigma: float = 0.15,
    balanced: bool = False,
) -> Base:
    """Pelvis over the feet: `drop` metres below the highest comfortable
    height, `shift` (T, 2) in the heading frame, tilted by `pitch`, `roll`
    and turned by `twist` relative to the heading. `balanced`: its planar
    path planned to keep the centre of pressure on the feet
    (`balanced_pelvis_path`, for locomotion) instead of low-passed over
    them with a fixed `sway`."""
    n = len(sc.t)
    xy, heading = pelvis_over_feet(feet, sc.body, sc.fps, sigma, sway * sc.s)
    if balanced:
        xy = balanced_pelvis_path(feet, sc.body, sc.fps, heading)
    if shift is not None:
        xy = xy + heading_frame(heading, np.column_stack([shift, np.zeros(n)]))[:, :2]
    rot = rot_z(heading + twist) @ rot_y(np.broadcast_to(pitch, n)) @ rot_x(np.broadcast_to(roll, n))
    z = reachable_height(xy, rot, feet, sc.body, KNEE, sc.fps)
    if balanced:  # no sudden drops of the pelvis: they are forces the feet would have to give
        z = smooth_under(z, sc.fps)
    z = z - drop
    plan = Plan(fps=sc.fps, pelvis=np.column_stack([xy, z]), pelvis_rot=rot, feet=feet)
    return Base(plan, heading)


def set_hand_shape(plan: Plan, side: str, grip, thumb_flex, opposition) -> None:
    """Finger trajectories from closure fractions (see `finger_joints`)."""
    n = plan.num_frames
    grip = np.broadcast_to(np.asarray(grip, dtype=float).reshape(n, -1), (n, 4))
    plan.joints.update(finger_joints(side, grip, np.broadcast_to(thumb_flex, n), np.broadcast_to(opposition, n)))


def set_joints(plan: Plan, **joints) -> None:
    """Direct joint trajectories (scalars are broadcast)."""
    n = plan.num_frames
    for name, values in joints.items():
        plan.joints[name] = np.broadcast_to(np.asarray(values, dtype=float), (n,)).copy()


def arm_swing(base: Base, step: float) -> None:
    """Arms swinging opposite to the legs, shoulders counter-rotating the pelvis."""
    feet = base.plan.feet
    forward = np.column_stack([np.cos(base.heading), np.sin(base.heading)])
    lead = np.sum((feet["left"][0][:, :2] - feet["right"][0][:, :2]) * forward, axis=1) / step
    swing = 0.4 * lead
    set_joints(
        base.plan,
        left_shoulder_y=swing,
        right_shoulder_y=-swing,
        left_elbow_y=-0.3 - 0.35 * np.maximum(-swing, 0.0),
        right_elbow_y=-0.3 - 0.35 * np.maximum(swing, 0.0),
        torso_z=0.1 * lead,
    )


def hand_target(base: Base, side: str, local_pos, fingers, palm, elbow, weight=1.0) -> HandTarget:
    """A hand target given in the pelvis-heading frame (arrays (T, 3) or (3,))."""
    n = base.plan.num_frames
    return HandTarget(
        position=base.point(np.broadcast_to(local_pos, (n, 3))),
        rotation=hand_rotation(side, base.vector(np.broadcast_to(fingers, (n, 3))), base.vector(palm)),
        elbow=base.vector(np.broadcast_to(elbow, (n, 3))),
        weight=np.broadcast_to(np.asarray(weight, dtype=float), (n,)),
    )


def yaw_pose(position: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(T, 7) object poses from positions and yaw angles."""
    yaw = np.broadcast_to(yaw, (len(position),))
    quat = np.column_stack([np.cos(yaw / 2), np.zeros((len(yaw), 2)), np.sin(yaw / 2)])
    return np.column_stack([position, quat])


def fist(plan: Plan, side: str, amount=1.0) -> None:
    """Close a hand into a fist by `amount` (0..1, scalar or (T,))."""
    amount = np.asarray(amount, dtype=float)
    set_hand_shape(plan, side, np.repeat(np.atleast_1d(0.95 * amount)[:, None], 4, 1), 0.6 * amount, 0.7 * amount)


def walk_along(
    sc: Scene, path: np.ndarray, step: float, step_time: float, count: int, first: str = "right", heel: float = 0.3
) -> Plan:
    """Steps along a planar path of (x, y, heading) poses from standing, the
    pelvis balanced over them (`stepping`); each foot pushes off with its
    heel raised `heel` rad."""
    steps, _ = path_steps(path, first, 0.4, step_time, 0.78 * step_time, count, sc.width, heel)
    return stepping(sc, steps, step, step_time)


def stepping(sc: Scene, steps: list[Step], step: float, step_time: float, swing: bool = True) -> Plan:
    """The plan of a walk over `steps`: the feet's tracks, the pelvis planned
    over them for balance, a foot down on every frame (`Plan.grounded`), the
    arms swinging with `step` (m) unless not `swing`."""
    feet = foot_tracks(sc.t, sc.body, stand(sc), steps)
    base = plan_base(sc, feet, sigma=0.4 * step_time, pitch=0.04, balanced=True)
    base.plan.grounded = True
    if swing:
        arm_swing(base, step)
    set_joints(base.plan, neck_y=-0.04)
    return base.plan
