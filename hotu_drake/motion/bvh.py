"""BVH motion capture files: read any skeleton into a human clip, write UDH clips.

`read_bvh` parses any BVH hierarchy (any channel count and order per joint,
position channels on any joint), runs forward kinematics over all frames at
once, finds the human landmarks through a skeleton map (built-in naming
families or a user YAML map, see `skeleton_maps`), and converts to metres
and z up, detecting the units from the skeleton's size and the up axis from
where the head is. `write_udh_bvh` writes a UDH clip as BVH (one BVH joint
per UDH body, one zero-channel site joint per landmark) so that reading it
back gives the UDH's landmarks.

BVH conventions used here: every joint frame is parallel to the world in the
rest pose; a joint's world transform is
parent * T(offset + position channels) * R_ch1 * R_ch2 * R_ch3, with the
rotation channels applied in the order listed, angles in degrees.
"""

from __future__ import annotations

import io
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from hotu_drake.io import write_text_atomic
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.human import check_coverage, human_clip
from hotu_drake.motion.skeleton_maps import JointNames, apply_user_map, best_family, load_user_map
from hotu_drake.rotations import euler_xyz, quat_to_matrix, signed_axis, up_from_body, up_rotation

if TYPE_CHECKING:
    from hotu_drake.embodiment import Embodiment

log = logging.getLogger("hotu_drake.input")

# Metres per file unit. CMU's ASF-derived files use 1 unit = 1/0.45 inch = 0.056444 m.
UNIT_SCALES: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "cmu": 0.056444}
_AXES = "xyz"
_CHANNELS = {f"{a}{kind}": (i, kind) for i, a in enumerate(_AXES) for kind in ("position", "rotation")}
# z-up world (x, y, z) -> Y-up file axes (y, z, x), for writing: a proper rotation.
_Z_UP_TO_Y_UP = [1, 2, 0]
# Typical standing height (m) used to choose units: the candidate nearest in log scale wins.
_TYPICAL_HEIGHT = 1.7
# Bounds on what a file may ask of the parser (a human skeleton has a few hundred joints at most).
MAX_DEPTH, MAX_JOINTS = 200, 2000
FRAME_TIME = (1e-4, 10.0)  # s: 10 kHz to 0.1 Hz


@dataclass
class BvhFile:
    """A parsed BVH file: the joint tree, channels and the raw motion table.

    Joints are in file order (parents before children). `channels[j]` lists
    (axis 0-2, "position" or "rotation") in file order; `columns[j]` is the
    first motion column of joint j. `end_sites[j]` is the End Site offset
    (NaN where the joint has none).
    """

    path: str
    names: list[str]
    parents: np.ndarray
    offsets: np.ndarray
    channels: list[list[tuple[int, str]]]
    columns: np.ndarray
    end_sites: np.ndarray
    frame_time: float
    motion: np.ndarray

    @property
    def num_frames(self) -> int:
        return int(self.motion.shape[0])

    @property
    def has_end_site(self) -> list[bool]:
        return [bool(np.all(np.isfinite(e))) for e in self.end_sites]

    @property
    def fps(self) -> float:
        """Frames per second, rounded to an integer when 1 / frame time is within 0.01 of one."""
        fps = 1.0 / self.frame_time
        return float(round(fps)) if abs(fps - round(fps)) < 0.01 else fps


# --- parsing ----------------------------------------------------------------------------------------------


class _Tokens:
    """Hierarchy tokens with their line numbers, read one at a time."""

    def __init__(self, where: str, lines: list[str]) -> None:
        self.where = where
        self.items = [
            (token, number)
            for number, line in enumerate(lines, start=1)
            for token in line.replace("{", " { ").replace("}", " } ").split()
        ]
        self.i = 0
        self.last_line = len(lines)

    def error(self, message: str, line: int | None = None) -> ClipFormatError:
        line = line if line is not None else (self.items[self.i][1] if self.i < len(self.items) else self.last_line)
        return ClipFormatError(f"{self.where}: line {line}: {message}")

    def peek(self) -> str | None:
        return self.items[self.i][0] if self.i < len(self.items) else None

    def next(self, what: str) -> tuple[str, int]:
        if self.i >= len(self.items):
            raise ClipFormatError(f"{self.where}: file ends inside HIERARCHY (truncated?) while reading {what}")
        self.i += 1
        return self.items[self.i - 1]

    def expect(self, word: str) -> None:
        token, line = self.next(repr(word))
        if token != word:
            raise self.error(f"expected {word!r}, found {token!r}", line)

    def number(self, what: str) -> float:
        token, line = self.next(what)
        try:
            value = float(token)
        except ValueError:
            raise self.error(f"{what}: {token!r} is not a number", line) from None
        if not math.isfinite(value):
            raise self.error(f"{what} is NaN or infinite", line)
        return value


@dataclass
class _Joint:
    name: str
    parent: int
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    channels: tuple[tuple[int, str], ...] = ()
    end_site: tuple[float, float, float] | None = None


def _parse_joint(tokens: _Tokens, parent: int, joints: list[_Joint], depth: int = 0) -> None:
    """Parse one ROOT/JOINT block (its keyword already read) and its children."""
    if depth > MAX_DEPTH or len(joints) >= MAX_JOINTS:
        what = f"nested more than {MAX_DEPTH} deep" if depth > MAX_DEPTH else f"more than {MAX_JOINTS} joints"
        raise tokens.error(f"the hierarchy has {what}: not a skeleton")
    name, line = tokens.next("a joint name")
    if name in ("{", "}"):
        raise tokens.error("a joint has no name", line)
    joint = _Joint(name, parent)
    index = len(joints)
    joints.append(joint)
    tokens.expect("{")
    has_offset = False
    while True:
        token, line = tokens.next(f"joint {name}")
        if token == "}":
            break
        if token == "OFFSET":
            joint.offset = tuple(tokens.number(f"OFFSET of {name}") for _ in range(3))
            has_offset = True
        elif token == "CHANNELS":
            joint.channels = _parse_channels(tokens, name)
        elif token == "JOINT":
            _parse_joint(tokens, index, joints, depth + 1)
        elif token == "End":
            joint.end_site = _parse_end_site(tokens, name)
        else:
            raise tokens.error(f"unexpected {token!r} in joint {name}", line)
    if not has_offset:
        raise tokens.error(f"joint {name} has no OFFSET", line)


def _parse_channels(tokens: _Tokens, name: str) -> tuple[tuple[int, str], ...]:
    count, line = tokens.next(f"CHANNELS of {name}")
    if not count.isdigit():
        raise tokens.error(f"CHANNELS of {name}: {count!r} is not a channel count", line)
    channels = []
    for _ in range(int(count)):
        token, line = tokens.next(f"CHANNELS of {name}")
        if token.lower() not in _CHANNELS:
            raise tokens.error(f"unknown channel {token!r} in joint {name}", line)
        channels.append(_CHANNELS[token.lower()])
    return tuple(channels)


def _parse_end_site(tokens: _Tokens, name: str) -> tuple[float, float, float]:
    tokens.expect("Site")
    while tokens.peek() not in (None, "{"):  # some exporters name their End Sites
        tokens.next("End Site")
    tokens.expect("{")
    tokens.expect("OFFSET")
    offset = tuple(tokens.number(f"End Site OFFSET of {name}") for _ in range(3))
    tokens.expect("}")
    return offset


def _parse_hierarchy(where: str, lines: list[str]) -> list[_Joint]:
    tokens = _Tokens(where, lines)
    if tokens.peek() != "HIERARCHY":
        raise ClipFormatError(f"{where}: not a BVH file (it does not start with HIERARCHY)")
    tokens.next("HIERARCHY")
    joints: list[_Joint] = []
    while tokens.peek() == "ROOT":
        tokens.next("ROOT")
        _parse_joint(tokens, -1, joints)
    if not joints:
        raise tokens.error("expected ROOT after HIERARCHY")
    if tokens.peek() is not None:
        raise tokens.error(f"unexpected {tokens.peek()!r} after the hierarchy (expected MOTION)")
    return joints


def _header_value(where: str, lines: list[str], index: int, key: str) -> tuple[str, int]:
    """The value of a `Frames:` / `Frame Time:` line at or after `index`."""
    while index < len(lines) and not lines[index].strip():
        index += 1
    if index >= len(lines):
        raise ClipFormatError(f"{where}: file ends before the MOTION section's {key!r} line (truncated?)")
    label, _, value = lines[index].partition(":")
    if " ".join(label.split()).lower() != key.lower() or not value.strip():
        raise ClipFormatError(f"{where}: line {index + 1}: expected '{key}: <value>', found {lines[index].strip()!r}")
    return value.strip(), index + 1


def _parse_motion(where: str, lines: list[str], start: int, num_channels: int) -> tuple[float, np.ndarray]:
    """Frame time and the (T, C) motion table from the lines after MOTION."""
    frames_text, index = _header_value(where, lines, start, "Frames")
    if not frames_text.isdigit():
        raise ClipFormatError(f"{where}: line {index}: Frames: {frames_text!r} is not a frame count")
    frames = int(frames_text)
    time_text, index = _header_value(where, lines, index, "Frame Time")
    try:
        frame_time = float(time_text)
    except ValueError:
        raise ClipFormatError(f"{where}: line {index}: Frame Time: {time_text!r} is not a number") from None
    if not (math.isfinite(frame_time) and FRAME_TIME[0] <= frame_time <= FRAME_TIME[1]):
        raise ClipFormatError(
            f"{where}: line {index}: Frame Time {time_text} s is not a plausible frame time "
            f"({FRAME_TIME[0]:g} to {FRAME_TIME[1]:g} s, i.e. {1 / FRAME_TIME[1]:g} to {1 / FRAME_TIME[0]:g} fps)"
        )
    if frames == 0:
        raise ClipFormatError(f"{where}: has zero frames")
    rows = [(number, line) for number, line in enumerate(lines[index:], start=index + 1) if line.strip()]
    if len(rows) < frames:
        raise ClipFormatError(f"{where}: truncated: Frames says {frames} but the file has {len(rows)} frame lines")
    if len(rows) > frames:
        raise ClipFormatError(f"{where}: line {rows[frames][0]}: more frame lines than Frames says ({frames})")
    split = [line.split() for _, line in rows]
    for (number, _), values in zip(rows, split):
        if len(values) != num_channels:
            raise ClipFormatError(
                f"{where}: line {number}: expected {num_channels} values (one per channel), found {len(values)}"
            )
    try:
        motion = np.array([v for values in split for v in values], dtype=float).reshape(frames, num_channels)
    except ValueError:
        raise _bad_number(where, rows, split) from None
    finite = np.all(np.isfinite(motion), axis=1)
    if not np.all(finite):
        raise ClipFormatError(f"{where}: line {rows[int(np.argmin(finite))][0]}: NaN or infinite value")
    return frame_time, motion


def _bad_number(where: str, rows: list[tuple[int, str]], split: list[list[str]]) -> ClipFormatError:
    for (number, _), values in zip(rows, split):
        for value in values:
            try:
                float(value)
            except ValueError:
                return ClipFormatError(f"{where}: line {number}: {value!r} is not a number")
    return ClipFormatError(f"{where}: malformed motion data")


def parse_bvh(path: str | Path) -> BvhFile:
    """Parse a BVH file; any problem raises `ClipFormatError` starting with the path."""
    where = str(path)
    path = Path(path)
    if not path.exists():
        raise ClipFormatError(f"{where}: no such file")
    if not path.is_file():
        raise ClipFormatError(f"{where}: not a file")
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as error:
        raise ClipFormatError(f"{where}: cannot read ({error.strerror or error})") from None
    return parse_bvh_text(text, where)


def parse_bvh_text(text: str, where: str = "<bvh>") -> BvhFile:
    """Parse BVH text; `where` names the source in error messages."""
    lines = text.splitlines()
    motion_at = next((i for i, line in enumerate(lines) if line.split()[:1] == ["MOTION"]), None)
    if not any(line.strip() for line in lines):
        raise ClipFormatError(f"{where}: empty file")
    joints = _parse_hierarchy(where, lines if motion_at is None else lines[:motion_at])
    if motion_at is None:
        raise ClipFormatError(f"{where}: no MOTION section (truncated?)")
    counts = np.array([len(j.channels) for j in joints], dtype=int)
    frame_time, motion = _parse_motion(where, lines, motion_at + 1, int(counts.sum()))
    nan3 = (math.nan, math.nan, math.nan)
    return BvhFile(
        path=where,
        names=[j.name for j in joints],
        parents=np.array([j.parent for j in joints], dtype=int),
        offsets=np.array([j.offset for j in joints], dtype=float),
        channels=[list(j.channels) for j in joints],
        columns=np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int),
        end_sites=np.array([j.end_site if j.end_site is not None else nan3 for j in joints], dtype=float),
        frame_time=frame_time,
        motion=motion,
    )


# --- forward kinematics ------------------------------------------------------------------------------------


def axis_rotations(axis: int, angles: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations about coordinate axis 0, 1 or 2 by `angles` (T,) radians."""
    c, s = np.cos(angles), np.sin(angles)
    out = np.zeros((len(angles), 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[:, axis, axis] = 1.0
    out[:, i, i] = c
    out[:, j, j] = c
    out[:, i, j] = -s
    out[:, j, i] = s
    return out


def forward_kinematics(bvh: BvhFile) -> tuple[np.ndarray, np.ndarray]:
    """World rotations (T, J, 3, 3) and positions (T, J, 3) of every joint, in file units and axes."""
    frames, count = bvh.num_frames, len(bvh.names)
    rotations = np.empty((frames, count, 3, 3))
    positions = np.empty((frames, count, 3))
    for j in range(count):
        translation = np.broadcast_to(bvh.offsets[j], (frames, 3)).copy()
        local = None
        for k, (axis, kind) in enumerate(bvh.channels[j]):
            values = bvh.motion[:, bvh.columns[j] + k]
            if kind == "position":
                translation[:, axis] += values
            else:
                r = axis_rotations(axis, np.radians(values))
                local = r if local is None else local @ r
        parent = bvh.parents[j]
        if parent < 0:
            positions[:, j] = translation
            rotations[:, j] = np.eye(3) if local is None else local
        else:
            parent_rotation = rotations[:, parent]
            positions[:, j] = positions[:, parent] + np.einsum("tab,tb->ta", parent_rotation, translation)
            rotations[:, j] = parent_rotation if local is None else parent_rotation @ local
    return rotations, positions


def _target_positions(
    bvh: BvhFile, rotations: np.ndarray, positions: np.ndarray, target: tuple[int, bool]
) -> np.ndarray:
    """(T, 3) positions of a joint origin or its End Site."""
    joint, end = target
    if not end:
        return positions[:, joint]
    return positions[:, joint] + rotations[:, joint] @ bvh.end_sites[joint]


# --- units and up axis ------------------------------------------------------------------------------------


def _chain_length(bvh: BvhFile, a: tuple[int, bool], b: tuple[int, bool]) -> float:
    """Bone-length sum along the tree between two targets (independent of pose)."""

    def ancestors(target: tuple[int, bool]) -> tuple[list[int], float]:
        joint, end = target
        chain = []
        while joint >= 0:
            chain.append(joint)
            joint = int(bvh.parents[joint])
        return chain, float(np.linalg.norm(bvh.end_sites[target[0]])) if end else 0.0

    chain_a, extra_a = ancestors(a)
    chain_b, extra_b = ancestors(b)
    common = set(chain_a) & set(chain_b)
    lengths = np.linalg.norm(bvh.offsets, axis=1)
    return extra_a + extra_b + float(sum(lengths[j] for j in chain_a + chain_b if j not in common))


def skeleton_height(bvh: BvhFile, landmarks: Mapping[str, tuple[int, bool]]) -> float:
    """Standing height in file units: the bone chain from head top (or head)
    to each ankle, averaged; without legs, the arm span (about a person's
    height) from wrist to wrist."""
    if "left_ankle" not in landmarks:
        return _chain_length(bvh, landmarks["left_wrist"], landmarks["right_wrist"])
    top = landmarks.get("head_top", landmarks["head"])
    return float(np.mean([_chain_length(bvh, top, landmarks[f"{side}_ankle"]) for side in ("left", "right")]))


def detect_units(height: float) -> str:
    """The unit ("m", "cm", "mm", "in" or "cmu") that makes `height` file units most like a human.

    Boundaries (file units): metres below about 7, CMU units up to about 45,
    inches up to about 107, centimetres up to about 540, then millimetres.
    """
    if not (math.isfinite(height) and height > 0):
        raise ValueError("the skeleton has no size")
    return min(UNIT_SCALES, key=lambda unit: abs(math.log(height * UNIT_SCALES[unit] / _TYPICAL_HEIGHT)))


def unit_scale(units: str | float) -> float:
    """Metres per file unit for a unit name or a number."""
    if isinstance(units, str):
        if units.lower() not in UNIT_SCALES:
            raise ValueError(f"unknown units {units!r}; choose from {', '.join(UNIT_SCALES)} or a number")
        return UNIT_SCALES[units.lower()]
    scale = float(units)
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"units must be a positive scale to metres, got {units!r}")
    return scale


# --- reading ----------------------------------------------------------------------------------------------


def read_bvh(
    path: str | Path,
    *,
    units: str | float | None = None,
    up: str | None = None,
    skeleton_map: str | Path | Mapping | None = None,
) -> MotionClip:
    """Read a BVH file as a human clip (landmarks in metres, world z up).

    Args:
        path: the BVH file.
        units: "m", "cm", "mm", "in", "cmu" or metres per file unit; detected
            from the skeleton's height when None.
        up: the file's up axis, optionally signed ("y", "+z", "-x", ...);
            when None, the axis along which the head stands above the
            ankles (or the pelvis), else +y (said on the `hotu_drake.input`
            logger).
        skeleton_map: a YAML file or dict {landmark: joint or "Joint:end"}
            applied over the best built-in naming family.

    Raises:
        ClipFormatError: bad file, unknown skeleton, missing landmarks (a
            skeleton may cover part of the body, see `human.check_coverage`);
            the message starts with the path.
    """
    where = str(path)
    bvh = parse_bvh(path)
    joints = JointNames(bvh.names, bvh.has_end_site)
    family, landmarks = best_family(joints)
    if skeleton_map is not None:
        landmarks = apply_user_map(landmarks, load_user_map(skeleton_map), joints, where)
    elif family is None:
        raise ClipFormatError(f"{where}: unknown skeleton (no built-in map covers it; pass --skeleton-map)")
    check_coverage(landmarks, where)
    rotations, positions = forward_kinematics(bvh)
    points = {name: _target_positions(bvh, rotations, positions, t) for name, t in landmarks.items()}
    up = _choose_up(up, points, where)
    if units is None:
        height = skeleton_height(bvh, landmarks)
        try:
            units = detect_units(height)
        except ValueError:
            raise ClipFormatError(f"{where}: cannot detect units (the skeleton has no size); pass units") from None
        log.info("%s: units %s (a skeleton %.4g file units tall)", where, units, height)
    scale = unit_scale(units)
    rotation = up_rotation(up)
    metric = {name: scale * p @ rotation.T for name, p in points.items()}
    return human_clip(metric, bvh.fps, source=where)


def _choose_up(up: str | None, points: Mapping[str, np.ndarray], where: str) -> str:
    """The file's up axis: `up` if given, else where the head stands over the
    feet (or the pelvis), else +y, BVH's convention; said on the
    `hotu_drake.input` logger."""
    if up is not None:
        try:
            return signed_axis(up)
        except ValueError as error:
            raise ClipFormatError(f"{where}: up: {error}") from None
    base = [points[n] for n in ("left_ankle", "right_ankle") if n in points] or [points.get("pelvis", points["chest"])]
    found = up_from_body(points["head"], np.mean(base, axis=0))
    if found is None:
        log.warning("%s: up axis unclear from the data (the head is above the feet along no axis); +y assumed", where)
        return "+y"
    log.info("%s: up axis %s (the head stands above the feet along it)", where, found)
    return found


# --- writing ----------------------------------------------------------------------------------------------


@dataclass
class _Node:
    """One BVH joint of the written file."""

    name: str
    offset: np.ndarray  # world (z-up) metres
    parent: int
    channels: list[str]  # z-up axis letters of the rotation channels, e.g. ["x", "y", "z"]
    values: np.ndarray | None = None  # (T, len(channels)) degrees


def _axis_letter(axis) -> tuple[str, float] | None:
    """("x", +1.0) for an axis along +x, None for an oblique axis."""
    a = np.asarray(axis, dtype=float)
    k = int(np.argmax(np.abs(a)))
    if abs(abs(a[k]) - 1.0) > 1e-9:
        return None
    return _AXES[k], float(np.sign(a[k]))


def _joint_groups(spec, placements) -> list[list]:
    """UDH joints grouped into BVH joints: consecutive axes at one point through light links."""
    children: dict[str, list] = {}
    for joint in spec.joints:
        children.setdefault(joint.parent, []).append(joint)
    carries_offset = {link for link, offset in placements.values() if np.linalg.norm(offset) > 1e-12}

    def intermediate(link: str) -> bool:
        kids = children.get(link, [])
        return (
            link != spec.root.name
            and link not in carries_offset
            and len(kids) == 1
            and kids[0].kind == "revolute"
            and np.linalg.norm(kids[0].offset) < 1e-12
        )

    child_of = {joint.child: joint for joint in spec.joints}
    groups = []
    for joint in spec.joints:
        if joint.parent in child_of and intermediate(joint.parent):
            continue  # inside a group started earlier
        group = [joint]
        while intermediate(group[-1].child):
            group.append(children[group[-1].child][0])
        groups.append(group)
    return groups


def _axis_angle(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations about a unit `axis` by `angles` (Rodrigues)."""
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    c, s = np.cos(angles)[:, None, None], np.sin(angles)[:, None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


def _group_channels(group, q: np.ndarray, column: dict[str, int]) -> tuple[list[str], np.ndarray]:
    """Rotation channel letters (z-up axes) and (T, k) degrees reproducing the group's rotation."""
    if any(j.kind != "revolute" for j in group):
        raise ValueError(f"joint {group[0].name}: only revolute joints can be written to BVH")
    letters = [_axis_letter(j.axis) for j in group]
    if len(group) <= 3 and None not in letters and len({a for a, _ in letters}) == len(letters):
        values = np.stack([sign * q[:, column[j.name]] for j, (_, sign) in zip(group, letters)], axis=1)
        return [a for a, _ in letters], np.degrees(values)
    rotation = np.broadcast_to(np.eye(3), (len(q), 3, 3))
    for j in group:
        rotation = rotation @ _axis_angle(np.asarray(j.axis), q[:, column[j.name]])
    return ["x", "y", "z"], np.degrees(euler_xyz(rotation))


def _udh_nodes(clip: MotionClip, udh: Embodiment) -> list[_Node]:
    """The written hierarchy: root, one node per joint group, one site per landmark."""
    from hotu_drake.motion.udh_skeleton import landmark_placements

    spec = udh.spec
    unknown = [name for name in clip.joint_names if name not in spec.joint_names]
    if unknown:
        raise ValueError(f"clip joints {unknown[:3]} are not joints of {spec.name} (hands={spec.hands})")
    column = {name: i for i, name in enumerate(spec.joint_names)}
    q = np.zeros((clip.num_frames, len(column)))
    for i, name in enumerate(clip.joint_names):
        q[:, column[name]] = clip.joint_positions[:, i]
    placements = landmark_placements(udh)
    origin = {link.name: np.asarray(link.origin, dtype=float) for link in spec.links}
    root = spec.root.name
    root_rotation = np.degrees(euler_xyz(quat_to_matrix(clip.root_quaternion)))
    nodes = [_Node(root, np.zeros(3), -1, ["x", "y", "z"], root_rotation)]
    node_of = {root: 0}  # link -> node whose frame (or origin, for light links) it shares
    for group in _joint_groups(spec, placements):
        parent = node_of[group[0].parent]
        final = group[-1].child
        letters, values = _group_channels(group, q, column)
        nodes.append(_Node(final, origin[final] - origin[nodes[parent].name], parent, letters, values))
        for joint in group:
            node_of[joint.child] = len(nodes) - 1
    for landmark, (link, offset) in placements.items():
        parent = node_of[link]
        site_offset = origin[link] - origin[nodes[parent].name] + np.asarray(offset, dtype=float)
        nodes.append(_Node(f"{landmark}_site", site_offset, parent, []))
    return nodes


def _depth_first(nodes: list[_Node]) -> list[tuple[int, int]]:
    """(node, depth) in file order: each node followed by its subtree (BVH motion columns follow it)."""
    kids: dict[int, list[int]] = {}
    for i, node in enumerate(nodes):
        kids.setdefault(node.parent, []).append(i)
    order, stack = [], [(0, 0)]
    while stack:
        i, depth = stack.pop()
        order.append((i, depth))
        stack.extend((k, depth + 1) for k in reversed(kids.get(i, [])))
    return order


def _hierarchy_text(nodes: list[_Node], scale: float, order: list[int]) -> str:
    """The HIERARCHY section; offsets in file units and axes."""
    letter = {a: _AXES[order.index(i)].upper() for i, a in enumerate(_AXES)}
    walk = _depth_first(nodes)
    out = ["HIERARCHY"]
    for n, (i, depth) in enumerate(walk):
        tab, node = "\t" * depth, nodes[i]
        offset = node.offset[order] / scale
        channels = [f"{letter[a]}rotation" for a in node.channels]
        if node.parent < 0:
            channels = [f"{a.upper()}position" for a in _AXES] + channels
        out += [
            f"{tab}{'ROOT' if node.parent < 0 else 'JOINT'} {node.name}",
            f"{tab}{{",
            f"{tab}\tOFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}",
            f"{tab}\tCHANNELS {len(channels)} {' '.join(channels)}".rstrip(),
        ]
        next_depth = walk[n + 1][1] if n + 1 < len(walk) else 0
        if next_depth <= depth:  # a leaf: close it with an End Site, then close the finished joints
            out += [f"{tab}\tEnd Site", f"{tab}\t{{", f"{tab}\t\tOFFSET 0.000000 0.000000 0.000000", f"{tab}\t}}"]
            out += ["\t" * d + "}" for d in range(depth, next_depth - 1, -1)]
    return "\n".join(out) + "\n"


def write_udh_bvh(
    clip: MotionClip, udh: Embodiment, path: str | Path, *, up: str = "y", units: str | float = "cm"
) -> Path:
    """Write a UDH clip as BVH, atomically.

    One BVH joint per UDH body (a multi-axis UDH joint becomes one BVH joint
    with its rotation channels in chain order), the finger joints when the
    UDH has hands, and a zero-channel `<landmark>_site` joint per landmark so
    `read_bvh` gives back `udh_skeleton.udh_landmarks`.

    Args:
        clip: a clip of `udh` (joint_names a subset of the UDH's joints).
        udh: the `hotu_drake.embodiment.Embodiment` the clip was made for.
        path: the output file.
        up: "y" (the BVH habit) or "z".
        units: "m", "cm", "mm", "in", "cmu" or metres per file unit.
    """
    if clip.embodiment != udh.name:
        raise ValueError(f"the clip is of {clip.embodiment!r}, not {udh.name!r}")
    if up not in ("y", "z"):
        raise ValueError(f"up must be 'y' or 'z', not {up!r}")
    scale = unit_scale(units)
    order = _Z_UP_TO_Y_UP if up == "y" else [0, 1, 2]
    nodes = _udh_nodes(clip, udh)
    walk = [nodes[i].values for i, _ in _depth_first(nodes)]
    columns = [clip.root_position[:, order] / scale] + [values for values in walk if values is not None]
    table = io.StringIO()
    np.savetxt(table, np.concatenate(columns, axis=1), fmt="%.6f")
    text = (
        _hierarchy_text(nodes, scale, order)
        + f"MOTION\nFrames: {clip.num_frames}\nFrame Time: {1.0 / clip.fps:.9f}\n"
        + table.getvalue()
    )
    return write_text_atomic(path, text)
