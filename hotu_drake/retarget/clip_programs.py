"""Whole-clip retargeting: one convex program per level of the tree, over every frame.

Offline the whole clip is known, so instead of stepping each part frame by
frame (`RetargetStream`, the streaming path), all parts of one level of the
tree (proximal first: the torso; shoulders and hips; elbows, knees and the
neck; wrists and ankles; fingers) are solved for every frame at
once. The step dq of the level's joints minimises

    sum_t [ sum_k w_tk |J_tk dq_t - e_tk|^2 + reg |dq_t|^2 ]
      + smooth sum_t |(q + dq)_{t+1} - (q + dq)_t|^2

within the joint limits and a trust region: one OSQP workspace per level
(levels of one shape share one; the `osqp` package, as the whole-body
controller's QP: Drake's `OsqpSolver` would set OSQP up again at every
solve), set up once per clip, its values and bounds updated at each
relinearisation (sequential convex programming). Forward kinematics and Jacobians of all frames are one
vectorised pass (`Tree.forward_frames`, `Landmarks.*_frames`); the targets
and parts are the streaming path's own.

Planted feet: over all frames the legs are solved by a program of their
own over both whole legs (hip, knee and ankle joints at once; the coarse
pass, and a clip too short for one, solve them by level first). After the
other parts, the root height keeps planted soles on the floor, the root
follows the first planted foot's anchor (left before right, as the
streaming path does), and the legs' program holds each planted ankle on
its anchor (where it landed, its sole on the floor) with its sole level,
or rolled over its edge as the source's (`foot_roll`), over each contact
phase, along with the legs' own targets.

A clip faster than 60 fps (`RetargetOptions.solve_rate`) is solved on
every k-th frame and interpolated back to its own rate (`OwnRate`).

Balance (`balance`, on legged robots with a floating base): the body is
shifted sideways so that the clip's centre of pressure comes inside its
planted soles (a ZMP filter, one convex program over the clip,
`balance.py`), and the legs' program puts the planted feet back, in a few
rounds.

The solvers read the parts, targets, root path and leg locks of the
`retargeter.Retargeter` that calls them (`retarget_clip`); that module
imports this one, so this one names it in prose only.
"""

from __future__ import annotations

import itertools
from functools import cached_property

import numpy as np
import osqp
import scipy.sparse as sparse

from hotu_drake.control.whole_body_qp import SOLVED
from hotu_drake.embodiment.spec import SIDES
from hotu_drake.motion.synthesis import smooth
from hotu_drake.retarget.balance import MOST_MOVED, balancing_shift, inside_share, shifted_pressure
from hotu_drake.retarget.foot_roll import SoleEdges, foot_rolls, sole_edges
from hotu_drake.retarget.part_ik import FINGER_LEVEL, SHAPE_TOLERANCE, TRUST_REGION
from hotu_drake.retarget.targets import sideways_target
from hotu_drake.retarget.tree import Pose, axis_angles
from hotu_drake.rotations import heading_rotation, normalize

# s: the Gaussian sigma over which the root's drift correction (planted feet kept where they landed) is averaged.
DRIFT_SMOOTHING = 0.06
# The balance pass: at most this many rounds of the ZMP filter's program and the legs' program; a round
# after the first only while less than ENOUGH_INSIDE of the supported frames are inside; a round after
# which fewer are inside is undone, one that brings fewer than WORTH_A_ROUND more inside is the last.
# The Qualisys walk's UDH takes five (0.96 inside; two left it at 0.90); at 0.98 CMU 01_01's NAVIAI took
# a third round its legs did not follow (0.97 before and after, its stage 0.5 -> 1.0 s).
BALANCE_ROUNDS = 6
ENOUGH_INSIDE = 0.97
WORTH_A_ROUND = 0.01
# The share of the body's shift its centre of mass was measured to follow is taken within these bounds,
# from a round that moved the body by at least this much (m, root mean square over the frames).
CARRIED = (0.5, 1.0)
MEASURABLE = 0.005
# The legs' program: weights of a planted ankle's distance (m) from its anchor
# and of its sole's tilt (rad), against the legs' direction targets (1 each).
ANCHOR_WEIGHT = 100.0
TILT_WEIGHT = 1.0
# The balance pass: the weight of a swinging ankle's path (m) at lift-off and touch-down, so that the moved
# body does not carry it off its anchor, fading over `SWING_FADE` s into the swing.
SWING_WEIGHT = 3.0
SWING_FADE = 0.05
# The balance pass: the legs' sideways targets (each foot's offset from its hip, less the body's shift) weighted
# this many times over, so the feet keep their width as the pelvis sways: at 1 the legs' directions carried
# BRUCE's swinging foot along (its walk's stance 0.985, least 0.955; 1.005 and 0.991 at 3).
PASS_SIDEWAYS_FACTOR = 3.0
# And a swinging foot's this many times over again: nothing anchors it, so the legs' directions drew BRUCE's
# swinging ankle inward as it passed the other (its walk's least stance 0.996 at 1, 0.999 at 3 or
# more; no foot skates more for it: a planted foot's width is its anchor's).
PASS_SWING_SIDEWAYS_FACTOR = 3.0
# s (a Gaussian's sigma) over which the root's height offsets that put the planted soles on the floor are averaged.
HEIGHT_SMOOTHING = 0.02


class ClipProgram:
    """The QP of K joint columns over all frames on one OSQP workspace; which
    joints, and their limits, come with each step, so levels of one shape
    can share it.

    Variables: dq (T, K), frame by frame. The Hessian's pattern is fixed:
    each frame's dense block per group of columns (its targets, the
    regularisation and the smoothness' diagonal) and each column's coupling
    to the next frame (the smoothness). Joints that no target couples (two
    parts, two fingers) can be kept in separate `groups` of columns, so the
    dense blocks stay small. OSQP is set up (and its ordering found) at the
    first step; later steps update its values, gradient and bounds and
    start its iterates from zero (its adaptive step size, rho, goes on from
    the last solve: steps agree with a fresh solve's within the tolerance).
    """

    GROUP = 8  # independent groups of columns are merged up to this many (a leg of 7 joints stays apart)
    # A relinearised step needs no more accuracy than this; with rho 0.2 (OSQP's default 0.1) the robots'
    # programs took 17-44% fewer iterations on CMU 01_01.
    SETTINGS = {
        "verbose": False,
        "polishing": False,
        "eps_abs": 1e-3,
        "eps_rel": 1e-3,
        "check_termination": 10,
        "rho": 0.2,
    }

    def __init__(self, frames: int, regularization: float, smoothness: float, groups: list[int]):
        self.regularization, self.smoothness = regularization, smoothness
        self.failed = False  # whether the last step's solve failed
        k = sum(groups)
        self.frames, self.k = frames, k
        self.columns = self.merge(groups)
        index = np.arange(frames * k).reshape(frames, k)  # dq[t, c] is variable t k + c
        rows, cols, self._upper = [], [], []
        for columns in self.columns:
            i, j = np.triu_indices(columns.stop - columns.start)
            self._upper.append((columns.start + i, columns.start + j))
            rows.append(index[:, columns.start + i].reshape(-1))
            cols.append(index[:, columns.start + j].reshape(-1))
        rows.append(index[:-1].reshape(-1))  # each column's smoothness coupling to the next frame
        cols.append(index[1:].reshape(-1))
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        self._order = np.lexsort((rows, cols))  # compressed sparse columns: by column, then row
        self._indices = rows[self._order]
        self._pointers = np.r_[0, np.cumsum(np.bincount(cols, minlength=frames * k))]
        # How many of the smoothness' pairs (t, t + 1) each frame is in, and their coupling's constant values.
        self._pairs = np.zeros(frames)
        self._pairs[:-1] += 1.0
        self._pairs[1:] += 1.0
        self._coupling = np.full((frames - 1) * k, -2.0 * smoothness)
        self._solver: osqp.OSQP | None = None

    @classmethod
    def merge(cls, sizes: list[int]) -> list[slice]:
        """Consecutive groups of columns (their `sizes`) merged while they fit in `GROUP`."""
        out, start, width = [], 0, 0
        for size in sizes:
            if width and width + size > cls.GROUP:
                out.append(slice(start, start + width))
                start, width = start + width, 0
            width += size
        out.append(slice(start, start + width))
        return out

    def _hessian_values(self, hessian: np.ndarray) -> np.ndarray:
        """The Hessian's entries in the pattern's order, from the frames' target Hessians (T, K, K)."""
        diagonal = self.regularization + self.smoothness * self._pairs  # (T,)
        values = []
        for i, j in self._upper:
            block = hessian[:, i, j] + np.where(i == j, diagonal[:, None], 0.0)
            values.append(2.0 * block.reshape(-1))
        values.append(self._coupling)
        return np.concatenate(values)[self._order]

    def step(
        self, hessian: np.ndarray, gradient: np.ndarray, q: np.ndarray, lower: np.ndarray, upper: np.ndarray
    ) -> np.ndarray:
        """The step (T, K) that minimises the frames' costs dq' H_t dq + 2 g_t' dq
        (`hessian` (T, K, K), `gradient` (T, K)), plus the regularisation and
        the smoothness of q + dq, within the joint limits (`lower`, `upper`
        (K,)) and the trust region; `q` (T, K) is the current configuration."""
        s = self.smoothness
        change = q[1:] - q[:-1]  # the smoothness term s |dq_t+1 - dq_t + (q_t+1 - q_t)|^2
        linear = 2.0 * gradient
        linear[:-1] -= 2.0 * s * change
        linear[1:] += 2.0 * s * change
        low = np.minimum(np.maximum(lower - q, -TRUST_REGION), 0.0)
        high = np.maximum(np.minimum(upper - q, TRUST_REGION), 0.0)
        values = self._hessian_values(hessian)
        n = self.frames * self.k
        if self._solver is None:
            self._solver = osqp.OSQP(algebra="builtin")  # (not looked up again at each set-up)
            matrix = sparse.csc_matrix((values, self._indices, self._pointers), shape=(n, n))
            self._solver.setup(
                matrix,
                linear.reshape(-1),
                sparse.identity(n, format="csc"),
                low.reshape(-1),
                high.reshape(-1),
                **self.SETTINGS,
            )
        else:
            self._solver.update(Px=values, q=linear.reshape(-1), l=low.reshape(-1), u=high.reshape(-1))
            self._solver.warm_start(x=np.zeros(n), y=np.zeros(n))
        result = self._solver.solve(raise_error=False)
        self.failed = result.info.status_val not in SOLVED
        if self.failed:  # no step this time; the caller does not count the level as settled
            return np.zeros_like(q)
        return np.clip(result.x.reshape(self.frames, self.k), low, high)


def normal_equations(rows: list) -> tuple[np.ndarray, np.ndarray]:
    """H_t = sum_k w J'J and g_t = -sum_k w J'e over a part's target rows
    ((J (T, m, k), e (T, m), w (T,)) each)."""
    hessian, gradient = 0.0, 0.0
    for jacobian, error, weight in rows:
        weighted = jacobian * weight[:, None, None]
        hessian = hessian + np.swapaxes(weighted, 1, 2) @ jacobian
        gradient = gradient - np.einsum("tmk,tm->tk", weighted, error)
    return hessian, gradient


class ClipSolver:
    """Retargets a whole clip with one `ClipProgram` per level of the tree
    (and one over both legs for the planted feet); levels of one shape share
    a program."""

    def __init__(self, retargeter, frames: int, legs: bool = True):
        """`retargeter`: the `Retargeter` whose parts these programs solve.
        `legs`: whether the levels solve the legs' parts too; if not (and
        the legs' program runs, planting the feet), only that program does."""
        self.r = r = retargeter
        self.frames = frames
        self.plants_feet = bool(r.legged and r._lock and r.options.lock_feet)
        # The legs' parts, by side, of the legs the legs' program solves (`plant_feet`).
        self.leg_parts = {
            side: [p for p in r.parts if p.name in {f"{side}_{n}" for n in ("hip", "knee", "ankle")}]
            for side in SIDES
            if side in r._lock
        }
        solved_by_legs_program = self.plants_feet and r.options.lock_iterations > 0
        held = set() if legs or not solved_by_legs_program else {id(p) for ps in self.leg_parts.values() for p in ps}
        self.levels: dict[int, list] = {}
        for part in r.parts:
            if id(part) not in held:
                self.levels.setdefault(part.level, []).append(part)
        self._programs: dict[tuple[int, ...], ClipProgram] = {}
        # Each planted foot's roll about its sole's edge (rad, T), the source's (`foot_roll`); none: flat.
        self.rolls: dict[str, np.ndarray] = {}

    def program(self, level: int) -> ClipProgram:
        """The program of one level."""
        return self._program([size for part in self.levels[level] for size in self._independent(part)])

    @property
    def lock(self) -> ClipProgram:
        """The legs' program that plants the feet."""
        return self._program([len(self.r._lock[side][0].joints) for side in SIDES if side in self.r._lock])

    def _independent(self, part) -> list[int]:
        """Sizes of the runs of a part's joints that no target couples: one
        run per finger in a hand's part, else the whole part."""
        if part.level < FINGER_LEVEL:
            return [len(part.problem.joints)]
        names = [self.r.tree.joint_names[j].rsplit("_", 1)[0] for j in part.problem.joints]
        return [len(list(run)) for _, run in itertools.groupby(names)]

    def _program(self, groups: list[int]) -> ClipProgram:
        """The program over columns in `groups` (sizes), built when first needed:
        levels (and the legs) of one shape share it, as each step sets all of
        its coefficients and bounds."""
        shape = tuple(columns.stop - columns.start for columns in ClipProgram.merge(groups))
        if shape not in self._programs:
            options = self.r.options
            self._programs[shape] = ClipProgram(self.frames, options.regularization, options.smoothness, groups)
        return self._programs[shape]

    # --- the parts ------------------------------------------------------------------

    def source_targets(self, src: dict, src_frames: dict) -> dict:
        """The targets that depend on the source only, per key (all frames)."""
        out = {}
        for part in self.r.parts:
            for _, key in part.targets:
                if key == "q" or key in out:
                    continue
                kind = key if isinstance(key, str) else key[0]
                if kind == "dir":
                    direction = normalize(src[key[2]] - src[key[1]], floor=1e-9)
                    out[key] = self.r.calibrated(key, direction, src, src_frames)
                elif kind == "level":
                    out[key] = np.zeros(len(src_frames["pelvis"]))
                elif kind == "side":
                    out[key] = sideways_target(src, src_frames, key, self.r.rest_leg_length, self.r.stance_of(key))
                elif kind == "bend":
                    a, b, c = (src[n] for n in key[1:])
                    out[key] = np.cross(normalize(b - a, floor=1e-9), normalize(c - b, floor=1e-9))
                elif kind == "finger":  # the finger's direction in the source's hand frame
                    v = normalize(src[key[2]] - src[key[1]], floor=1e-9)
                    out[key] = np.einsum("tji,tj->ti", src_frames[key[3]], v)
                else:
                    out[key] = src_frames[key]
        return out

    def _target(self, key, fixed: dict, q: np.ndarray, poses: Pose) -> np.ndarray:
        if key == "q":
            return q
        if key[0] == "finger":  # expressed in the robot's current hand frame
            hand = key[3]
            robot_hand = poses.rotations[:, self.r._link_of(hand)] @ self.r.rest_frames[hand]
            return np.einsum("tij,tj->ti", robot_hand, fixed[key])
        return fixed[key]

    def solve_parts(
        self,
        q: np.ndarray,
        rotations: np.ndarray,
        positions: np.ndarray,
        fixed: dict,
        iterations: int,
        tolerance: float | None = None,
        quantile: float = 1.0,
        levels: list[int] | None = None,
    ) -> dict[int, float]:
        """Relinearise and solve the `levels` (by default all but the
        fingers', which `solve_fingers` solves) in turn (at most `iterations`
        times, until no joint moves more than `tolerance`, by default the
        options' own), in place on q (T, n); returns each level's last step:
        the `quantile` over frames of each frame's largest joint change (1:
        the largest of all).

        A level that has settled by its last step is skipped while the
        levels it hangs from have too; the fingers' targets are in the hand's
        own frame, so they wait for nothing but themselves."""
        r = self.r
        tolerance = r.options.tolerance if tolerance is None else tolerance
        levels = sorted([level for level in self.levels if level < FINGER_LEVEL] if levels is None else levels)
        moved = dict.fromkeys(levels, np.inf)
        for _ in range(iterations):
            for level in levels:
                settled = moved[level] < tolerance
                below = [moved[other] for other in levels if other < level and level < FINGER_LEVEL]
                if settled and all(m < tolerance for m in below):
                    moved[level] = 0.0
                    continue
                groups = None if level >= FINGER_LEVEL else r._body_groups
                poses = r.tree.forward_frames(q, rotations, positions, groups)
                parts = self.levels[level]
                blocks = [(p.problem.joints, self._rows(p, p.problem.joints, fixed, q, poses)) for p in parts]
                moved[level] = self._step(self.program(level), blocks, q, quantile)
            if max(moved.values(), default=0.0) < tolerance:
                break
        return moved

    def solve_fingers(
        self,
        q: np.ndarray,
        rotations: np.ndarray,
        positions: np.ndarray,
        fixed: dict,
        iterations: int,
        tolerance: float | None = None,
        quantile: float = 1.0,
    ) -> float:
        """The fingers' level, in place on q (T, n), as `solve_parts` solves
        it, but each run of frames that keep one hand shape (`shape_runs`)
        solved once: the fingers' targets are in the hand's own frame, so
        frames of one shape have one solution (as the stream keeps a settled
        hand whose shape did not change). Returns the level's last step."""
        if FINGER_LEVEL not in self.levels or not len(q):
            return 0.0
        parts = self.levels[FINGER_LEVEL]
        keys = [key for part in parts for _, key in part.targets if key != "q"]
        runs = shape_runs(np.concatenate([fixed[key] for key in keys], axis=1))
        first = np.flatnonzero(np.r_[True, runs[1:] != runs[:-1]])
        shapes = q[first]
        moved = ClipSolver(self.r, len(first)).solve_parts(
            shapes,
            rotations[first],
            positions[first],
            _take(fixed, first),
            iterations,
            tolerance=tolerance,
            quantile=quantile,
            levels=[FINGER_LEVEL],
        )
        joints = [j for part in parts for j in part.problem.joints]
        q[:, joints] = shapes[runs][:, joints]
        return moved[FINGER_LEVEL]

    def _step(self, program: ClipProgram, blocks: list, q: np.ndarray, quantile: float = 1.0) -> float:
        """One step of `program` in place on q (T, n), from target rows by block
        of its joints ((joints, rows), in the program's order); the `quantile`
        over frames of each frame's largest joint change, infinite if the
        solve failed."""
        joints = [j for block_joints, _ in blocks for j in block_joints]
        k = len(joints)
        hessian = np.zeros((self.frames, k, k))
        gradient = np.zeros((self.frames, k))
        start = 0
        for block_joints, rows in blocks:
            block = slice(start, start + len(block_joints))
            hessian[:, block, block], gradient[:, block] = normal_equations(rows)
            start += len(block_joints)
        emb = self.r.embodiment
        step = program.step(hessian, gradient, q[:, joints], emb.position_lower[joints], emb.position_upper[joints])
        q[:, joints] += step
        return np.inf if program.failed else float(np.quantile(np.max(np.abs(step), axis=1), quantile))

    def _rows(self, part, joints: list[int], fixed: dict, q: np.ndarray, poses: Pose) -> list:
        """A part's target rows over `joints` for every frame."""
        return [
            target.rows_frames(self.r.marks, poses, joints, self._target(key, fixed, q, poses))
            for target, key in part.targets
        ]

    # --- the feet -------------------------------------------------------------------

    def _poses(self, q, rotations, positions) -> Pose:
        return self.r.tree.forward_frames(q, rotations, positions, self.r._body_groups)

    def _lowest(self, poses: Pose) -> dict[str, np.ndarray]:
        return {side: self.r.soles.lowest_frames(poses, side) for side in self.r.soles.feet}

    def _heights(self, lowest: dict[str, np.ndarray], contacts: dict[str, np.ndarray], fps: float) -> np.ndarray:
        """Root height offsets: the lowest planted sole on the floor, joined
        straight across frames with no foot planted, averaged over
        `HEIGHT_SMOOTHING` (so a contact taken or let go does not make the
        body jump), and no sole ever below the floor."""
        feet = np.stack(list(lowest.values()), axis=1)  # (T, feet)
        flags = np.stack([contacts[side] if side in contacts else np.zeros(self.frames, bool) for side in lowest], 1)
        planted = np.flatnonzero(flags.any(axis=1))
        lift_all = -feet.min(axis=1)  # what keeps every sole above the floor
        if not len(planted):
            return np.maximum.accumulate(np.maximum(lift_all, 0.0))  # nothing to stand on: only ever up
        on_floor = -np.where(flags[planted], feet[planted], np.inf).min(axis=1)
        offsets = smooth(np.interp(np.arange(self.frames), planted, on_floor), fps, HEIGHT_SMOOTHING)
        return np.maximum(offsets, lift_all)

    def plant_feet(
        self, q: np.ndarray, rotations: np.ndarray, positions: np.ndarray, contacts: dict, fixed: dict, fps: float
    ) -> np.ndarray:
        """Root positions (T, 3) that keep planted feet on the floor and where
        they landed; the leg joints of q are corrected in place."""
        r = self.r
        poses = self._poses(q, rotations, positions)
        lift = np.zeros((self.frames, 3))
        lift[:, 2] = self._heights(self._lowest(poses), contacts, fps)
        positions = positions + lift
        if not self.plants_feet:
            return positions
        poses = poses.translated(lift[:, None])  # moving the root moves every link alike
        ankles = self.ankles(poses)
        # Where each planted ankle goes: its flat foot's ankle where it landed, its sole on the floor (where
        # the other foot held the body up, the root's height alone left it hovering), turned by its roll.
        headings, rolls, edges = self._headings(poses), self._rolls(), self.edges
        flat = {side: edges[side].unrolled(ankles[side], headings[side], rolls[side]) for side in r._lock}
        for side in r._lock:
            flat[side][:, 2] = -edges[side].down
        anchors = {side: np.full((self.frames, 3), np.nan) for side in r._lock}
        shift = np.zeros((self.frames, 3))
        current: dict[str, np.ndarray] = {}
        carrier: list[str | None] = []  # per frame, the first planted foot (left before right): it carries the body
        for t in range(self.frames):
            planted = [s for s in r._lock if contacts.get(s) is not None and contacts[s][t]]
            for side in list(current):
                if side not in planted:
                    del current[side]
            for side in planted:  # a foot lands: its anchor is where it is (its sole on the floor), unshifted
                current.setdefault(side, flat[side][t].copy())
                anchors[side][t] = current[side]
            carrier.append(planted[0] if planted else None)
        for side in r._lock:
            anchors[side] = edges[side].rolled(anchors[side], headings[side], rolls[side])
        for t, side in enumerate(carrier):
            if side is not None:
                shift[t, :2] = (anchors[side][t] - ankles[side][t])[:2]
        # The drift taken out smoothly: frame-by-frame corrections would shake the body (its centre of mass
        # accelerating at 5-9 m/s^2 in the library walk); the legs' program keeps the planted feet on their anchors.
        shift = smooth(shift, fps, DRIFT_SMOOTHING)
        positions += shift
        self._lock_legs(q, rotations, positions, anchors, fixed, poses.translated(shift[:, None]))
        np.clip(q, r.embodiment.position_lower, r.embodiment.position_upper, out=q)  # before the soles' last lift
        # The levelled soles: planted ones back on the floor (up to the heights' averaging), none below it.
        positions[:, 2] += self._heights(self._lowest(self._poses(q, rotations, positions)), contacts, fps)
        return positions

    def _headings(self, poses: Pose) -> dict[str, np.ndarray]:
        """Each foot's yaw-only frame (T, 3, 3)."""
        return {side: heading_rotation(poses.rotations[:, self.r._link_of(f"{side}_toe")]) for side in self.r._lock}

    def _rolls(self) -> dict[str, np.ndarray]:
        return {side: self.rolls.get(side, np.zeros(self.frames)) for side in self.r._lock}

    @cached_property
    def edges(self) -> dict[str, SoleEdges]:
        """Each sole's edges from its ankle, from the standing pose (its feet flat)."""
        r = self.r
        pose = r.tree.forward(r.embodiment.standing_pose)
        return {side: sole_edges(pose, r.soles, r.marks.position(pose, f"{side}_ankle"), side) for side in r._lock}

    def ankles(self, poses: Pose) -> dict[str, np.ndarray]:
        """Each leg's ankle (T, 3) in the world, of the body at `poses`."""
        return {side: self.r.marks.point_jacobian_frames(poses, f"{side}_ankle", [])[0] for side in self.r._lock}

    def move_body(
        self,
        q: np.ndarray,
        rotations: np.ndarray,
        positions: np.ndarray,
        contacts: dict,
        fixed: dict,
        shift: np.ndarray,
        ankles: dict[str, np.ndarray],
        fps: float,
    ) -> np.ndarray:
        """Root positions moved by `shift` (T, 3) with the feet kept where
        they were (`ankles`, from before any move): the legs' program solves
        the legs again, each planted ankle anchored there and each swinging
        one drawn to its path near its contacts (so a foot lifting off
        leaves from its anchor, not from where the moved body would carry
        it); then the soles' heights."""
        r = self.r
        planted = {side: contacts.get(side, np.zeros(self.frames, bool)) for side in ankles}
        anchors = {side: np.where(planted[side][:, None], ankle, np.nan) for side, ankle in ankles.items()}
        fade = SWING_FADE * fps
        swing = {side: (ankle, SWING_WEIGHT * _near_contact(planted[side], fade)) for side, ankle in ankles.items()}
        positions = positions + shift
        with r.sideways_weighted(PASS_SIDEWAYS_FACTOR):
            self._lock_legs(q, rotations, positions, anchors, fixed, self._poses(q, rotations, positions), swing)
        np.clip(q, r.embodiment.position_lower, r.embodiment.position_upper, out=q)
        positions[:, 2] += self._heights(self._lowest(self._poses(q, rotations, positions)), contacts, fps)
        return positions

    def _lock_legs(
        self, q, rotations, positions, anchors: dict[str, np.ndarray], fixed: dict, poses: Pose, swing=None
    ) -> None:
        """The leg program: the legs' own targets, and over each contact phase
        the planted ankle on its anchor with its sole level (and, given
        `swing` ankle paths (T, 3) and weights (T,) per side, each unplanted
        ankle drawn to its path); a few relinearisations of one program over
        both legs, the first at `poses` (the body's, at q)."""
        r, program = self.r, self.lock
        planted = {side: ~np.isnan(anchor[:, 0]) for side, anchor in anchors.items()}
        rolls = self._rolls()
        for iteration in range(r.options.lock_iterations):
            if iteration:
                poses = self._poses(q, rotations, positions)
            blocks, headings = [], self._headings(poses)
            for side in (s for s in SIDES if s in r._lock):
                problem, position, orientation = r._lock[side]
                joints = problem.joints
                mask = planted[side].astype(float)
                heading = headings[side]
                # The sole level, or turned about its edge by the foot's roll (`foot_roll`).
                turn = axis_angles(heading[:, :, 1], rolls[side])
                level = turn @ heading @ r.rest_frames[f"{side}_foot"]
                target = np.where(planted[side][:, None], anchors[side], 0.0)
                rows = [row for part in self.leg_parts[side] for row in self._rows(part, joints, fixed, q, poses)]
                goals = [(position, target, ANCHOR_WEIGHT * mask), (orientation, level, TILT_WEIGHT * mask)]
                if swing is not None:
                    path, weight = swing[side]
                    goals.append((position, path, weight * (1.0 - mask)))
                for goal, targets, weight in goals:
                    jacobian, error, _ = goal.rows_frames(r.marks, poses, joints, targets)
                    rows.append((jacobian, error, weight))
                blocks.append((joints, rows))
            if self._step(program, blocks, q) < r.options.tolerance:
                break


def balance(
    solver: ClipSolver,
    q,
    rotations,
    positions,
    contacts: dict,
    fixed: dict,
    fps: float,
    own_rate: OwnRate | None = None,
) -> tuple[np.ndarray, dict]:
    """The balance pass: the body shifted so that the clip's centre of
    pressure, with the robot's own mass distribution, comes
    `balance.MARGIN` inside the support of its planted soles, as far as
    its ankles can hold it (`ClipBalance.support`, `ankles_hold`; the ZMP
    filter's program, `balance.balancing_shift`), and the legs' program
    putting the planted feet back where they were; in up to
    `BALANCE_ROUNDS` rounds, each filtering the body the last one left
    (the legs do not move quite as a translated body would, and the feet
    may settle by a few millimetres), while fewer than `ENOUGH_INSIDE` of
    the supported frames are inside and the filter's shift would bring at
    least `WORTH_A_ROUND` more of them inside; a round after which fewer
    are inside is undone, and one that gained less than `WORTH_A_ROUND` is
    the last. The body moves `balance.MOST_MOVED` at most. On a clip solved
    on some of its frames (`own_rate`), the support and the centre of
    pressure are those of the clip brought back to its own rate, every
    frame of it. Returns the root positions (solved frames) and the soles'
    support margins (m, per frame of the clip) before and after."""
    dynamics = solver.r.balance
    own_fps, solved = (fps, slice(None)) if own_rate is None else (own_rate.fps, own_rate.solved)

    def posed(positions):
        """The body's poses at `positions` and its feet's contacts, at `own_fps`."""
        if own_rate is None:
            return dynamics.poses(q, rotations, positions), contacts
        q_own = own_rate.joints(q)
        return dynamics.poses(q_own, own_rate.rotations, own_rate.root(q_own, positions)), own_rate.contacts

    def measured(positions):
        """The body's poses and contacts at `positions` (`posed`), its support
        (as far as the ankles can hold, `ClipBalance.support`), centre of
        mass and centre of pressure, at `own_fps`."""
        seen = posed(positions)
        return seen, dynamics.support(*seen, ankles_hold=True), *dynamics.centroidal(seen[0], own_fps)

    def soles_margin(seen, pressure):
        """How far `pressure` lies inside the planted soles themselves (what the report measures)."""
        poses, planted = seen
        return dynamics.support_margin(poses, pressure, planted)

    seen, support, com, pressure = measured(positions)  # where the planted feet are, and will be put back
    margins = {"before": soles_margin(seen, pressure)}
    ankles = solver.ankles(solver._poses(q, rotations, positions))
    # How far the centre of mass moves with the body (the feet stay, the legs lean): first from the robot's build.
    carried = float(np.clip(dynamics.carried, *CARRIED))
    total = np.zeros((len(com), 2))
    share = inside_share(support.margin(pressure))
    for index in range(BALANCE_ROUNDS):
        if index and (share is None or share >= ENOUGH_INSIDE):  # (no supported frame: nothing to move)
            break
        shift = balancing_shift(support, com, pressure, own_fps, moved=total * carried)
        promised = inside_share(support.margin(shifted_pressure(com, pressure, shift, own_fps)))
        if index and promised < share + WORTH_A_ROUND:
            break  # the legs' program is the round's cost: not for what the filter itself says gains little
        shift = np.clip(total + shift / carried, -MOST_MOVED, MOST_MOVED) - total
        if not np.any(np.abs(shift) > 1e-4):
            break
        last = (positions.copy(), q.copy(), seen, support, pressure, share)
        staying = feet_stay(solver, fixed, (total + shift)[solved], contacts)
        on_solved = np.c_[shift[solved], np.zeros(len(q))]
        positions = solver.move_body(q, rotations, positions, contacts, staying, on_solved, ankles, fps)
        seen, support, moved_com, pressure = measured(positions)
        share, before = inside_share(support.margin(pressure)), -1.0 if last[-1] is None else last[-1]
        if share is None or share < before:  # the legs did not follow the filter: the round undone
            positions, q[:], seen, support, pressure, share = last
            break
        total += shift
        moved = np.sum(shift * shift)
        if moved > MEASURABLE**2 * len(com):  # a round that hardly moved the body says little about how it follows
            carried = float(np.clip(np.sum((moved_com[:, :2] - com[:, :2]) * shift) / moved, *CARRIED))
        com = moved_com
        if share < before + WORTH_A_ROUND:
            break
    margins["after"] = soles_margin(seen, pressure)
    return positions, margins


def feet_stay(solver: ClipSolver, fixed: dict, shift: np.ndarray, contacts: dict) -> dict:
    """The source targets with each leg point's sideways offset from its hip
    less the body's sideways shift (T, 2): the pelvis sways over the feet,
    and a swinging foot keeps its path across the floor (as the library's
    planned walks do), rather than being carried along and closing the
    stance; kept within the stance's bounds (clear of the other leg), and
    weighted `PASS_SWING_SIDEWAYS_FACTOR` times over while the foot swings
    (`contacts`: per side, planted on each frame)."""
    out = dict(fixed)
    for key, target in fixed.items():
        if isinstance(key, tuple) and key[0] == "side":
            stance = solver.r.stance_of(key)
            left = target[:, :3]
            offset = np.clip(target[:, 3] - np.einsum("ti,ti->t", left[:, :2], shift), stance.low, stance.high)
            planted = contacts.get(key[1].split("_")[0])
            factor = np.ones(len(offset)) if planted is None else np.where(planted, 1.0, PASS_SWING_SIDEWAYS_FACTOR)
            out[key] = np.column_stack((left, offset, factor))
    return out


def _near_contact(planted: np.ndarray, fade: float) -> np.ndarray:
    """Per frame, exp(-d / fade), d: the frames to the nearest planted one (with none planted, 0 everywhere)."""
    where = np.flatnonzero(planted)
    if not len(where):
        return np.zeros(len(planted))
    frames = np.arange(len(planted))
    after = np.clip(np.searchsorted(where, frames), 0, len(where) - 1)
    before = np.clip(after - 1, 0, len(where) - 1)
    distance = np.minimum(np.abs(where[after] - frames), np.abs(frames - where[before]))
    return np.exp(-distance / max(fade, 1e-9))


def _take(fixed: dict, index: np.ndarray) -> dict:
    return {key: value[index] for key, value in fixed.items()}


def hermite(knots: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Values (len(at), m) of the cubic Hermite curve through `values` (K, m)
    at increasing `knots` (K >= 3,), with the tangents of the parabola
    through each knot and its neighbours (so a parabola comes out exact), at
    points `at` within the knots."""
    knots = knots.astype(float)
    slopes = np.gradient(values, knots, axis=0, edge_order=2)
    segment = np.clip(np.searchsorted(knots, at, side="right") - 1, 0, len(knots) - 2)
    width = (knots[segment + 1] - knots[segment])[:, None]
    s = (at - knots[segment])[:, None] / width
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return (
        h00 * values[segment]
        + h10 * width * slopes[segment]
        + h01 * values[segment + 1]
        + h11 * width * slopes[segment + 1]
    )


def shape_runs(shapes: np.ndarray, window: int = 64) -> np.ndarray:
    """The run (0, 1, ...) of each frame of `shapes` (T, m): a run starts at
    the first frame that differs from the run's first frame by
    `SHAPE_TOLERANCE` or more in some entry."""
    runs = np.empty(len(shapes), dtype=int)
    start, run = 0, 0
    while start < len(shapes):
        end = start + 1
        while end < len(shapes):  # look ahead a window at a time
            ahead = shapes[end : end + window]
            changed = np.flatnonzero(np.max(np.abs(ahead - shapes[start]), axis=1) >= SHAPE_TOLERANCE)
            if len(changed):
                end += int(changed[0])
                break
            end += len(ahead)
        runs[start:end] = run
        start, run = end, run + 1
    return runs


def retarget_clip(
    retargeter, src: dict, src_frames: dict, contacts: dict, ratio: float, fps: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint positions (T, n), root rotations (T, 3, 3) and root positions
    (T, 3) of a whole clip, by the `Retargeter` `retargeter`.

    A clip faster than `RetargetOptions.solve_rate` is solved on every k-th
    frame (`solved_frames`), the last one included, and brought back to its
    own rate (`OwnRate`). A human clip is low-passed to about 8 Hz first, so
    a 60 fps solve keeps what it has; the support margins
    (`retargeter.margins`) are the balance pass's, measured on the clip at
    its own rate.
    """
    r = retargeter
    frames = len(next(iter(src.values())))
    solved = solved_frames(frames, fps, r.options.solve_rate)
    if len(solved) == frames:
        return _retarget_solved(r, src, src_frames, contacts, ratio, fps)
    on_solved = (_take(src, solved), _take(src_frames, solved), contacts_on(contacts, solved))
    rate = fps * (len(solved) - 1) / (frames - 1)
    own_rate = OwnRate(r, solved, fps, contacts, *r.root_path(src, src_frames, ratio))
    q_solved, _, positions_solved = _retarget_solved(r, *on_solved, ratio, rate, own_rate)
    q = own_rate.joints(q_solved)
    positions = own_rate.root(q, positions_solved)
    return q, own_rate.rotations, positions


class OwnRate:
    """How a clip solved on some of its frames (`solved`) comes back to
    all of them: the joints' paths cubic (`hermite`; the fingers' linear, so
    a held hand shape stays held), the root's rotations (and a planar base)
    the source's own at every frame, and the root's positions the source's
    path (`positions`) plus the solve's corrections to it (feet planted,
    balance) interpolated, with no sole below the floor. The balance pass
    estimates the centre of pressure of the clip so brought back: at a
    capture's 200 fps the solved frames' own estimate differed from it by
    1 cm (median) to 10 cm near a landing."""

    def __init__(self, retargeter, solved: np.ndarray, fps: float, contacts: dict, base, rotations, positions):
        """`contacts`: the clip's foot contacts at every frame (the support the
        balance pass measures); `base`, `rotations`, `positions`: the source's
        root path at every frame (`Retargeter.root_path`)."""
        self.r, self.solved, self.fps, self.contacts = retargeter, solved, fps, contacts
        self.base, self.rotations, self.positions = base, rotations, positions
        self.frames = len(rotations)
        parts = retargeter.parts
        self.fingers = sorted({j for part in parts if part.level == FINGER_LEVEL for j in part.problem.joints})

    def joints(self, q_solved: np.ndarray) -> np.ndarray:
        """Joint positions at every frame, within the joints' limits."""
        everywhere = np.arange(self.frames)
        q = np.empty((self.frames, q_solved.shape[1]))
        rest = np.setdiff1d(np.arange(q.shape[1]), self.fingers)
        q[:, rest] = hermite(self.solved, q_solved[:, rest], everywhere)
        for j in self.fingers:
            q[:, j] = np.interp(everywhere, self.solved, q_solved[:, j])
        if self.base is not None:
            q[:, self.r.base] = self.base
        return np.clip(q, self.r.embodiment.position_lower, self.r.embodiment.position_upper)

    def root(self, q: np.ndarray, positions_solved: np.ndarray) -> np.ndarray:
        """Root positions at every frame, given its joints `q` there."""
        r, source = self.r, self.positions
        positions = source + hermite(self.solved, positions_solved - source[self.solved], np.arange(self.frames))
        if r.legged and r.soles.feet:  # between solved frames a sole may dip below the floor by a fraction of a mm
            poses = r.tree.forward_frames(q, self.rotations, positions, r._body_groups)
            lowest = np.min([r.soles.lowest_frames(poses, side) for side in r.soles.feet], axis=0)
            positions[:, 2] += np.maximum(-lowest, 0.0)
        return positions


def solved_frames(frames: int, fps: float, rate: float) -> np.ndarray:
    """The frames a whole-clip solve works on: every k-th (k the largest
    that keeps `rate` or more a second) and the last; all of a short clip."""
    stride = max(int(fps // rate), 1)
    if stride == 1 or frames < 4 * stride:
        return np.arange(frames)
    return np.unique(np.r_[np.arange(0, frames, stride), frames - 1])


def contacts_on(contacts: dict, solved: np.ndarray) -> dict:
    """Foot contacts on the `solved` frames: planted where the foot is
    planted on any frame nearer than the next solved one, so every planted
    frame lies between two planted solved frames (both on the foot's
    anchor) and an interpolated frame does not slide."""
    reach = int(np.max(np.diff(solved))) - 1 if len(solved) > 1 else 0
    window = np.ones(2 * reach + 1)
    near = {side: np.convolve(flags.astype(float), window, mode="same") for side, flags in contacts.items()}
    return {side: count[solved] > 0.0 for side, count in near.items()}


def _retarget_solved(
    retargeter,
    src: dict,
    src_frames: dict,
    contacts: dict,
    ratio: float,
    fps: float,
    own_rate: OwnRate | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`retarget_clip` on every frame it is given.

    Coarse to fine: the programs first converge on every `coarse_stride`-th
    frame from the standing pose; the joint paths interpolated from them
    (cubic, `hermite`) start the relinearisations over all frames (the
    fingers' only if their coarse solve had not settled); then the legs'
    program solves the legs and plants the feet; last, the balance pass
    (`balance`) shifts the body over its feet (`retargeter.margins`: the
    support margins before and after).
    """
    r, options = retargeter, retargeter.options
    lower, upper = r.embodiment.position_lower, r.embodiment.position_upper
    frames = len(next(iter(src.values())))
    q = np.tile(r.embodiment.standing_pose, (frames, 1))
    base, rotations, positions = r.root_path(src, src_frames, ratio)
    if base is not None:
        q[:, r.base] = base
    stride = options.coarse_stride
    coarse_pass = stride > 1 and frames >= 4 * stride
    # After a coarse pass, the legs' program alone solves the legs over all frames.
    solver = ClipSolver(r, frames, legs=not coarse_pass)
    if r.legged and solver.plants_feet:
        for side, (way, rise) in foot_rolls(src, src_frames, contacts).items():
            if side in solver.edges:
                solver.rolls[side] = solver.edges[side].rolls_rising(ratio * rise, way)
    fixed = solver.source_targets(src, src_frames)
    if coarse_pass:
        coarse = np.unique(np.r_[np.arange(0, frames, stride), frames - 1])
        q_coarse, on_coarse = q[coarse], (rotations[coarse], positions[coarse], _take(fixed, coarse))
        settle = {"tolerance": options.coarse_tolerance, "quantile": options.coarse_quantile}
        coarse_solver = ClipSolver(r, len(coarse))
        coarse_solver.solve_parts(q_coarse, *on_coarse, options.clip_iterations, **settle)
        fingers = coarse_solver.solve_fingers(q_coarse, *on_coarse, options.clip_iterations, **settle)
        everywhere = np.arange(frames)
        body = sorted({j for part in r.parts if part.level < FINGER_LEVEL for j in part.problem.joints})
        q[:, body] = hermite(coarse, q_coarse[:, body], everywhere)
        np.clip(q, lower, upper, out=q)  # a cubic may overshoot; the pass over all frames takes it back
        # The fingers linearly: a settled hand is not solved again, and a cubic would overshoot a held shape.
        for j in {j for part in r.parts if part.level == FINGER_LEVEL for j in part.problem.joints}:
            q[:, j] = np.interp(everywhere, coarse, q_coarse[:, j])
        solver.solve_parts(q, rotations, positions, fixed, options.fine_iterations)
        # The fingers may stay as interpolated: their coarse solve settled and waits for no other level.
        if fingers >= options.tolerance:
            solver.solve_fingers(q, rotations, positions, fixed, options.fine_iterations)
    else:
        solver.solve_parts(q, rotations, positions, fixed, options.clip_iterations)
        solver.solve_fingers(q, rotations, positions, fixed, options.clip_iterations)
    r.margins = {}
    if r.legged:
        positions = solver.plant_feet(q, rotations, positions, contacts, fixed, fps)
        if options.balance and r.spec.floating_base and solver.plants_feet and contacts:
            positions, r.margins = balance(solver, q, rotations, positions, contacts, fixed, fps, own_rate)
    np.clip(q, lower, upper, out=q)
    return q, rotations, positions
