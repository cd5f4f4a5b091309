"""Kinematic retargeting of landmark motion onto one embodiment.

The floating base follows the source pelvis (scaled by the ratio of leg
lengths); every functional part then solves its partial IK (proximal parts
first) against directions and body frames of the source; planted feet are
pinned where they landed and the root height keeps the soles on the floor.
Velocities are finite differences of the positions.

A whole clip is solved offline by one program per level of the tree over
all frames (`clip_programs`); a stream (`RetargetStream`, the
`RetargetingSystem` of a diagram) solves one frame at a time. Both share
the parts and their targets.
"""

import copy
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.hands import COUPLED_JOINTS
from hotu_drake.embodiment.landmarks import landmark_placements
from hotu_drake.embodiment.spec import FINGERS, SIDES
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import landmarks_of
from hotu_drake.objects import scale_object_poses
from hotu_drake.retarget import frames
from hotu_drake.retarget.balance import ClipBalance
from hotu_drake.retarget.clip_programs import retarget_clip
from hotu_drake.retarget.contacts import Soles, detect_foot_contacts
from hotu_drake.retarget.neutral import calibrate, neutral_calibration
from hotu_drake.retarget.part_ik import FINGER_LEVEL, SHAPE_TOLERANCE, PartProblem
from hotu_drake.retarget.source_frames import hand_frame_kind, low_passed, source_frames
from hotu_drake.retarget.stance import leg_clearance
from hotu_drake.retarget.targets import (
    BendPlane,
    Coupling,
    Direction,
    Landmarks,
    LevelSideways,
    Orientation,
    Position,
    Sideways,
    SidewaysStance,
    sideways_offsets,
    sideways_target,
)
from hotu_drake.retarget.tree import Tree, cross, rotation_vector
from hotu_drake.retarget.udh_rest import udh_rest_landmarks
from hotu_drake.rotations import heading_rotation, matrix_to_quat

LOCK_STEPS = 2  # leg-IK steps at most per planted foot and frame
LOCK_TOLERANCE = 0.002  # m: a planted ankle this close to its anchor is left alone
LEVEL_TOLERANCE = 0.01  # rad: and a planted sole this close to level
WRIST_POINTING_WEIGHT = 3.0  # the wrist-to-hand direction's weight beside the hand frame's (1)
# A foot's sideways offset from its own hip (m), beside the thigh's direction (1): the robot keeps its
# own stance where its hips are wider apart (for its leg length) than the source's. At 20 (10 before) the
# UDH's planted feet keep nearer their targets on CMU 01_01 (its median stance 1.574 -> 1.553 of its width,
# H1's 1.250 then 0.805 of it) at 5-15% more foot skate on the captures; heavier weights let the feet slide
# more still, and a clip solved at 60 fps strays further from its every-frame solve.
SIDEWAYS_WEIGHT = 20.0
# A foot's roll held at level, beside its toe's direction (1): a swing foot rolled to point its toe hit
# the other leg (Walker's library walk: 3 cm into the other shank).
LEVEL_WEIGHT = 0.5


@dataclass
class RetargetOptions:
    """Knobs of the whole-clip and the per-frame solves."""

    whole_clip: bool = True  # a clip at once (`clip_programs`); False: frame by frame, as a stream does
    # Whole clip: at most this many relinearisations of all levels on the coarse frames (or on all frames
    # of a clip too short for a coarse pass), or until no joint moves more (rad) on this share of the
    # coarse frames; the pass over all frames does the rest.
    clip_iterations: int = 8
    coarse_tolerance: float = 0.04
    coarse_quantile: float = 0.99
    coarse_stride: int = 8  # every this many frames of the clip (1: no coarse pass)
    # Whole clip: a faster clip is solved at this rate or a little above (every k-th frame) and interpolated.
    solve_rate: float = 60.0
    fine_iterations: int = 1  # then over all frames, of the levels but the legs'
    lock_iterations: int = 1  # and of the legs' program, which solves the legs and plants the feet
    sweeps: int = 2  # at most this many passes over all parts per frame (30 fps)
    high_rate_sweeps: int = 1  # the same at 60 fps or more, where frames are close
    tolerance: float = 2e-3  # stop the passes once no joint moves more (rad)
    first_frame_sweeps: int = 12  # from the standing pose to the first frame
    regularization: float = 1e-3
    smoothness: float = 1e-2
    lock_feet: bool = True
    # Whole clip: shift the body so the centre of pressure stays inside the planted soles (`clip_programs.balance`).
    balance: bool = True
    # Whole clip of a human: its landmarks low-passed first, a Gaussian of this sigma (s; about 8 Hz). On CMU
    # 01_01 the centre of pressure came inside on 0.89-0.97 of the frames instead of 0.47-0.89, the feet
    # skating half as much; 0.03-0.04 s balanced a little more and skated more.
    source_smoothing: float = 0.02
    # Match limb directions relative to the embodiment's neutral pose (`neutral_calibration`).
    calibrate: bool = True
    # Whole clip: the clip's timing. "person" keeps the source's; "dynamic" plays a legged embodiment's clip
    # `dynamic_pace` times as fast (dynamic similarity: the source's Froude number kept, so the body swings at
    # the pace of its own pendulum); "auto", dynamic where that pace is more than `AUTO_PACE` times the
    # person's (or less than its inverse), else the person's. A stream keeps the person's (it is live).
    pace: str = "auto"

    def __post_init__(self) -> None:
        if self.pace not in PACES:
            raise ValueError(f"pace '{self.pace}': choose from {', '.join(PACES)}")


PACES = ("auto", "person", "dynamic")
# "auto" paces a clip dynamically beyond this factor: a person walks at 0.8-1.25 of their own preferred pace,
# so within it the person's timing is one a body of that size walks at too. Measured (`bench performs`,
# BENCHMARKS.md): BRUCE (1.43) stood in 43 of 64 library starts at the dynamic pace, 29 at the person's; NAVIAI
# (1.08) and Walker (1.20) lost starts of the fast walk at the dynamic pace (4 and 1 of 4).
AUTO_PACE = 1.25


def dynamic_pace(ratio: float) -> float:
    """How many times as fast an embodiment whose legs are `ratio` times the
    source's moves under dynamic similarity: gravity sets the time scale of a
    walking body (a pendulum's period grows as the square root of its length),
    so a body half as tall walks with steps 1/sqrt(2) as long in time (BRUCE,
    0.49 of the UDH's legs: 1.43x; Walker 1.20x, NAVIAI 1.08x, H1 1.01x)."""
    return 1.0 / np.sqrt(ratio)


@dataclass
class _Part:
    name: str
    level: int  # 0 = torso, 1 = shoulders and hips ... FINGER_LEVEL = fingers
    problem: PartProblem
    targets: list  # (target, source key)
    # Fingers: the source's finger directions in its hand frame when last
    # solved, and whether that solve had settled (then an unchanged hand
    # shape needs no new solve).
    signature: np.ndarray | None = None
    settled: bool = False


def leg_length(p: dict[str, np.ndarray]) -> float:
    """Median hip-knee-ankle length over both legs and all frames: the body scale of the root path."""
    lengths = [
        np.linalg.norm(p[f"{s}_knee"] - p[f"{s}_hip"], axis=-1)
        + np.linalg.norm(p[f"{s}_ankle"] - p[f"{s}_knee"], axis=-1)
        for s in SIDES
    ]
    return float(np.median(np.concatenate([np.atleast_1d(x) for x in lengths])))


class Retargeter:
    """Retargets landmark motion (a human or the UDH) onto one embodiment."""

    def __init__(self, embodiment: Embodiment, source_landmarks: set[str], options: RetargetOptions | None = None):
        self.embodiment = embodiment
        self.options = options or RetargetOptions()
        self.spec = embodiment.spec
        self.tree = Tree(self.spec)
        self.marks = Landmarks(self.tree, landmark_placements(self.spec))
        self.q_rest = np.zeros(len(self.tree.joint_names))
        rest_pose = self.tree.forward(self.q_rest)
        self.rest = self.marks.all_positions(rest_pose)
        self.rest_frames = self._rest_frames()
        self.pelvis_offset = self.rest["pelvis"] - rest_pose.positions[self.tree.root]
        self.rest_leg_length = leg_length(self.rest) if "left_ankle" in self.rest else 0.0
        self.stance = self._stance() if "left_ankle" in self.rest else {}
        self.soles = Soles(self.spec, self.tree)
        self.legged = "left_ankle" in self.marks and "left_ankle" in source_landmarks
        self.parts = self._build_parts(set(source_landmarks))
        self._lock = self._build_leg_locks() if self.legged else {}
        self.balance = ClipBalance(embodiment) if self.legged else None
        self.margins: dict[str, np.ndarray] = {}  # the last whole clip's support margins, before and after balancing
        self.base = [self.tree.joint_index[n] for n in embodiment.base_joints]
        fingers = set(embodiment.finger_joints)
        body = [i for i, n in enumerate(self.tree.joint_names) if n not in fingers]
        self._body_groups = self.tree.depth_groups(body)
        # The joints above each leg's ankle, toe and sole: all that planting a foot moves or looks at.
        sole = {side: [link] for side, (link, _, _) in self.soles.feet.items()}
        legs = {
            joint
            for side in self._lock
            for link in [self._link_of(f"{side}_ankle"), self._link_of(f"{side}_toe"), *sole.get(side, [])]
            for joint in self.tree.link_ancestors[link]
        }
        self._leg_groups = self.tree.depth_groups(sorted(legs))
        self.calibration: dict = {}
        if self.options.calibrate and embodiment.name != "udh":
            self.calibration = neutral_calibration(self, set(source_landmarks))
            for part in self.parts:  # the neutral solve is not a frame of any clip
                part.signature, part.settled = None, False

    # --- set-up -------------------------------------------------------------------

    def _rest_frames(self) -> dict[str, np.ndarray]:
        p = self.rest
        out = {"chest": frames.chest_frame(p)}
        if "left_hip" in p:
            out["pelvis"] = frames.pelvis_frame(p)
        if "head_top" in p:
            out["head"] = frames.head_frame(p)
        for side in SIDES:
            if all(f"{side}_{n}" in p for n in ("wrist", "hand", "index_1", "little_1")):
                out[f"{side}_hand"] = frames.hand_frame(p, side)
            if f"{side}_toe" in p and "pelvis" in out:
                out[f"{side}_foot"] = frames.foot_frame(p, side, out["pelvis"][:, 1])
        return out

    def _stance(self) -> dict[tuple[str, str], SidewaysStance]:
        """Per (hip, leg point: knee, ankle or toe): the standing pose's offset
        from the hip (m, sideways), the human standing straight's (the UDH
        at rest) per unit of leg, and the bounds that keep the point on its
        side of the midline, clear of the other leg (`leg_clearance`); the
        toe's keeps a foot from turning into the other."""
        standing_pose = self.tree.forward(self.embodiment.standing_pose)
        standing = {k: v[None] for k, v in self.marks.all_positions(standing_pose).items()}
        human = {k: v[None] for k, v in udh_rest_landmarks().items()}
        human_leg = leg_length(human)
        heading = heading_rotation(frames.pelvis_frame(standing))[0]
        middle = (standing["left_hip"][0] + standing["right_hip"][0]) / 2
        clearance = leg_clearance(self.spec)
        out = {}
        for point in ("knee", "ankle", "toe"):
            own, neutral = sideways_offsets(standing, point), sideways_offsets(human, point)
            for s, sign in (("left", 1.0), ("right", -1.0)):
                hip = float(heading[:, 1] @ (standing[f"{s}_hip"][0] - middle))  # the hip's own side of the midline
                clear = clearance[point] / 2 - sign * hip  # the offset that brings the point to half the clearance
                low, high = (clear, np.inf) if sign > 0 else (-np.inf, -clear)
                out[(f"{s}_hip", point)] = SidewaysStance(float(own[s][0]), float(neutral[s][0]) / human_leg, low, high)
        return out

    @contextmanager
    def sideways_weighted(self, factor: float) -> Iterator[None]:
        """The legs' sideways targets weighted `factor` times over within the
        block: where the feet's width must hold against the legs' directions
        (the neutral solve; the balance pass, which sways the pelvis over feet
        that stay)."""
        targets = [t for part in self.parts for t, key in part.targets if isinstance(key, tuple) and key[0] == "side"]
        weights = [target.weight for target in targets]
        for target in targets:
            target.weight *= factor
        try:
            yield
        finally:
            for target, weight in zip(targets, weights):
                target.weight = weight

    def stance_of(self, key: tuple) -> SidewaysStance:
        """The `SidewaysStance` of a sideways target's key."""
        return self.stance[(key[1], key[4].rsplit("_", 1)[1])]

    def _joints(self, prefix: str) -> list[int]:
        return [i for i, n in enumerate(self.tree.joint_names) if n.startswith(prefix)]

    def _link_of(self, landmark: str) -> int:
        return self.marks.items[landmark][0]

    def _hinge_sign(self, joint: int, start: str, mid: str, end: str) -> float:
        """Which way a hinge's axis points relative to its limb's bend normal."""
        spec_joint = self.spec.joints[joint]
        flex = spec_joint.upper if abs(spec_joint.upper) >= abs(spec_joint.lower) else spec_joint.lower
        q = self.q_rest.copy()
        q[joint] = 0.5 * flex
        pose = self.tree.forward(q)
        a, b, c = (self.marks.position(pose, n) for n in (start, mid, end))
        normal = np.cross(b - a, c - b)
        return 1.0 if np.dot(normal, pose.joint_axes[joint]) >= 0 else -1.0

    def _problem(self, name: str, joints: list[int]) -> PartProblem:
        return PartProblem(
            name,
            joints,
            self.embodiment.position_lower[joints],
            self.embodiment.position_upper[joints],
            self.options.regularization,
            self.options.smoothness,
        )

    def _build_parts(self, src: set[str]) -> list[_Part]:
        parts: list[_Part] = []
        both = src & set(self.marks.items)

        def add(name: str, level: int, joints: list[int], targets: list) -> None:
            targets = [t for t in targets if t is not None]
            if joints and targets:
                parts.append(_Part(name, level, self._problem(name, joints), targets))

        root_link = self.tree.root
        hips_on_root = self._link_of("left_hip") == root_link if "left_hip" in self.marks else False
        self.root_frame = "pelvis" if hips_on_root or "left_hip" not in self.marks else "chest"
        torso_frame = "chest" if self.root_frame == "pelvis" else "pelvis"
        torso_link = self._link_of("left_shoulder" if torso_frame == "chest" else "left_hip")
        add("torso", 0, self._joints("torso_"), [(Orientation(torso_link, self.rest_frames[torso_frame]), torso_frame)])
        if "head" in self.rest_frames and "head_top" in src:
            head_link = self._link_of("head")
            add("neck", 2, self._joints("neck_"), [(Orientation(head_link, self.rest_frames["head"]), "head")])
        for side in SIDES:
            s = f"{side}_"
            elbow = self._joints(f"{s}elbow_")
            bend = self._bend(both, elbow, f"{s}shoulder", f"{s}elbow", f"{s}wrist")
            add(
                f"{s}shoulder",
                1,
                self._joints(f"{s}shoulder_"),
                [self._direction(both, f"{s}shoulder", f"{s}elbow"), bend],
            )
            add(f"{s}elbow", 2, elbow, [self._direction(both, f"{s}elbow", f"{s}wrist")])
            hand = f"{s}hand"
            if hand in self.rest_frames and {f"{s}index_1", f"{s}little_1", hand} <= src:
                wrist_targets = [(Orientation(self._link_of(hand), self.rest_frames[hand]), hand)]
                # Where the arm cannot reach the whole hand frame, it points the hand first.
                pointing = self._direction(both, f"{s}wrist", hand)
                if pointing is not None:
                    wrist_targets.append((replace(pointing[0], weight=WRIST_POINTING_WEIGHT), pointing[1]))
            else:
                wrist_targets = [self._direction(both, f"{s}wrist", hand)]
            add(f"{s}wrist", 3, self._joints(f"{s}wrist_"), wrist_targets)
            # The finger part: all fingers of one hand in one program.
            model = self.spec.hand_mounts.get(side, ("none",))[0]
            finger_joints, finger_targets = [], []
            for finger in FINGERS:
                joints = self._joints(f"{s}{finger}_")
                targets = [t for t in (self._finger(both, side, finger, i) for i in (1, 2, 3)) if t is not None]
                if not targets:  # a capture with fewer finger points: the whole finger at once
                    targets = [t for t in (self._whole_finger(src, side, finger),) if t is not None]
                if joints and targets:
                    start = len(finger_joints)
                    pairs = COUPLED_JOINTS.get(model, {}).get(finger, ())
                    finger_targets += targets + [(Coupling(start + a, start + b), "q") for a, b in pairs]
                    finger_joints += joints
            add(f"{s}finger", FINGER_LEVEL, finger_joints, finger_targets)
            knee = self._joints(f"{s}knee_")
            bend = self._bend(both, knee, f"{s}hip", f"{s}knee", f"{s}ankle")
            add(
                f"{s}hip",
                1,
                self._joints(f"{s}hip_"),
                [
                    self._direction(both, f"{s}hip", f"{s}knee"),
                    bend,
                    self._sideways(both, s, "knee"),
                    self._sideways(both, s, "ankle"),
                    self._sideways(both, s, "toe"),
                ],
            )
            add(f"{s}knee", 2, knee, [self._direction(both, f"{s}knee", f"{s}ankle")])
            # Ankle to ball of the foot fixes pitch and yaw; roll is not observable
            # from two points, so it stays put (and planted feet are levelled).
            add(
                f"{s}ankle",
                3,
                self._joints(f"{s}ankle_"),
                [self._direction(both, f"{s}ankle", f"{s}toe"), self._level_foot_target(s)],
            )
        return sorted(parts, key=lambda p: p.level)

    def _bend(self, both: set[str], hinge: list[int], proximal: str, middle: str, distal: str):
        """The bend plane of a limb whose middle joint is the hinge `hinge` (elbow, knee), if it has one."""
        if hinge and {proximal, middle, distal} <= both:
            sign = self._hinge_sign(hinge[0], proximal, middle, distal)
            return BendPlane(hinge[0], sign), ("bend", proximal, middle, distal)
        return None

    def _sideways(self, both: set[str], s: str, point: str):
        """A leg point's (knee, ankle or toe) sideways offset from its hip, as the source's scaled to this leg."""
        hip, knee, ankle = f"{s}hip", f"{s}knee", f"{s}ankle"
        if {hip, knee, ankle, f"{s}{point}", "right_hip", "left_hip"} <= both:
            return Sideways(hip, f"{s}{point}", SIDEWAYS_WEIGHT), ("side", hip, knee, ankle, f"{s}{point}")
        return None

    def _level_foot_target(self, s: str):
        """The foot unrolled (its sideways axis horizontal): the source's two foot points leave the roll free."""
        foot = f"{s}foot"
        if foot in self.rest_frames and f"{s}toe" in self.marks:
            return LevelSideways(self._link_of(f"{s}toe"), self.rest_frames[foot], LEVEL_WEIGHT), ("level", s)
        return None

    def _direction(self, both: set[str], start: str, end: str):
        if {start, end} <= both:
            return Direction(start, end), ("dir", start, end)
        return None

    def _finger(self, both: set[str], side: str, finger: str, i: int):
        start, end = f"{side}_{finger}_{i}", f"{side}_{finger}_{i + 1}"
        hand = f"{side}_hand"
        if {start, end} <= both and hand in self.rest_frames:
            return Direction(start, end, 0.5), ("finger", start, end, hand)
        return None

    def _whole_finger(self, src: set[str], side: str, finger: str):
        """One direction over a whole finger for a source without the
        finger's middle points (`whole_finger_points`)."""
        points = whole_finger_points(src, set(self.marks.items), side, finger)
        if points is None or f"{side}_hand" not in self.rest_frames or hand_frame_kind(src, side) is None:
            return None
        source_base, source_tip, base, tip = points
        return Direction(base, tip, 0.5), ("finger", source_base, source_tip, f"{side}_hand")

    def _build_leg_locks(self) -> dict[str, tuple[PartProblem, Position, Orientation]]:
        locks = {}
        for side in SIDES:
            joints = self._joints(f"{side}_hip_") + self._joints(f"{side}_knee_") + self._joints(f"{side}_ankle_")
            foot = f"{side}_foot"
            if joints and foot in self.rest_frames:
                orientation = Orientation(self._link_of(f"{side}_toe"), self.rest_frames[foot], 1.0)
                locks[side] = (self._problem(f"{side}_leg_lock", joints), Position(f"{side}_ankle", 10.0), orientation)
        return locks

    def calibrated(self, key, directions: np.ndarray, src: dict, src_frames: dict) -> np.ndarray:
        """Source directions (T, 3) of a direction target as this embodiment's
        neutral pose holds them (`neutral.calibrate`)."""
        return calibrate(self.calibration, key, directions, src, src_frames)

    def root_path(
        self, src: dict[str, np.ndarray], src_frames: dict[str, np.ndarray], ratio: float
    ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
        """Planar base joints (T, 3) (none for a floating base), root rotations
        (T, 3, 3) and positions (T, 3) that follow the source, before the feet."""
        frames_count = len(next(iter(src.values())))
        root_rest = self.rest_frames.get(self.root_frame)
        pelvis = src.get("pelvis")
        if self.spec.floating_base and pelvis is not None:
            rotations = src_frames[self.root_frame] @ root_rest.T
            return None, rotations, pelvis * ratio - rotations @ self.pelvis_offset
        if self.spec.floating_base:  # the upper body only: stand under the chest, facing its way
            rotations = heading_rotation(src_frames["chest"] @ root_rest.T)
            positions = src["chest"].copy()
            positions[:, 2] = self.embodiment.standing_root_height
            return None, rotations, positions
        # A planar base follows the pelvis (or the chest) over the floor.
        over = pelvis if pelvis is not None else src["chest"]
        heading = heading_rotation(src_frames["pelvis"])
        base = np.column_stack((over[:, 0], over[:, 1], np.arctan2(heading[:, 1, 0], heading[:, 0, 0])))
        return base, np.tile(np.eye(3), (frames_count, 1, 1)), np.zeros((frames_count, 3))

    # --- per frame ----------------------------------------------------------------

    def _target(self, key, t: int, src: dict, src_frames: dict, pose) -> np.ndarray:
        kind = key if isinstance(key, str) else key[0]
        if kind == "dir":
            v = src[key[2]][t] - src[key[1]][t]
            v = v / max(np.linalg.norm(v), 1e-9)
            if key not in self.calibration:
                return v
            here = {n: f[t : t + 1] for n, f in src.items()}
            return self.calibrated(key, v[None], here, {n: f[t : t + 1] for n, f in src_frames.items()})[0]
        if kind == "level":
            return np.zeros(1)
        if kind == "side":
            here = {n: src[n][t : t + 1] for n in key[1:]}
            pelvis = {"pelvis": src_frames["pelvis"][t : t + 1]}
            return sideways_target(here, pelvis, key, self.rest_leg_length, self.stance_of(key))[0]
        if kind == "bend":
            a, b, c = (src[n][t] for n in key[1:])
            u1, u2 = b - a, c - b
            return cross(u1 / max(np.linalg.norm(u1), 1e-9), u2 / max(np.linalg.norm(u2), 1e-9))
        if kind == "finger":
            v = src[key[2]][t] - src[key[1]][t]
            v = v / max(np.linalg.norm(v), 1e-9)
            hand = key[3]
            robot_hand = pose.rotations[self._link_of(hand)] @ self.rest_frames[hand]
            return robot_hand @ (src_frames[hand][t].T @ v)
        return src_frames[key][t]  # a body frame

    def _solve_parts(self, q, q_previous, root_rotation, root_position, t, src, src_frames, sweeps) -> None:
        for _ in range(sweeps):
            level = None
            pose = None
            largest = 0.0
            for part in self.parts:
                if part.level == FINGER_LEVEL and self._finger_unchanged(part, t, src, src_frames):
                    continue
                if part.level != level:  # proximal parts first; fingers need the full tree
                    groups = None if part.level >= FINGER_LEVEL else self._body_groups
                    pose = self.tree.forward(q, root_rotation, root_position, groups)
                    level = part.level
                rows = [
                    target.rows(
                        self.marks,
                        pose,
                        part.problem.joints,
                        q if key == "q" else self._target(key, t, src, src_frames, pose),
                    )
                    for target, key in part.targets
                ]
                step = part.problem.step(rows, q[part.problem.joints], q_previous[part.problem.joints])
                q[part.problem.joints] += step
                largest = max(largest, float(np.max(np.abs(step))))
                part.settled = float(np.max(np.abs(step))) < self.options.tolerance
            if largest < self.options.tolerance:
                break

    def _finger_unchanged(self, part: _Part, t: int, src: dict, src_frames: dict) -> bool:
        """True if the source hand's shape is as when this settled part was solved."""
        shape = []
        for _, key in part.targets:
            if key != "q":
                v = src[key[2]][t] - src[key[1]][t]
                shape.append(src_frames[key[3]][t].T @ (v / max(np.linalg.norm(v), 1e-9)))
        shape = np.concatenate(shape)
        same = part.signature is not None and np.max(np.abs(shape - part.signature)) < SHAPE_TOLERANCE
        unchanged = same and part.settled
        if not unchanged:
            part.signature = shape
        return unchanged

    def retarget(self, source: MotionClip) -> MotionClip:
        """The source (a human or UDH clip, through its landmarks) on this
        embodiment. A human clip retargeted whole has its body's landmarks
        low-passed first (`RetargetOptions.source_smoothing`; each hand
        as a rigid body): a capture's markers jitter from frame to frame, which its
        centre of pressure and foot contacts would take for motion."""
        if source.embodiment != "human":
            return self.retarget_landmarks(_landmarks_of_embodiment_clip(source), source.fps, source)
        src = landmarks_of(source)
        if self.options.whole_clip and self.options.source_smoothing > 0.0:
            src = low_passed(src, source.fps, self.options.source_smoothing)
        return self.retarget_landmarks(src, source.fps, source)

    def retarget_landmarks(
        self, src: dict[str, np.ndarray], fps: float, source: MotionClip | None = None
    ) -> MotionClip:
        """Retarget landmark trajectories {name: (T, 3)} sampled at `fps`."""
        frames_count = len(next(iter(src.values())))
        src_frames = source_frames(src)
        contacts = {}
        if self.legged:  # the source's own foot contacts carry through human -> UDH -> robot
            contacts = foot_contacts_of(source, frames_count) or detect_foot_contacts(src, fps)
        if self.options.whole_clip:
            ratio = self.scale_ratio(src)
            fps = fps * self.pace_factor(ratio)  # the same frames, closer in time where the pace is dynamic
            q, rotations, positions = retarget_clip(self, src, src_frames, contacts, ratio, fps)
            return self._clip(q, rotations, positions, fps, source, contacts, ratio)
        stream = RetargetStream(self, fps, src)
        out_q = np.zeros((frames_count, len(self.tree.joint_names)))
        out_rotation = np.zeros((frames_count, 3, 3))
        out_position = np.zeros((frames_count, 3))
        for t in range(frames_count):
            frame = {name: value[t : t + 1] for name, value in src.items()}
            body = {name: value[t : t + 1] for name, value in src_frames.items()}
            planted = {side: bool(flags[t]) for side, flags in contacts.items()}
            out_q[t], out_rotation[t], out_position[t] = stream.push(frame, body, planted)
        return self._clip(out_q, out_rotation, out_position, fps, source, contacts, stream.ratio)

    def pace_factor(self, ratio: float) -> float:
        """How many times as fast as the source this embodiment's whole clip
        plays (`RetargetOptions.pace`), its legs `ratio` times the source's."""
        factor, pace = dynamic_pace(ratio), self.options.pace
        dynamic = pace == "dynamic" or (pace == "auto" and max(factor, 1.0 / factor) > AUTO_PACE)
        return factor if dynamic else 1.0

    def scale_ratio(self, src: dict[str, np.ndarray]) -> float:
        """The body-size ratio (leg lengths, this embodiment over the source)
        that scales the root path and the objects."""
        return leg_length(self.rest) / leg_length(src) if self.legged else 1.0

    def _body_pose(self, q, root_rotation, root_position):
        """Poses of every link but the fingers."""
        return self.tree.forward(q, root_rotation, root_position, self._body_groups)

    def _leg_pose(self, q, root_rotation, root_position):
        """Poses of the legs' links (the others left unset): what `_feet` moves and looks at."""
        return self.tree.forward(q, root_rotation, root_position, self._leg_groups)

    def _feet(self, q, root_rotation, root_position, contacts, anchors, height_offset):
        """Keep planted soles on the floor and where they landed."""
        pose = self._leg_pose(q, root_rotation, root_position)
        planted = [s for s in SIDES if contacts.get(s)]
        for side in SIDES:
            if side not in planted:
                anchors.pop(side, None)
        if planted:
            lift = -min(self.soles.lowest(pose, s) for s in planted)
            root_position = root_position + [0.0, 0.0, lift]
            height_offset += lift
            pose = pose.translated([0.0, 0.0, lift])
            if self.options.lock_feet:
                for side in planted:  # a planted sole is flat: level it, and anchor it where it lands
                    for _ in range(LOCK_STEPS):
                        if self._tilt(pose, side) < LEVEL_TOLERANCE:
                            break
                        self._lock_leg(side, q, pose, None, self._level_foot(pose, side))
                        pose = self._leg_pose(q, root_rotation, root_position)
                    anchors.setdefault(side, self.marks.position(pose, f"{side}_ankle").copy())
                # The earliest planted foot carries the body: shift the root onto it.
                first = planted[0]
                drift = anchors[first] - self.marks.position(pose, f"{first}_ankle")
                root_position = root_position + [drift[0], drift[1], 0.0]
                pose = pose.translated([drift[0], drift[1], 0.0])
                for side in planted:
                    foot = self._level_foot(pose, side)
                    for _ in range(LOCK_STEPS):  # until the ankle is on its anchor and the sole level
                        near = np.linalg.norm(self.marks.position(pose, f"{side}_ankle") - anchors[side])
                        if near < LOCK_TOLERANCE and self._tilt(pose, side) < LEVEL_TOLERANCE:
                            break
                        self._lock_leg(side, q, pose, anchors[side], foot)
                        pose = self._leg_pose(q, root_rotation, root_position)
        feet = [self.soles.lowest(pose, s) for s in SIDES if s in self.soles.feet]
        if feet and min(feet) < 0.0:  # never below the floor
            root_position = root_position + [0.0, 0.0, -min(feet)]
            height_offset -= min(feet)
        return root_position, height_offset

    def _tilt(self, pose, side: str) -> float:
        """How far (rad) the foot's sole is from level."""
        rotation = pose.rotations[self._link_of(f"{side}_toe")]
        return float(np.linalg.norm(rotation_vector(heading_rotation(rotation) @ rotation.T)))

    def _level_foot(self, pose, side: str) -> np.ndarray:
        """The foot frame of a flat sole with the foot's current heading."""
        return heading_rotation(pose.rotations[self._link_of(f"{side}_toe")]) @ self.rest_frames[f"{side}_foot"]

    def _lock_leg(self, side, q, pose, anchor, foot_frame) -> None:
        """One IK step of the whole leg that brings the ankle back to its anchor
        (none: anywhere) with the foot frame `foot_frame` (`pose` is the current
        configuration)."""
        if side not in self._lock:
            return
        problem, position, orientation = self._lock[side]
        joints = problem.joints
        rows = [] if anchor is None else [position.rows(self.marks, pose, joints, anchor)]
        rows.append(orientation.rows(self.marks, pose, joints, foot_frame))
        q[joints] += problem.step(rows, q[joints], q[joints])

    def _clip(self, q, rotations, positions, fps, source, contacts, ratio: float = 1.0) -> MotionClip:
        """The retargeted clip; the source's object tracks scaled by the
        body-size `ratio` the root was scaled by (`objects.scale_object_poses`)."""
        quaternions = matrix_to_quat(rotations)
        key_names = list(self.embodiment.key_bodies.values())
        key_names = list(dict.fromkeys(key_names))
        key_index = [self.tree.link_index[n] for n in key_names]
        key_positions = self.tree.forward_frames(q, rotations, positions, self._body_groups).positions[:, key_index]
        contact_names = [f"{s}_foot" for s in SIDES if s in contacts]
        objects = None
        if source is not None and source.object_poses is not None:
            objects = scale_object_poses(list(source.object_names), source.object_poses, ratio)
        contact_values = np.stack([contacts[s] for s in SIDES if s in contacts], axis=1) if contacts else None
        return MotionClip.from_positions(
            self.embodiment.name,
            source.source if source is not None else "landmarks",
            fps,
            self.tree.joint_names,
            q,
            positions,
            quaternions,
            key_names,
            key_positions,
            part_index=self.embodiment.parts,
            object_names=list(source.object_names) if source is not None else [],
            object_poses=objects,
            contact_names=contact_names if contacts else [],
            contacts=contact_values,
        )


class RetargetStream:
    """Retargets one frame at a time, carrying the warm start, the planted
    feet's anchors and the root height offset from frame to frame."""

    def __init__(self, retargeter: Retargeter, fps: float, sample: dict[str, np.ndarray]):
        r = self.retargeter = retargeter
        self.fps = fps
        self.ratio = r.scale_ratio(sample)
        self.sweeps = r.options.high_rate_sweeps if fps >= 60 else r.options.sweeps
        self.q = r.embodiment.standing_pose.copy()
        self.q_previous = self.q.copy()
        self.anchors: dict[str, np.ndarray] = {}
        self.height_offset = 0.0
        self.count = 0

    def __deepcopy__(self, memo: dict) -> "RetargetStream":
        """A copy of the stream's own state that shares the retargeter (its
        programs are scratch space, rebuilt by nothing): how Drake copies a
        stream held as abstract state."""
        other = copy.copy(self)
        other.q, other.q_previous = self.q.copy(), self.q_previous.copy()
        other.anchors = {side: anchor.copy() for side, anchor in self.anchors.items()}
        return other

    def push(
        self, src: dict[str, np.ndarray], src_frames: dict[str, np.ndarray] | None = None, planted=None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Joint positions, root rotation and root position for one source frame.

        `src` maps landmarks to (1, 3) positions; `planted` maps a side to
        whether its foot is in contact (none: no foot locking this frame).
        """
        r, q = self.retargeter, self.q
        src_frames = source_frames(src) if src_frames is None else src_frames
        base, rotations, positions = r.root_path(src, src_frames, self.ratio)
        if base is not None:
            q[r.base] = base[0]
        root_rotation, root_position = rotations[0], positions[0].copy()
        root_position[2] += self.height_offset
        sweeps = r.options.first_frame_sweeps if self.count == 0 else self.sweeps
        r._solve_parts(q, self.q_previous, root_rotation, root_position, 0, src, src_frames, sweeps)
        if r.legged and planted is not None:
            root_position, self.height_offset = r._feet(
                q, root_rotation, root_position, planted, self.anchors, self.height_offset
            )
        np.clip(q, r.embodiment.position_lower, r.embodiment.position_upper, out=q)
        self.q_previous = q.copy()
        self.count += 1
        return q.copy(), root_rotation, root_position


def whole_finger_points(src: set[str], robot: set[str], side: str, finger: str) -> tuple[str, str, str, str] | None:
    """(source base, source tip, robot base, robot tip) of a whole finger, for
    a capture with only a finger's tip (CMU's hands carry one chain for the
    four fingers, from the knuckles, and one for the thumb, from the wrist):
    a finger without a tip of its own follows the index finger's; the
    robot's finger runs from its own base, the thumb from the wrist."""
    tip = f"{side}_{finger}_4"
    source_tip = tip if tip in src else (f"{side}_index_4" if finger != "thumb" else None)
    if finger == "thumb":
        source_base = base = f"{side}_wrist"
    else:
        source_base, base = f"{side}_hand", f"{side}_{finger}_1"
    if source_tip not in src or source_base not in src or not {base, tip} <= robot:
        return None
    return source_base, source_tip, base, tip


def foot_contacts_of(clip: MotionClip | None, frames_count: int) -> dict[str, np.ndarray]:
    """A clip's recorded foot contacts, if it has them for both feet."""
    if clip is None or clip.contacts is None or clip.num_frames != frames_count:
        return {}
    names = {f"{side}_foot": side for side in SIDES}
    if not set(names) <= set(clip.contact_names):
        return {}
    return {side: clip.contact(name).astype(bool) for name, side in names.items()}


def _landmarks_of_embodiment_clip(clip: MotionClip) -> dict[str, np.ndarray]:
    """Landmarks of a UDH clip (the method retargets human -> UDH -> robot)."""
    from hotu_drake import embodiment
    from hotu_drake.motion.udh_skeleton import udh_landmarks

    if clip.embodiment != "udh":
        raise ValueError(f"can retarget from a human or UDH clip, not from {clip.embodiment!r}")
    hands = "full" if any(n.endswith("_index_0") for n in clip.joint_names) else "none"
    return udh_landmarks(embodiment.load("udh", hands), clip)
