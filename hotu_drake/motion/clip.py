"""`MotionClip`: one motion in memory, one `.npz` format on disk.

A clip is a trajectory sampled at `fps` of an embodiment (the UDH, a robot,
or `"human"` for a demonstration before retargeting): root pose and twist,
joint positions and velocities, key-body positions, and optionally object
poses and binary contacts. Human clips carry no joints (n = 0); their
landmarks are key bodies.

On disk (`np.savez`, format version 1):

| key | shape / type | meaning |
|---|---|---|
| format_version | int | 1 |
| embodiment, source | str | embodiment name; where the motion came from |
| fps | float | frames per second |
| joint_names | (n,) str | joint order of the arrays below |
| joint_positions, joint_velocities | (T, n) | rad or m; rad/s or m/s |
| root_position | (T, 3) | world, metres |
| root_quaternion | (T, 4) | world, w x y z |
| root_linear_velocity | (T, 3) | world frame |
| root_angular_velocity | (T, 3) | world frame |
| key_body_names | (k,) str | |
| key_body_positions | (T, k, 3) | world |
| part_index | str (JSON) | functional part -> joint names |
| object_names | (m,) str | optional objects (box, drill, ...) |
| object_poses | (T, m, 7) | x y z, w x y z |
| contact_names | (c,) str | e.g. left_foot, right_hand_box |
| contacts | (T, c) bool | binary contact per frame |
"""

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hotu_drake.errors import InputError
from hotu_drake.io import atomic_output

FORMAT_VERSION = 1
_ARRAYS = (
    "joint_positions",
    "joint_velocities",
    "root_position",
    "root_quaternion",
    "root_linear_velocity",
    "root_angular_velocity",
    "key_body_positions",
)
_REQUIRED = ("format_version", "embodiment", "source", "fps", "joint_names", "key_body_names", *_ARRAYS)


class ClipFormatError(InputError):
    """A clip file or array that does not follow the format."""


def _scalar(arrays: dict, key: str, path: Path, kind: type):
    """A 0-d entry of a clip file as `kind` (str, int or float), checked."""
    value = arrays[key]
    ok = value.shape == () and (
        value.dtype.kind in "US" if kind is str else value.dtype.kind in ("iu" if kind is int else "iuf")
    )
    if not ok:
        raise ClipFormatError(f"{path}: {key} must be a single {kind.__name__}, not {value.dtype} {value.shape}")
    return kind(value.item() if kind is not str else str(value))


def _names(arrays: dict, key: str, path: Path) -> list[str]:
    value = arrays.get(key, np.zeros(0, dtype=str))
    if value.ndim != 1 or (value.size and value.dtype.kind not in "US"):
        raise ClipFormatError(f"{path}: {key} must be a list of names, not {value.dtype} {value.shape}")
    names = [str(s) for s in value]
    if len(set(names)) != len(names):
        raise ClipFormatError(f"{path}: {key} repeats a name")
    return names


def _numbers(arrays: dict, key: str, path: Path) -> np.ndarray:
    value = arrays[key]
    if value.dtype.kind not in "iuf":
        raise ClipFormatError(f"{path}: {key} must hold numbers, not {value.dtype}")
    return value.astype(np.float64, copy=False)


def _flags(arrays: dict, key: str, path: Path) -> np.ndarray:
    value = arrays[key]
    if value.dtype.kind not in "biu" or (value.size and not np.isin(value, (0, 1)).all()):
        raise ClipFormatError(f"{path}: {key} must hold true/false flags")
    return value.astype(bool, copy=False)


def lifts(down: np.ndarray) -> list[tuple[int, int]]:
    """The (start, stop) frames of each run of `down` (T,) bools that is
    False: a foot's lifts, or, of all feet together, the frames with none
    down (a run to the clip's end stops at T)."""
    out, start = [], None
    for frame, flag in enumerate([*down, True]):
        if not flag and start is None:
            start = frame
        elif flag and start is not None:
            out.append((start, frame))
            start = None
    return out


@dataclass
class MotionClip:
    """A motion of one embodiment, sampled at `fps`."""

    embodiment: str
    source: str
    fps: float
    joint_names: list[str]
    joint_positions: np.ndarray
    joint_velocities: np.ndarray
    root_position: np.ndarray
    root_quaternion: np.ndarray
    root_linear_velocity: np.ndarray
    root_angular_velocity: np.ndarray
    key_body_names: list[str]
    key_body_positions: np.ndarray
    part_index: dict[str, list[str]] = field(default_factory=dict)
    object_names: list[str] = field(default_factory=list)
    object_poses: np.ndarray | None = None
    contact_names: list[str] = field(default_factory=list)
    contacts: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.validate()

    @classmethod
    def from_positions(
        cls,
        embodiment: str,
        source: str,
        fps: float,
        joint_names: list[str],
        joint_positions: np.ndarray,
        root_position: np.ndarray,
        root_quaternion: np.ndarray,
        key_body_names: list[str] | None = None,
        key_body_positions: np.ndarray | None = None,
        **optional,
    ) -> "MotionClip":
        """A clip whose velocities are the finite differences of its positions
        (the root's quaternions made sign-continuous first). `optional` takes
        `part_index`, `object_names`, `object_poses`, `contact_names`, `contacts`."""
        from hotu_drake.rotations import angular_velocity, finite_difference, make_continuous

        joint_positions = np.asarray(joint_positions, dtype=float)
        root_position = np.asarray(root_position, dtype=float)
        quaternion = make_continuous(root_quaternion)
        frames = len(root_position)
        return cls(
            embodiment=embodiment,
            source=source,
            fps=float(fps),
            joint_names=list(joint_names),
            joint_positions=joint_positions,
            joint_velocities=finite_difference(joint_positions, fps),
            root_position=root_position,
            root_quaternion=quaternion,
            root_linear_velocity=finite_difference(root_position, fps),
            root_angular_velocity=angular_velocity(quaternion, fps),
            key_body_names=list(key_body_names or []),
            key_body_positions=np.zeros((frames, 0, 3)) if key_body_positions is None else key_body_positions,
            **optional,
        )

    @property
    def num_frames(self) -> int:
        return int(self.root_position.shape[0])

    @property
    def duration(self) -> float:
        return (self.num_frames - 1) / self.fps

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.num_frames) / self.fps

    def _index(self, names: list[str], name: str, what: str) -> int:
        if name not in names:
            shown = ", ".join(names[:8]) + (" ..." if len(names) > 8 else "")
            raise InputError(f"no {what} named {name!r} (it has {shown or 'none'})", self.source, what)
        return names.index(name)

    def joint(self, name: str) -> np.ndarray:
        """The trajectory of one joint."""
        return self.joint_positions[:, self._index(self.joint_names, name, "joint")]

    def key_body(self, name: str) -> np.ndarray:
        """The (T, 3) trajectory of one key body."""
        return self.key_body_positions[:, self._index(self.key_body_names, name, "key body")]

    def contact(self, name: str) -> np.ndarray:
        if self.contacts is None:
            raise InputError(f"no contacts (asked for {name!r})", self.source, "contact")
        return self.contacts[:, self._index(self.contact_names, name, "contact")]

    def object_pose(self, name: str) -> np.ndarray:
        if self.object_poses is None:
            raise InputError(f"no objects (asked for {name!r})", self.source, "object")
        return self.object_poses[:, self._index(self.object_names, name, "object")]

    def validate(self, where: str = "clip") -> None:
        """Raise `ClipFormatError` on wrong shapes, NaNs or zero frames."""
        if not np.isfinite(self.fps) or self.fps <= 0:
            raise ClipFormatError(f"{where}: fps must be a positive number")
        counts = [np.shape(getattr(self, name))[0] for name in _ARRAYS if np.ndim(getattr(self, name)) >= 1]
        t = max(set(counts), key=counts.count) if counts else 0  # the frame count most arrays agree on
        if t <= 0:
            raise ClipFormatError(f"{where}: has zero frames")
        n, k = len(self.joint_names), len(self.key_body_names)
        shapes = {
            "joint_positions": (t, n),
            "joint_velocities": (t, n),
            "root_position": (t, 3),
            "root_quaternion": (t, 4),
            "root_linear_velocity": (t, 3),
            "root_angular_velocity": (t, 3),
            "key_body_positions": (t, k, 3),
        }
        if self.object_names or self.object_poses is not None:
            shapes["object_poses"] = (t, len(self.object_names), 7)
        if self.contact_names or self.contacts is not None:
            shapes["contacts"] = (t, len(self.contact_names))
        for name, shape in shapes.items():
            value = getattr(self, name)
            if value is None or np.shape(value) != shape:
                raise ClipFormatError(f"{where}: {name} has shape {np.shape(value)}, expected {shape}")
            if name != "contacts" and not np.all(np.isfinite(value)):
                raise ClipFormatError(f"{where}: {name} contains NaN or infinite values")
        norms = np.linalg.norm(self.root_quaternion, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-3):
            raise ClipFormatError(f"{where}: root_quaternion rows are not unit quaternions")
        for part, joints in self.part_index.items():
            unknown = set(joints) - set(self.joint_names)
            if unknown:
                raise ClipFormatError(f"{where}: part {part} names unknown joints {sorted(unknown)[:3]}")

    def slice(self, start: int, stop: int) -> "MotionClip":
        """Frames [start, stop) as a new clip (`InputError` for an empty or outside range)."""
        if not (isinstance(start, int) and isinstance(stop, int) and 0 <= start < stop <= self.num_frames):
            raise InputError(f"frames [{start}, {stop}) are not a range of its {self.num_frames}", self.source, "slice")
        return self._frames(np.s_[start:stop])

    def held_first(self, seconds: float) -> "MotionClip":
        """The clip with its first frame held at rest for `seconds` (whole
        frames, rounded) before it: time to get ready before it moves."""
        if not np.isfinite(seconds):
            raise InputError(f"a lead-in of {seconds} s is no time", self.source, "held_first")
        held = int(round(seconds * self.fps))
        if held <= 0:
            return self
        clip = self._frames(np.r_[np.zeros(held, int), np.arange(self.num_frames)])
        for velocities in (clip.joint_velocities, clip.root_linear_velocity, clip.root_angular_velocity):
            velocities[:held] = 0.0
        return clip

    def _frames(self, index) -> "MotionClip":
        """The clip's frames at `index` (a slice or an array of frames) as a new clip."""
        return MotionClip(
            embodiment=self.embodiment,
            source=self.source,
            fps=self.fps,
            joint_names=list(self.joint_names),
            joint_positions=self.joint_positions[index],
            joint_velocities=self.joint_velocities[index],
            root_position=self.root_position[index],
            root_quaternion=self.root_quaternion[index],
            root_linear_velocity=self.root_linear_velocity[index],
            root_angular_velocity=self.root_angular_velocity[index],
            key_body_names=list(self.key_body_names),
            key_body_positions=self.key_body_positions[index],
            part_index=dict(self.part_index),
            object_names=list(self.object_names),
            object_poses=None if self.object_poses is None else self.object_poses[index],
            contact_names=list(self.contact_names),
            contacts=None if self.contacts is None else self.contacts[index],
        )

    def save(self, path: str | Path, extra: dict[str, np.ndarray] | None = None) -> Path:
        """Write the clip as `.npz`, atomically (no partial file on failure);
        `extra` arrays (per frame, say a performance's actions) are written
        beside the clip's own, which `load` leaves aside."""
        path = Path(path)
        arrays = {
            "format_version": np.array(FORMAT_VERSION),
            "embodiment": np.array(self.embodiment),
            "source": np.array(self.source),
            "fps": np.array(float(self.fps)),
            "joint_names": np.array(self.joint_names, dtype=str),
            "joint_positions": np.asarray(self.joint_positions, dtype=np.float64),
            "joint_velocities": np.asarray(self.joint_velocities, dtype=np.float64),
            "root_position": np.asarray(self.root_position, dtype=np.float64),
            "root_quaternion": np.asarray(self.root_quaternion, dtype=np.float64),
            "root_linear_velocity": np.asarray(self.root_linear_velocity, dtype=np.float64),
            "root_angular_velocity": np.asarray(self.root_angular_velocity, dtype=np.float64),
            "key_body_names": np.array(self.key_body_names, dtype=str),
            "key_body_positions": np.asarray(self.key_body_positions, dtype=np.float64),
            "part_index": np.array(json.dumps(self.part_index, sort_keys=True)),
            "object_names": np.array(self.object_names, dtype=str),
            "object_poses": np.zeros((self.num_frames, 0, 7))
            if self.object_poses is None
            else np.asarray(self.object_poses, dtype=np.float64),
            "contact_names": np.array(self.contact_names, dtype=str),
            "contacts": np.zeros((self.num_frames, 0), dtype=bool)
            if self.contacts is None
            else np.asarray(self.contacts, dtype=bool),
        }
        clash = set(extra or {}) & set(arrays)
        if clash:
            raise ValueError(f"extra arrays may not be named as the clip's own: {', '.join(sorted(clash))}")
        with atomic_output(path, suffix=".npz") as tmp:
            np.savez(tmp, **arrays, **(extra or {}))
        return path

    @staticmethod
    def load(path: str | Path) -> "MotionClip":
        """Read a clip; a file that is not a valid clip raises `ClipFormatError`."""
        path = Path(path)
        if not path.is_file():
            raise ClipFormatError(f"{path}: no such file")
        try:
            with open(path, "rb") as f, np.load(f, allow_pickle=False) as data:  # the file closed on every path
                arrays = {key: data[key] for key in data.files}
        except (OSError, ValueError, zipfile.BadZipFile, EOFError) as error:
            raise ClipFormatError(f"{path}: not a readable .npz clip ({type(error).__name__})") from None
        missing = [key for key in _REQUIRED if key not in arrays]
        if missing:
            raise ClipFormatError(f"{path}: not a hotu_drake clip (missing {', '.join(missing[:3])})")
        version = _scalar(arrays, "format_version", path, int)
        if version != FORMAT_VERSION:
            raise ClipFormatError(f"{path}: clip format version {version} is not supported (expected 1)")
        try:
            part_index = json.loads(_scalar(arrays, "part_index", path, str) if "part_index" in arrays else "{}")
        except json.JSONDecodeError:
            raise ClipFormatError(f"{path}: part_index is not valid JSON") from None
        if not isinstance(part_index, dict) or not all(
            isinstance(v, list) and all(isinstance(j, str) for j in v) for v in part_index.values()
        ):
            raise ClipFormatError(f"{path}: part_index must map parts to lists of joint names")
        object_names = _names(arrays, "object_names", path)
        contact_names = _names(arrays, "contact_names", path)
        clip = MotionClip.__new__(MotionClip)
        clip.__dict__.update(
            embodiment=_scalar(arrays, "embodiment", path, str),
            source=_scalar(arrays, "source", path, str),
            fps=_scalar(arrays, "fps", path, float),
            joint_names=_names(arrays, "joint_names", path),
            key_body_names=_names(arrays, "key_body_names", path),
            part_index=part_index,
            object_names=object_names,
            object_poses=_numbers(arrays, "object_poses", path) if object_names else None,
            contact_names=contact_names,
            contacts=_flags(arrays, "contacts", path) if contact_names else None,
            **{key: _numbers(arrays, key, path) for key in _ARRAYS},
        )
        clip.validate(str(path))
        return clip
