"""What the whole-body controller tracks along a clip of its embodiment.

The clip's state at any time (a looping clip with its root motion: each
pass starts where the last one ended, turned as it ended), its contact
schedule, and a centre-of-mass path planned by Drake's `ZmpPlanner` from
the clip's footsteps (the pressure under the stance foot's ankle on one
foot, moving between the feet in double support; the linear inverted
pendulum at the clip's mean centre-of-mass height), whose LQR feedback gives the CoM
acceleration for the robot's actual CoM state: a pushed robot's CoM is
brought back along the plan, not merely pulled to where the clip is.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.math import RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.planning import ZmpPlanner
from pydrake.trajectories import PiecewisePolynomial

from hotu_drake.control.whole_body_qp import feet_soles, sole_corners, soles_on_edges, soles_rolling_with_legs
from hotu_drake.embodiment import Embodiment
from hotu_drake.motion.clip import MotionClip, lifts
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.motion.synthesis import smooth
from hotu_drake.rotations import heading_yaw, quat_multiply, quat_to_matrix, rot_z

GRAVITY = 9.81
PRESSURE_SMOOTHING = 0.05  # s: the clip's CoM acceleration averaged over this before it becomes a ZMP path
PLAN_WEIGHTS = (np.eye(2), 1e-3 * np.eye(2))  # ZmpPlanner's Qy (on the ZMP's error) and R (on its input)
HOLD_AFTER = 1.0  # s: a plan goes on this long past its clip's end, standing still
SHIFT_TIME = 0.3  # s: how long the planned pressure takes to move between a stance foot and the clip's own
NOMINAL_RATE = 240.0  # Hz: the plan's nominal CoM sampled this often, interpolated between
SUPPORT_SHRINK = 0.5  # the support the plan keeps the pressure in: the soles shrunk this much toward their anchors
HALF_FRAME_SLACK = 1e-6  # frames: a clip time this near a half frame counts as on it
# `ClipPlan.velocities` keeps this many times' velocities: a control step asks for its own time and half a
# frame either side (its reference's accelerations), and the next step asks for two of those again.
VELOCITY_CACHE = 8
# s: a robot standing on flat soles that roll only as its legs lean (H1: no ankle roll) holds a clip's first
# frame this long before the clip moves, so that the plan's preview shifts its weight toward the first
# stance foot before the clip lifts the other (`lead_in_for`). With both soles flat its legs cannot lean:
# its centre of mass moves sideways in double support at a third to a half of what the plan asks, and the
# clips' first steps come 0.3-0.45 s in. H1, library motions from ten starts: walk_turn_left 10/10 (8/10
# without), walk_turn_right 10/10 (9/10); BRUCE (line feet, free to roll) fell more often with it.
WEIGHT_SHIFT_LEAD_IN = 0.5
# A clip's first frame is at rest (a lead-in may hold it) with no joint faster than this (rad/s) and its root
# slower than this (m/s): held at rest, a clip caught mid-motion (H1's boxing 7-9 frames in) jumps to speed.
AT_REST_JOINT_SPEED, AT_REST_ROOT_SPEED = 1.0, 0.3
# m: a foot the clip lifts whose sole stays this near the floor over the whole lift (between two frames down),
# while at some frame of it one end of the sole is `IN_PLACE_TILT` higher than the other, is lifted in place:
# its heel rises and comes down over toes that stay down (`ClipPlan.lifted_in_place`). A sole that only slides
# flat across the floor is not.
IN_PLACE_HEIGHT, IN_PLACE_TILT = 0.01, 0.01


def pendulum_frequency(height: float) -> float:
    """The linear inverted pendulum's frequency sqrt(g / h) (1/s) for a CoM `height` m up (taken as 0.1 at least)."""
    return float(np.sqrt(GRAVITY / max(float(height), 0.1)))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The z of the cross product of 2-D vectors (rows)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _convex_hull(points: np.ndarray) -> np.ndarray:
    """The corners (counter-clockwise) of the convex hull of 2-D `points` (monotone chain)."""
    ordered = sorted(set(map(tuple, np.round(points, 9).tolist())))  # distinct, by x then y
    if len(ordered) < 3:
        return np.array(ordered, float).reshape(-1, 2)

    def half(points):  # in Python floats: a numpy call per point cost a fifth of a control step
        chain = []
        for x, y in points:
            while len(chain) >= 2:
                (ax, ay), (bx, by) = chain[-2], chain[-1]
                if (bx - ax) * (y - ay) - (by - ay) * (x - ax) > 0.0:
                    break
                chain.pop()
            chain.append((x, y))
        return chain[:-1]

    return np.array(half(ordered) + half(ordered[::-1]))


def into_support(point: np.ndarray, support: np.ndarray) -> np.ndarray:
    """`point` (2,), or the nearest point of the convex hull of `support` (K, 2) if it lies outside it."""
    if len(support) == 0:
        raise ValueError("into_support: an empty support holds no point")
    hull = _convex_hull(support)
    if len(hull) == 1:
        return hull[0].copy()
    edges = np.roll(hull, -1, axis=0) - hull
    if len(hull) >= 3 and np.all(_cross(edges, point - hull) >= 0.0):
        return point.copy()
    share = np.clip(np.einsum("ij,ij->i", point - hull, edges) / np.einsum("ij,ij->i", edges, edges), 0.0, 1.0)
    nearest = hull + share[:, None] * edges
    return nearest[np.argmin(np.linalg.norm(nearest - point, axis=1))]


def footstep_zmp(
    times: np.ndarray,
    planted: list[tuple[str, ...]],
    anchors: list[dict[str, np.ndarray]],
    clip_zmp: np.ndarray,
    supports: list[np.ndarray | None],
) -> np.ndarray:
    """The ZMP path (T, 2) from a clip's footsteps: on one foot, that foot's
    anchor (`anchors`, per frame and foot); on both, from the last stance
    foot's anchor to the next's (a short double support), or the clip's own
    ZMP (`clip_zmp`) kept inside the planted soles (`supports`, per frame
    the soles' points, or None in the air: there the last frame's ZMP is
    held, as the clip's own blows up in a jump) with `SHIFT_TIME` s of blending
    into and out of it (a long one; a clip that never stands on one foot
    keeps its own path, inside its support)."""
    zmp = np.array([z if support is None else into_support(z, support) for z, support in zip(clip_zmp, supports)])
    for k in range(1, len(zmp)):  # in the air (a jump), the pressure planned where the robot last stood
        if supports[k] is None:
            zmp[k] = zmp[k - 1]
    single = np.array([len(names) == 1 for names in planted])
    frames = len(times)
    start = 0
    while start < frames:
        end = start
        while end + 1 < frames and single[end + 1] == single[start] and planted[end + 1] == planted[start]:
            end += 1
        if single[start]:
            name = planted[start][0]
            zmp[start : end + 1] = [anchors[k][name] for k in range(start, end + 1)]
        elif planted[start]:
            before = anchors[start - 1][planted[start - 1][0]] if start > 0 and single[start - 1] else None
            after = anchors[end + 1][planted[end + 1][0]] if end + 1 < frames and single[end + 1] else None
            t0 = times[start - 1] if before is not None else times[start]
            t1 = times[end + 1] if after is not None else times[end]
            for k in range(start, end + 1):
                t = times[k]
                if before is not None and after is not None and t1 - t0 <= 2.0 * SHIFT_TIME:
                    zmp[k] = before + (t - t0) / (t1 - t0) * (after - before)
                    continue
                if before is not None and t - t0 < SHIFT_TIME:
                    zmp[k] = before + (t - t0) / SHIFT_TIME * (zmp[k] - before)
                if after is not None and t1 - t < SHIFT_TIME:
                    zmp[k] = after + (t1 - t) / SHIFT_TIME * (zmp[k] - after)
        start = end + 1
    return zmp


def _lifted_in_place(down: np.ndarray, lowest: np.ndarray, highest: np.ndarray) -> np.ndarray:
    """The frames (T,) of each lift of a foot (`down` False between two
    frames down: not one the clip starts or ends with, nor, in a loop, one
    across its seam) whose sole's lowest corner (`lowest`, m, per frame)
    stays within `IN_PLACE_HEIGHT` of the floor over all of it, its highest
    (`highest`) rising `IN_PLACE_TILT` above it on some frame."""
    out = np.zeros(len(down), bool)
    for start, stop in lifts(down):
        lift = slice(start, stop)
        if start > 0 and stop < len(down) and lowest[lift].max() < IN_PLACE_HEIGHT:
            out[lift] = np.max(highest[lift] - lowest[lift]) > IN_PLACE_TILT
    return out


def lead_in_for(clip: MotionClip, embodiment: Embodiment) -> float:
    """How long (s) `embodiment` holds `clip`'s first frame before
    performing it from there: `WEIGHT_SHIFT_LEAD_IN` for a robot on flat
    soles that roll only as its legs lean, if the clip starts at rest
    (`AT_REST_JOINT_SPEED`, `AT_REST_ROOT_SPEED`); none otherwise."""
    if clip.num_frames == 0 or not embodiment.floating_base:
        return 0.0
    if np.abs(clip.joint_velocities[0]).max(initial=0.0) > AT_REST_JOINT_SPEED:
        return 0.0
    if np.linalg.norm(clip.root_linear_velocity[0]) > AT_REST_ROOT_SPEED:
        return 0.0
    plant = MultibodyPlant(0.0)
    model = embodiment.add_to_plant(plant, builtin_pd=False)
    plant.Finalize()
    soles = feet_soles(plant, embodiment)
    on_edges = soles_on_edges(soles_rolling_with_legs(plant, model, embodiment, soles), soles)
    return WEIGHT_SHIFT_LEAD_IN if on_edges and all(on_edges.values()) else 0.0


def standing_clip(embodiment: Embodiment, seconds: float = 2.0, fps: float = 30.0) -> MotionClip:
    """`embodiment` standing still in its standing pose, both feet down: the
    clip a controller holds a robot up by (a teacher's clip for a start that
    follows no reference)."""
    frames = int(round(seconds * fps)) + 1
    return MotionClip.from_positions(
        embodiment.name,
        "standing",
        fps,
        embodiment.joint_names,
        np.tile(embodiment.standing_pose, (frames, 1)),
        np.tile([0.0, 0.0, embodiment.standing_root_height], (frames, 1)),
        np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1)),
        contact_names=["left_foot", "right_foot"],
        contacts=np.ones((frames, 2), bool),
    )


def interp_rows(at: float, times: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """`rows` (T, k), one per time of the increasing `times`, linearly
    interpolated at `at` (held past either end): `np.interp` on every
    column at once, with its arithmetic (bit for bit its values, for finite
    rows)."""
    if not at < times[-1]:
        return rows[-1].copy() if at == at else np.full(rows.shape[1], np.nan)
    if at < times[0]:
        return rows[0].copy()
    j = int(np.searchsorted(times, at, side="right")) - 1
    if times[j] == at:
        return rows[j].copy()
    slope = (rows[j + 1] - rows[j]) / (times[j + 1] - times[j])
    return slope * (at - times[j]) + rows[j]


class Planar:
    """x -> R x + s with R a turn about z: where pass k of a loop puts the clip."""

    def __init__(self, rotation: np.ndarray | None = None, shift: np.ndarray | None = None):
        self.rotation = np.eye(3) if rotation is None else rotation
        self.shift = np.zeros(3) if shift is None else shift

    def __matmul__(self, other: Planar) -> Planar:
        return Planar(self.rotation @ other.rotation, self.rotation @ other.shift + self.shift)

    def inverse(self) -> Planar:
        return Planar(self.rotation.T, -self.rotation.T @ self.shift)

    def point(self, x: np.ndarray) -> np.ndarray:
        return self.rotation @ x + self.shift


# The map of a loop's first pass, and of a clip that does not loop (no `Planar` is changed once made).
IDENTITY = Planar()


class ClipPlan:
    """A clip of `embodiment` as the controller's reference, on `plant` (a
    plant holding that embodiment as `model`; `context`, one of its
    contexts, is scratch space while the CoM path is planned)."""

    def __init__(self, clip: MotionClip, plant: MultibodyPlant, model, embodiment: Embodiment, context, loop: bool):
        self.clip, self.loop, self.embodiment = clip, loop, embodiment
        self.plant, self.model = plant, model
        self.playback = ClipPlayback(clip, loop=False)
        # Where each of the clip's joints sits in the plant's positions and velocities, and the floating root.
        joints = [plant.GetJointByName(name, model) for name in clip.joint_names]
        self._joint_positions = np.array([joint.position_start() for joint in joints])
        self._joint_velocities = np.array([joint.velocity_start() for joint in joints])
        self._root = plant.GetBodyByName(embodiment.spec.root.name, model)
        # The floating root's velocities (its joint's: angular, then linear, in the world), and all the clip sets.
        self._root_velocities = np.zeros(0, int)
        self._root_positions = np.zeros(0, int)  # its quaternion (w x y z) and position in the plant's positions
        if embodiment.floating_base:
            self._root_velocities = self._root.floating_velocities_start_in_v() + np.arange(6)
            self._root_positions = self._root.floating_positions_start() + np.arange(7)
        self._clip_velocities = np.r_[self._joint_velocities, self._root_velocities]
        self.period = (clip.num_frames - 1) / clip.fps
        self._step = Planar()  # what one pass of a loop does to the root: turn, then shift
        if loop and embodiment.floating_base:
            ends = quat_to_matrix(clip.root_quaternion[[0, -1]])
            turn = rot_z(float(heading_yaw(ends[1]) - heading_yaw(ends[0])))
            shift = clip.root_position[-1] - turn @ clip.root_position[0]
            self._step = Planar(turn, np.array([shift[0], shift[1], 0.0]))
        self._velocity_cache: dict[float, np.ndarray] = {}  # `velocities` at the last few times asked
        self.contacts = {name: clip.contact(name).astype(bool) for name in clip.contact_names}
        self._placements = [Planar()]  # `placement` of each pass so far
        self._pass_maps: dict[int, tuple[Planar, Planar]] = {}  # per pass, into the plan and back (`_plan_maps`)
        self._pass_turns: dict[int, np.ndarray] = {}  # `_pass_turn`
        self._last_frame = (np.nan, 0)  # `frame`'s last time and answer
        self._pelvis = plant.GetBodyByName(embodiment.key_bodies["pelvis"], model)  # `pelvis_travel`
        self._feet = {
            f"{side}_foot": plant.GetBodyByName(embodiment.key_bodies[f"{side}_foot"], model)
            for side in ("left", "right")
            if f"{side}_foot" in embodiment.key_bodies
        }
        self._corners = {name: sole_corners(embodiment, foot.name()) for name, foot in self._feet.items()}
        # Where on each sole (its foot's frame) the plan puts the pressure standing on it alone.
        self.anchors = {name: self._sole_anchor(self._corners[name]) for name in self._feet}
        # Where the plan keeps the pressure on each sole (3, K in the foot's frame): shrunk toward its anchor.
        self._support = {
            name: (self.anchors[name] + (1.0 - SUPPORT_SHRINK) * (corners - self.anchors[name])).T
            for name, corners in self._corners.items()
        }
        self._plan_com(context)

    @property
    def root_body(self):
        """The robot's root body on the plan's plant."""
        return self._root

    def feet_positions(self, context) -> list[np.ndarray] | None:
        """The left and right feet's origins (world) in `context` of the
        plan's plant (the reference, as `set_reference` sets it); None
        without both feet."""
        if len(self._feet) < 2:
            return None
        feet = (self._feet[f"{side}_foot"] for side in ("left", "right"))
        return [self.plant.EvalBodyPoseInWorld(context, foot).translation() for foot in feet]

    @staticmethod
    def _sole_anchor(corners: np.ndarray) -> np.ndarray:
        """Where on a sole (a point in the foot's frame) the plan puts the
        centre of pressure while the robot stands on that foot alone: under
        the ankle (where its torque holds the weight with the least effort),
        kept within the middle half of the sole's length, across its middle."""
        low, high = corners[:, 0].min(), corners[:, 0].max()
        quarter = (high - low) / 4.0
        return np.array([np.clip(0.0, low + quarter, high - quarter), corners[:, 1].mean(), corners[:, 2].mean()])

    # --- the clip's state ------------------------------------------------------

    def pass_at(self, time: float) -> tuple[int, float]:
        """The pass (0, 1, ...) of a looping clip at `time`, and the clip time within it."""
        if not self.loop or self.period <= 0.0:
            return 0, min(max(time, 0.0), self.period)
        index = math.floor(max(time, 0.0) / self.period)
        return index, time - index * self.period

    def placement(self, index: int) -> Planar:
        """Where pass `index` of a loop puts the clip (pass 0: where it is)."""
        while len(self._placements) <= index:
            self._placements.append(self._step @ self._placements[-1])
        return self._placements[index]

    def _pass_turn(self, index: int) -> np.ndarray:
        """`placement(index)`'s rotation as a unit quaternion (w x y z)."""
        turn = self._pass_turns.get(index)
        if turn is None:
            turn = self._pass_turns[index] = RotationMatrix(self.placement(index).rotation).ToQuaternion().wxyz()
        return turn

    def set_reference(self, context, time: float) -> None:
        """Set `context` (of the plan's plant) to the clip's state at `time`:
        its positions and velocities in one call (the root's pose composed
        with the pass's placement here, not through `SetFreeBodyPose`: a
        fifteenth of the control step)."""
        index, clip_time = self.pass_at(time)
        plant = self.plant
        positions, velocities = plant.GetPositions(context), plant.GetVelocities(context)
        positions[self._joint_positions] = self.playback.lerp(self.clip.joint_positions, clip_time)
        velocities[self._clip_velocities] = self.velocities(time)[self._clip_velocities]
        if self.embodiment.floating_base:  # the root's quaternion (w x y z), then its position
            quaternion, position = self.playback.root_pose_at(clip_time)
            placement = self.placement(index)
            turned = quat_multiply(self._pass_turn(index), quaternion)
            positions[self._root_positions[:4]] = turned if turned[0] >= 0.0 else -turned  # w >= 0, as Drake sets it
            positions[self._root_positions[4:]] = placement.rotation @ position + placement.shift
        plant.SetPositionsAndVelocities(context, np.concatenate([positions, velocities]))

    def root_position(self, time: float) -> np.ndarray:
        """The clip's root position (world) at `time`, a loop's pass placed."""
        index, clip_time = self.pass_at(time)
        placement = self.placement(index)
        return placement.rotation @ self.playback.root_pose_at(clip_time)[1] + placement.shift

    def pelvis_travel(self, start: float, duration: float) -> float:
        """How far (m, horizontally) the clip's pelvis moves over `duration`
        s from `start` (a loop carrying its root motion on): what a run that
        follows the clip is measured against."""
        scratch, ends = self.plant.CreateDefaultContext(), []
        for time in (start, start + duration):
            self.set_reference(scratch, time)
            ends.append(self.plant.EvalBodyPoseInWorld(scratch, self._pelvis).translation())
        return float(np.linalg.norm((ends[1] - ends[0])[:2]))

    def velocities(self, time: float) -> np.ndarray:
        """The plant's generalized velocities in the clip's state at `time`
        (those `set_reference` sets, with no context to set: the floating
        root's angular then linear velocity in the world, then the joints'),
        read-only: the controller asks for each time three times over its
        steps (`VELOCITY_CACHE`)."""
        cached = self._velocity_cache.get(time)
        if cached is not None:
            return cached
        index, clip_time = self.pass_at(time)
        out = np.zeros(self.plant.num_velocities())
        if self.loop or time < self.period:  # a clip that has ended holds its last pose, at rest
            out[self._joint_velocities] = self.playback.lerp(self.clip.joint_velocities, clip_time)
            if len(self._root_velocities):
                turn = self.placement(index).rotation
                omega = self.playback.lerp(self.clip.root_angular_velocity, clip_time)
                linear = self.playback.lerp(self.clip.root_linear_velocity, clip_time)
                out[self._root_velocities] = np.concatenate([turn @ omega, turn @ linear])
        out.flags.writeable = False
        if len(self._velocity_cache) >= VELOCITY_CACHE:
            del self._velocity_cache[next(iter(self._velocity_cache))]
        self._velocity_cache[time] = out
        return out

    def planted(self, time: float) -> dict[str, bool]:
        """Per contact name (`left_foot`, `right_foot`), whether the clip has that foot down at `time`."""
        frame = self.frame(time)
        return {name: bool(flags[frame]) for name, flags in self.contacts.items()}

    def frame(self, time: float) -> int:
        """The clip's frame nearest `time` (within its pass of a loop); a time
        halfway between two frames (every other step of a 60 Hz controller on
        a 30 fps clip) takes the later, whatever its last bits: Python's round
        takes the even one, and a time one bit either side of the half flipped
        a foot's contact (49/60 s gave frame 24, 0.8166666666666668 s 25)."""
        if time == self._last_frame[0]:  # asked some eight times a control step
            return self._last_frame[1]
        _, clip_time = self.pass_at(time)
        frame = min(max(math.floor(clip_time * self.clip.fps + 0.5 + HALF_FRAME_SLACK), 0), self.clip.num_frames - 1)
        self._last_frame = (time, frame)
        return frame

    def _frames_to_landing(self, flags: np.ndarray, frame: int) -> int:
        """Frames from `frame` until `flags` is next down (a loop's next pass
        counts; an ended clip holds its last frame, so it may never come)."""
        ahead = flags[frame:]
        if ahead.any():
            return int(np.argmax(ahead))
        return len(ahead) + (int(np.argmax(flags[1:])) if self.loop and flags.any() else 0)

    def swing_progress(self, name: str, time: float) -> float:
        """How far (0 at its last frame down, 1 at its next) foot `name` is
        through its swing at `time` in the clip's schedule (1 while it is
        down). A loop's swing may span the seam between passes; a clip that
        does not loop holds its last frame, so a foot up at its end stays
        short of 1."""
        flags, frame = self.contacts[name], self.frame(time)
        if flags[frame]:
            return 1.0
        lifted = self._frames_since_down(flags, frame)
        return lifted / (lifted + self._frames_to_landing(flags, frame))

    def lifted_in_place(self, name: str, time: float) -> bool:
        """Whether the clip has foot `name` up at `time` in a lift whose sole
        never leaves the floor (`IN_PLACE_HEIGHT`): the back foot of a lunge,
        its heel rising over its toes and coming down again (the library's
        contacts end as the ankle moves, `generate._foot_contacts`)."""
        flags = self._in_place.get(name)
        return flags is not None and bool(flags[self.frame(time)])

    def since_lifting(self, name: str, time: float) -> float:
        """Seconds from the clip's last frame with foot `name` down to `time`
        (0 while it is down; a loop's swing may span the seam between passes)."""
        flags, frame = self.contacts[name], self.frame(time)
        return 0.0 if flags[frame] else self._frames_since_down(flags, frame) / self.clip.fps

    def _frames_since_down(self, flags: np.ndarray, frame: int) -> int:
        """Frames back from `frame` (up) to the last frame `flags` is down (a
        loop's pass before counts: its last frame is this one's first)."""
        since = flags[frame::-1]  # back to its liftoff
        lifted = int(np.argmax(since)) if since.any() else frame + 1
        if self.loop and not since.any():
            lifted += int(np.argmax(flags[-2::-1])) if flags.any() else 0
        return lifted

    def until_lifting(self, name: str, time: float) -> float:
        """Seconds from `time` until the clip next lifts foot `name` (0 while
        it is up; a loop's next pass counts; infinite if it never does, as in
        a clip that has ended)."""
        flags, frame = self.contacts[name], self.frame(time)
        if not flags[frame]:
            return 0.0
        if not self.loop and time >= self.period:
            return np.inf
        up = ~flags[frame:]
        if up.any():
            return int(np.argmax(up)) / self.clip.fps
        if self.loop and not flags.all():
            return (len(up) + int(np.argmax(~flags[1:]))) / self.clip.fps
        return np.inf

    def until_landing(self, name: str, time: float) -> float:
        """Seconds from `time` until the clip next has foot `name` down (0
        while it is down; a loop's next pass counts, an ended clip holds its
        last frame)."""
        return self._frames_to_landing(self.contacts[name], self.frame(time)) / self.clip.fps

    # --- the centre of mass --------------------------------------------------------

    def _plan_com(self, context) -> None:
        """The clip's CoM path, the ZMP path from its footsteps, and the
        ZmpPlanner over them: three passes of a loop (the controller follows
        the first from the clip's first frame, then the middle one for every
        later pass, so the plan's preview never sees an end), or the clip; then
        its last frame held for `HOLD_AFTER` s (a clip that ends, at rest; a
        loop, only so that the planner's last ZMP is held)."""
        clip, plant, fps = self.clip, self.plant, self.clip.fps
        passes = 3 if self.loop else 1
        times, com, planted, anchors, supports = [], [], [], [], []
        # Each sole's lowest and highest corner (z: the same on any pass).
        lowest, highest = ({name: np.zeros(clip.num_frames) for name in self._feet} for _ in range(2))
        for index in range(passes):
            for frame in range(clip.num_frames - (1 if index < passes - 1 else 0)):
                time = index * self.period + frame / fps
                self.set_reference(context, time)
                times.append(time)
                com.append(plant.CalcCenterOfMassPositionInWorld(context, [self.model]))
                feet_down = (name for name, down in self.planted(time).items() if down and name in self._feet)
                planted.append(tuple(sorted(feet_down)))  # (a clip's hand contacts are not footsteps)
                poses = {name: plant.EvalBodyPoseInWorld(context, foot) for name, foot in self._feet.items()}
                if index == passes - 1:  # (the pass that has every frame)
                    for name, pose in poses.items():
                        heights = pose.multiply(self._corners[name].T)[2]
                        lowest[name][frame], highest[name][frame] = heights.min(), heights.max()
                anchors.append({name: pose.multiply(self.anchors[name])[:2] for name, pose in poses.items()})
                down = [name for name in poses if name in planted[-1]]
                soles = [poses[name].multiply(self._support[name])[:2].T for name in down]
                supports.append(np.vstack(soles) if soles else None)
        self._in_place = {
            name: _lifted_in_place(self.contacts[name], lowest[name], highest[name])
            for name in lowest
            if name in self.contacts
        }
        times, com = np.array(times), np.array(com)
        extra = times[-1] + np.arange(1, int(HOLD_AFTER * fps) + 1) / fps
        times, com = np.r_[times, extra], np.vstack([com, np.repeat(com[-1:], len(extra), axis=0)])
        planted += [planted[-1]] * len(extra)
        anchors += [anchors[-1]] * len(extra)
        supports += [supports[-1]] * len(extra)
        velocity = np.gradient(com, 1.0 / fps, axis=0)
        acceleration = smooth(np.gradient(velocity, 1.0 / fps, axis=0), fps, PRESSURE_SMOOTHING)
        if not self.loop:
            velocity[-len(extra) :], acceleration[-len(extra) :] = 0.0, 0.0
        # One (T, 9) array, read all at once by `com_reference`; the CoM, its velocity and acceleration views of it.
        self.com_times, self._com_rows = times, np.hstack([com, velocity, acceleration])
        self.com, self.com_velocity, self.com_acceleration = np.hsplit(self._com_rows, 3)
        self.height = float(np.mean(com[:, 2]))
        clip_zmp = com[:, :2] - com[:, 2:3] / (GRAVITY + acceleration[:, 2:3]) * acceleration[:, :2]
        self.zmp = footstep_zmp(times, planted, anchors, clip_zmp, supports)
        self.planner = ZmpPlanner()
        start = np.r_[com[0, :2], velocity[0, :2]]
        zmp = PiecewisePolynomial.FirstOrderHold(times, self.zmp.T)
        self.planner.Plan(zmp, start, self.height, GRAVITY, *PLAN_WEIGHTS)
        # The plan's nominal CoM and its velocity at the clip's frames (interpolated between: cheaper than the
        # planner's trajectories at every control step).
        com_plan, comd_plan = self.planner.get_nominal_com(), self.planner.get_nominal_comd()
        self._nominal_times = np.arange(times[0], times[-1], 1.0 / NOMINAL_RATE)
        self._nominal = np.array(
            [np.r_[com_plan.value(t).ravel(), comd_plan.value(t).ravel()] for t in self._nominal_times]
        )

    def _plan_maps(self, time: float) -> tuple[Planar, Planar, float]:
        """The map from the world at `time` into the planned pass, its
        inverse, and the plan's time: a loop's first pass is the plan's
        first (planned from the clip's own first frame, where the robot
        starts), every later one its middle pass (which follows a pass, as
        they do). Kept per pass: asked three times a control step."""
        index, clip_time = self.pass_at(time)
        if not self.loop or index == 0:
            return IDENTITY, IDENTITY, clip_time
        maps = self._pass_maps.get(index)
        if maps is None:
            to_plan = self.placement(1) @ self.placement(index).inverse()
            maps = self._pass_maps[index] = (to_plan, to_plan.inverse())
        return *maps, clip_time + self.period

    def com_reference(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The clip's CoM position, velocity and acceleration (world) at `time`."""
        _, back, at = self._plan_maps(time)
        position, velocity, acceleration = interp_rows(at, self.com_times, self._com_rows).reshape(3, 3)
        return back.point(position), back.rotation @ velocity, back.rotation @ acceleration

    def planned_com(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """The ZMP plan's nominal horizontal CoM position and velocity (world, (2,) each) at `time`."""
        _, back, at = self._plan_maps(time)
        x, y, x_rate, y_rate = interp_rows(at, self._nominal_times, self._nominal)
        position, velocity = np.array([x, y, 0.0]), np.array([x_rate, y_rate, 0.0])
        return back.point(position)[:2], (back.rotation @ velocity)[:2]

    def com_acceleration_for(self, time: float, com: np.ndarray, com_velocity: np.ndarray) -> np.ndarray:
        """The horizontal CoM acceleration (2,) the ZMP plan's LQR asks of a
        robot whose CoM is at `com` moving at `com_velocity`, at `time`."""
        to_plan, _, at = self._plan_maps(time)
        position, velocity = to_plan.point(com), to_plan.rotation @ com_velocity
        acceleration = self.planner.ComputeOptimalCoMdd(at, np.concatenate([position[:2], velocity[:2]]))
        return to_plan.rotation[:2, :2].T @ acceleration
