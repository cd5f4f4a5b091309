"""OptiTrack Motive CSV exports of rigid bodies: the objects of human-object clips.

Motive writes a header row of key-value pairs ("Format Version", ...,
"Export Frame Rate", "Rotation Type", "Length Units", ...), then rows
labelled Type (Rigid Body, Rigid Body Marker, Marker, Bone, ...), Name and
ID, a group row (Rotation, Position, Mean Marker Error), a component row
(X Y Z W for quaternions, X Y Z for positions), and data rows starting
with the frame number and time. Motive's world is Y up with +Z forward and
quaternions are x y z w; `read_optitrack_csv` returns z-up poses
(x y z, w x y z) in metres, the world and the bodies' own axes both turned
by the rotation that takes Motive's (x, y, z) to (y, z, x): forward
becomes +x and up +z, so an upright object keeps an identity orientation.
"""

import csv
import dataclasses
import io
from pathlib import Path

import numpy as np

from hotu_drake.errors import check_number
from hotu_drake.io import atomic_output
from hotu_drake.motion.clip import ClipFormatError, MotionClip

# Rows of this matrix take a Y-up Motive vector (x, y, z) to z up: (z, x, y).
Y_UP_TO_Z_UP = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
LENGTH_UNITS = {
    "meters": 1.0,
    "metres": 1.0,
    "m": 1.0,
    "centimeters": 0.01,
    "cm": 0.01,
    "millimeters": 1e-3,
    "mm": 1e-3,
}
RIGID_BODY = "rigid body"
RATE_RANGE = (1.0, 10000.0)  # Hz
UNIT_TOLERANCE = 0.01  # how far a recorded quaternion's norm may be from 1
MAX_COORDINATE = 1e5  # in the file's length units: 100 m in millimetres, 100 km in metres
_ROTATION = ("X", "Y", "Z", "W")
_POSITION = ("X", "Y", "Z")


def read_optitrack_csv(
    path: str | Path, *, fps: float | None = None, up: str = "y"
) -> tuple[list[str], np.ndarray, float]:
    """Rigid-body poses from a Motive CSV export: (names, poses (T, m, 7), fps).

    Poses are x y z (metres) and w x y z, z up. Only "Rigid Body" columns are
    read; empty cells (occlusion) are interpolated (linear positions,
    normalised linear quaternions) and held at the ends; bodies never seen
    are dropped. `fps` overrides the file's Export Frame Rate; `up="z"` if
    Motive was set to Z up.
    """
    path = Path(path)
    rows = _rows(path)
    meta = _header(rows, path)
    group_row = _find_row(rows, lambda cells: {"rotation", "position"} & {c.strip().lower() for c in cells[1:]})
    if group_row is None:
        raise ClipFormatError(f"{path}: no Rotation/Position header row")
    type_row = _labelled(rows, group_row, "type") or _find_row(
        rows[:group_row], lambda cells: RIGID_BODY in {c.strip().lower() for c in cells}
    )
    if type_row is None:
        raise ClipFormatError(f"{path}: no Type row naming the columns' assets")
    name_row = _labelled(rows, group_row, "name") or type_row + 1
    columns = _rigid_body_columns(rows, type_row, name_row, group_row, path, meta)
    data = _data_rows(rows, group_row + 1, path)
    values = _numbers(data, columns, path)  # (T, m, 7): px py pz qx qy qz qw
    _check_rotations(values, list(columns), data, path)
    rate = _frame_rate(fps, meta, data, path)
    scale = LENGTH_UNITS.get(meta.get("length units", "meters").strip().lower())
    if scale is None:
        raise ClipFormatError(f"{path}: unknown Length Units {meta['length units']!r}")
    names, poses = [], []
    for k, name in enumerate(columns):
        pose = _fill(values[:, k])
        if pose is not None:
            names.append(name)
            poses.append(pose)
    if not names:
        raise ClipFormatError(f"{path}: no rigid body is tracked in any frame")
    poses = np.stack(poses, axis=1)
    return names, _to_z_up(poses, scale, up), rate


def _rows(path: Path) -> list[list[str]]:
    if not path.is_file():
        raise ClipFormatError(f"{path}: no such file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise ClipFormatError(f"{path}: not a text CSV file") from None
    try:
        return list(csv.reader(io.StringIO(text)))
    except csv.Error as error:
        raise ClipFormatError(f"{path}: malformed CSV ({error})") from None


def _header(rows: list[list[str]], path: Path) -> dict[str, str]:
    """Key-value pairs of the header rows (keys lower-cased)."""
    if not rows or not rows[0] or rows[0][0].strip().lower() != "format version":
        raise ClipFormatError(f"{path}: not an OptiTrack Motive CSV export (no Format Version header)")
    meta = {}
    for cells in rows[:8]:
        if cells and cells[0].strip().lower() in ("", "type", "frame"):
            break
        for key, value in zip(cells[0::2], cells[1::2]):
            if key.strip():
                meta[key.strip().lower()] = value.strip()
    return meta


def _find_row(rows: list[list[str]], test) -> int | None:
    for i, cells in enumerate(rows):
        if test(cells):
            return i
    return None


def _labelled(rows: list[list[str]], before: int, label: str) -> int | None:
    """Index of the row above `before` whose first cells include `label` (Type, Name)."""
    for i in range(before - 1, -1, -1):
        if label in {c.strip().lower() for c in rows[i][:3]}:
            return i
    return None


def _cell(cells: list[str], column: int) -> str:
    return cells[column].strip() if column < len(cells) else ""


def _rigid_body_columns(rows, type_row, name_row, group_row, path, meta) -> dict[str, list[int]]:
    """Rigid body name -> the 7 column indices of px py pz qx qy qz qw."""
    found: dict[str, dict[tuple[str, str], int]] = {}
    components = rows[group_row + 1] if group_row + 1 < len(rows) else []
    for column, kind in enumerate(rows[type_row]):
        if kind.strip().lower() != RIGID_BODY:
            continue
        name = _cell(rows[name_row], column) or f"rigid_body_{column}"
        key = (_cell(rows[group_row], column).lower(), _cell(components, column).upper())
        found.setdefault(name, {})[key] = column
    if not found:
        raise ClipFormatError(f"{path}: no Rigid Body columns")
    rotation_type = meta.get("rotation type", "quaternion").lower()
    out = {}
    for name, cols in found.items():
        if rotation_type != "quaternion" or ("rotation", "W") not in cols:
            raise ClipFormatError(
                f"{path}: rigid body {name} has {meta.get('rotation type', 'Euler')} rotations; export quaternions"
            )
        needed = [("position", c) for c in _POSITION] + [("rotation", c) for c in _ROTATION]
        missing = [f"{g} {c}" for g, c in needed if (g, c) not in cols]
        if missing:
            raise ClipFormatError(f"{path}: rigid body {name} lacks columns {', '.join(missing)}")
        out[name] = [cols[key] for key in needed]
    return out


def _data_rows(rows: list[list[str]], start: int, path: Path) -> list[list[str]]:
    """Rows after the headers whose first cell is a frame number."""
    data = []
    for cells in rows[start:]:
        first = _cell(cells, 0)
        if not first or first.lower().startswith("frame"):
            continue
        try:
            float(first)
        except ValueError:
            raise ClipFormatError(f"{path}: data row starts with {first[:20]!r}, not a frame number") from None
        data.append(cells)
    if not data:
        raise ClipFormatError(f"{path}: has no data rows (zero frames)")
    return data


def _numbers(data: list[list[str]], columns: dict[str, list[int]], path: Path) -> np.ndarray:
    """(T, m, 7) floats, NaN for empty cells."""
    index = np.array(list(columns.values()))
    out = np.full((len(data), *index.shape), np.nan)
    for t, cells in enumerate(data):
        for k, body in enumerate(index):
            for j, column in enumerate(body):
                text = _cell(cells, column)
                if text:
                    try:
                        out[t, k, j] = float(text)
                    except ValueError:
                        raise ClipFormatError(f"{path}: frame {cells[0]}: {text[:20]!r} is not a number") from None
                    if not np.isfinite(out[t, k, j]):  # an empty cell is an occlusion; a written NaN is not
                        name = list(columns)[k]
                        raise ClipFormatError(f"{path}: frame {cells[0]}: body {name}: {text[:20]!r} is not finite")
    return out


def _check_rotations(values: np.ndarray, names: list[str], data: list[list[str]], path: Path) -> None:
    """Every recorded pose (a frame with all seven cells) has a unit quaternion
    and a position within `MAX_COORDINATE` of the origin."""
    seen = np.all(np.isfinite(values), axis=-1)  # (T, m)
    far = seen & np.any(np.abs(values[..., :3]) > MAX_COORDINATE, axis=-1)
    if far.any():
        t, k = np.argwhere(far)[0]
        raise ClipFormatError(
            f"{path}: frame {_cell(data[t], 0)}: body {names[k]}: a position beyond {MAX_COORDINATE:g}"
        )
    with np.errstate(all="ignore"):  # huge numbers overflow to inf: not unit either
        norms = np.linalg.norm(values[..., 3:], axis=-1)
    bad = seen & ~(np.abs(norms - 1.0) <= UNIT_TOLERANCE)
    if bad.any():
        t, k = np.argwhere(bad)[0]
        raise ClipFormatError(
            f"{path}: frame {_cell(data[t], 0)}: body {names[k]}: the rotation is not a unit quaternion "
            f"(norm {norms[t, k]:.3g})"
        )


def _frame_rate(fps: float | None, meta: dict[str, str], data: list[list[str]], path: Path) -> float:
    """`fps`, else Export (or Capture) Frame Rate, else from the time column."""
    if fps is not None:
        return check_number(fps, "fps", path, low=RATE_RANGE[0], high=RATE_RANGE[1], unit="Hz")
    for key in ("export frame rate", "capture frame rate"):
        if key in meta:  # a stated rate must be a plausible one
            try:
                rate = float(meta[key])
            except ValueError:
                raise ClipFormatError(f"{path}: {key.title()}: {meta[key][:20]!r} is not a number") from None
            return check_number(rate, key.title(), path, low=RATE_RANGE[0], high=RATE_RANGE[1], unit="Hz")
    try:
        times = np.array([float(_cell(cells, 1)) for cells in data])
        step = float(np.median(np.diff(times))) if len(times) > 1 else np.nan
    except ValueError:
        step = np.nan
    if len(data) > 1 and np.isfinite(step) and step > 0:
        return check_number(
            1.0 / step, "the time column's rate", path, low=RATE_RANGE[0], high=RATE_RANGE[1], unit="Hz"
        )
    raise ClipFormatError(f"{path}: no frame rate in the header or the time column")


def _fill(body: np.ndarray) -> np.ndarray | None:
    """Interpolate the missing frames of one body's (T, 7) px py pz qx qy qz qw; None if never seen."""
    valid = np.all(np.isfinite(body), axis=1)
    norms = np.ones(len(body))
    norms[valid] = np.linalg.norm(body[valid, 3:], axis=1)
    if not valid.any():
        return None
    body = body.copy()
    body[valid, 3:] /= norms[valid, None]
    good = np.flatnonzero(valid)
    quats = body[good, 3:]
    flips = np.cumprod(np.where(np.sum(quats[1:] * quats[:-1], axis=1) < 0, -1.0, 1.0))
    quats[1:] *= flips[:, None]  # same hemisphere, so componentwise interpolation is short-path
    body[good, 3:] = quats
    frames = np.arange(len(body))
    out = np.stack([np.interp(frames, good, body[good, j]) for j in range(7)], axis=1)
    out[:, 3:] /= np.linalg.norm(out[:, 3:], axis=1, keepdims=True)
    return out


def _to_z_up(poses: np.ndarray, scale: float, up: str) -> np.ndarray:
    """Motive (px py pz qx qy qz qw) -> z-up (x y z w x y z), metres."""
    up = up.strip().lower()
    if up not in ("y", "z"):
        raise ValueError(f"up must be 'y' or 'z', not {up!r}")
    turn = Y_UP_TO_Z_UP if up == "y" else np.eye(3)
    position = poses[..., :3] * scale @ turn.T
    vector = poses[..., 3:6] @ turn.T  # conjugating by a rotation turns the quaternion's axis
    return np.concatenate([position, poses[..., 6:7], vector], axis=-1)


def write_optitrack_csv(
    path: str | Path, names: list[str], poses: np.ndarray, fps: float, *, units: str = "Meters"
) -> Path:
    """Write z-up poses (T, m, 7: x y z, w x y z) as a Motive-style rigid-body CSV (Y up).

    NaN rows are written as empty cells (occlusion). Atomic (temp file + rename).
    """
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 3 or poses.shape[1:] != (len(names), 7) or poses.shape[0] == 0:
        raise ValueError(f"poses must be (T > 0, {len(names)}, 7), got {poses.shape}")
    scale = LENGTH_UNITS.get(units.lower())
    if scale is None:
        raise ValueError(f"unknown units {units!r}")
    turn = Y_UP_TO_Z_UP.T  # inverse of the reader's turn
    position = poses[..., :3] @ turn.T / scale
    vector = poses[..., 4:7] @ turn.T
    motive = np.concatenate([vector, poses[..., 3:4], position], axis=-1)  # qx qy qz qw px py pz
    frames = len(poses)
    header = ["Format Version", "1.23", "Take Name", Path(path).stem, "Capture Frame Rate", f"{fps:.6f}"]
    header += ["Export Frame Rate", f"{fps:.6f}", "Total Frames in Take", str(frames)]
    header += ["Total Exported Frames", str(frames), "Rotation Type", "Quaternion", "Length Units", units]
    header += ["Coordinate Space", "Global"]
    rows = [header, []]
    rows.append(["", "Type"] + ["Rigid Body"] * (7 * len(names)))
    rows.append(["", "Name"] + [name for name in names for _ in range(7)])
    rows.append(["", "ID"] + [str(k + 1) for k in range(len(names)) for _ in range(7)])
    rows.append(["", ""] + (["Rotation"] * 4 + ["Position"] * 3) * len(names))
    rows.append(["Frame", "Time (Seconds)"] + [*_ROTATION, *_POSITION] * len(names))
    for t in range(frames):
        cells = [str(t), f"{t / fps:.6f}"]
        for k in range(len(names)):
            body = motive[t, k]
            cells += [f"{v:.6f}" for v in body] if np.all(np.isfinite(body)) else [""] * 7
        rows.append(cells)
    with atomic_output(path, suffix=".csv") as tmp, open(tmp, "w", newline="") as f:
        csv.writer(f).writerows(rows)
    return Path(path)


# --- synchronising objects with a clip ---------------------------------------


def slerp(q0: np.ndarray, q1: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of (..., 4) unit quaternions by `alpha` (...,), shortest path."""
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    alpha = np.asarray(alpha, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    angle = np.arccos(np.clip(np.abs(dot), 0.0, 1.0))
    sin = np.sin(angle)
    small = sin < 1e-6
    safe = np.where(small, 1.0, sin)
    w0 = np.where(small, 1.0 - alpha, np.sin((1.0 - alpha) * angle) / safe)
    w1 = np.where(small, alpha, np.sin(alpha * angle) / safe)
    out = w0 * q0 + w1 * q1
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def resample_poses(poses: np.ndarray, fps: float, times: np.ndarray, time_offset: float = 0.0) -> np.ndarray:
    """Poses (K, m, 7) sampled at `time_offset + k / fps`, evaluated at `times` (T,):
    linear in position, slerp in orientation, held outside the recording."""
    poses = np.asarray(poses, dtype=float)
    u = np.clip((np.asarray(times, dtype=float) - time_offset) * fps, 0.0, len(poses) - 1)
    i0 = np.minimum(np.floor(u).astype(int), len(poses) - 1)
    i1 = np.minimum(i0 + 1, len(poses) - 1)
    alpha = (u - i0)[:, None]
    position = (1.0 - alpha[..., None]) * poses[i0, :, :3] + alpha[..., None] * poses[i1, :, :3]
    quaternion = slerp(poses[i0, :, 3:], poses[i1, :, 3:], np.broadcast_to(alpha, poses[i0, :, 0].shape))
    return np.concatenate([position, quaternion], axis=-1)


def attach_objects(
    clip: MotionClip, names: list[str], poses: np.ndarray, fps: float, time_offset: float = 0.0
) -> MotionClip:
    """The clip with objects whose poses (K, m, 7) start at clip time `time_offset`
    and run at `fps`, resampled to the clip's frames. Objects already in the
    clip keep their poses unless named again (then replaced)."""
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 3 or poses.shape[1:] != (len(names), 7) or poses.shape[0] == 0:
        raise ValueError(f"poses must be (K > 0, {len(names)}, 7), got {poses.shape}")
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    resampled = resample_poses(poses, fps, clip.times, time_offset)
    kept = [k for k, name in enumerate(clip.object_names) if name not in names]
    old = clip.object_poses if clip.object_poses is not None else np.zeros((clip.num_frames, 0, 7))
    return dataclasses.replace(
        clip,
        object_names=[clip.object_names[k] for k in kept] + list(names),
        object_poses=np.concatenate([old[:, kept], resampled], axis=1),
    )
