"""C3D files: labelled marker trajectories in, a human clip out.

`read_c3d` reads labelled markers with ezc3d (metres, z up, gaps filled);
`load_c3d_clip` turns them into the human landmarks through a marker set
(`motion.marker_sets`) and returns a human `MotionClip`; `write_c3d` writes
markers (for synthetic captures and round trips).
"""

import struct
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from hotu_drake.io import atomic_output
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.human import human_clip
from hotu_drake.motion.marker_sets import AXES, MarkerSetLike, marker_names, markers_to_landmarks

UNIT_SCALES = {"mm": 1e-3, "cm": 1e-2, "dm": 0.1, "m": 1.0, "in": 0.0254, "inch": 0.0254, "ft": 0.3048}


# --- C3D files ---------------------------------------------------------------


def _check_header(path: Path) -> None:
    """Raise `ClipFormatError` unless `path` starts like a C3D file with frames."""
    if not path.is_file():
        raise ClipFormatError(f"{path}: no such file")
    with open(path, "rb") as f:
        header = f.read(512)
        if len(header) < 512 or header[1] != 0x50:
            raise ClipFormatError(f"{path}: not a C3D file (no C3D header)")
        f.seek(max(header[0] - 1, 0) * 512)
        parameters = f.read(4)
    if len(parameters) < 4:
        raise ClipFormatError(f"{path}: truncated C3D file (no parameter section)")
    order = ">" if parameters[3] == 86 else "<"  # 84 Intel, 85 DEC, 86 MIPS (big-endian)
    first, last = struct.unpack(order + "HH", header[6:10])
    if last < first:
        raise ClipFormatError(f"{path}: the C3D file has no frames")


def _labels(parameters: Mapping) -> list[str]:
    """POINT:LABELS, continued in LABELS2, LABELS3, ... for large marker sets."""
    group = parameters["POINT"]
    labels = list(group["LABELS"]["value"]) if "LABELS" in group else []
    k = 2
    while f"LABELS{k}" in group:
        labels += list(group[f"LABELS{k}"]["value"])
        k += 1
    return [str(label).strip() for label in labels]


def _strip_prefix(labels: list[str], wanted: set[str]) -> list[str]:
    """Drop Vicon subject prefixes ("Subject:LASI" -> "LASI") when that makes names unique."""
    stripped = [label.rsplit(":", 1)[-1] for label in labels]
    if len(set(stripped)) == len(stripped) and (not wanted or len(wanted & set(stripped)) >= len(wanted & set(labels))):
        return stripped
    return labels


def _up_rotation(up: str) -> np.ndarray:
    """Rotation taking the file's up axis ("+y", "-z", ...) to +z, right-handed.

    Y up (x, y, z) -> (z, x, y): a Y-up lab's z axis becomes x.
    """
    sign, axis = (-1.0, up[-1]) if up.startswith("-") else (1.0, up[-1])
    rows = {"z": np.eye(3), "y": np.array([[0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0]])}
    rows["x"] = np.array([[0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0]])
    rotation = rows[axis]
    return rotation if sign > 0 else np.diag([1.0, -1.0, -1.0]) @ rotation


def _signed_axis(text: str) -> str:
    """Normalise an axis name: y, +Y, -z -> +y, +y, -z."""
    text = str(text).strip().lower()
    axis = text.lstrip("+-")
    if axis not in AXES or len(text) - len(axis) > 1:
        raise ValueError(f"up must be x, y or z, optionally signed, not {text!r}")
    return ("-" if text.startswith("-") else "+") + axis


def _detect_up(parameters: Mapping, points: np.ndarray, missing: np.ndarray) -> tuple[str, str]:
    """(up axis, how it was found): POINT:Y_SCREEN, else the data, else z."""
    screen = parameters["POINT"].get("Y_SCREEN", {}).get("value", [])
    if len(screen) and str(screen[0]).strip().lower().lstrip("+-") in AXES:
        return _signed_axis(screen[0]), "POINT:Y_SCREEN"
    masked = np.where(missing[..., None], np.nan, points)  # (n, T, 3)
    if np.isfinite(masked).any() and len(points) >= 3:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # frames with no marker
            extent = np.nanmedian(np.nanmax(masked, axis=0) - np.nanmin(masked, axis=0), axis=0)
        order = np.argsort(extent)[::-1]
        if np.all(np.isfinite(extent)) and extent[order[0]] > 1.5 * extent[order[1]]:
            return "+" + "xyz"[order[0]], "data (tallest extent)"
    return "+z", "default (z assumed)"


def fill_gaps(x: np.ndarray, missing: np.ndarray, method: str = "cubic") -> np.ndarray:
    """Fill missing samples of a (T, d) trajectory: interior gaps by cubic
    Hermite (end slopes from the neighbouring samples) or linear
    interpolation, edge gaps by holding the nearest valid sample."""
    x = np.array(x, dtype=float)
    valid = np.flatnonzero(~missing)
    if len(valid) == 0:
        raise ValueError("no valid samples to fill from")
    x[: valid[0]] = x[valid[0]]
    x[valid[-1] + 1 :] = x[valid[-1]]
    for j in np.flatnonzero(np.diff(valid) > 1):
        a, b = valid[j], valid[j + 1]
        s = ((np.arange(a + 1, b) - a) / (b - a))[:, None]
        chord = x[b] - x[a]
        if method == "linear":
            x[a + 1 : b] = x[a] + s * chord
            continue
        m0 = (x[a] - x[a - 1]) * (b - a) if a > 0 and not missing[a - 1] else chord
        m1 = (x[b + 1] - x[b]) * (b - a) if b + 1 < len(x) and not missing[b + 1] else chord
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        x[a + 1 : b] = h00 * x[a] + h10 * m0 + h01 * x[b] + h11 * m1
    return x


def read_c3d(
    path: str | Path, *, marker_set: MarkerSetLike = None, up: str | None = None, fill: str = "cubic"
) -> tuple[dict[str, np.ndarray], float, dict]:
    """Labelled marker trajectories of a C3D file, in metres with z up.

    Returns ({marker: (T, 3)}, fps, info). Units come from POINT:UNITS (mm
    assumed if absent); the up axis from `up`, else POINT:Y_SCREEN, else
    the axis of the largest per-frame extent if clearly the largest, else z
    (`info` says which and how). Missing samples (negative residual, NaN or
    all-zero) are filled (`fill_gaps`); markers never seen and unlabelled
    ones ("*12") are dropped. With `marker_set`, only its markers are kept.
    `info["filled"]` holds a (T,) mask of the filled samples per marker.
    """
    import ezc3d

    path = Path(path)
    _check_header(path)
    try:
        c3d = ezc3d.c3d(str(path))
        parameters = c3d["parameters"]
        points = np.asarray(c3d["data"]["points"], dtype=float)[:3].transpose(1, 2, 0)  # (n, T, 3)
        residuals = np.asarray(c3d["data"]["meta_points"]["residuals"], dtype=float)[0]
        labels = _labels(parameters)
        rate = float(np.ravel(parameters["POINT"]["RATE"]["value"])[0])
    except (OSError, RuntimeError, ValueError, KeyError, IndexError, TypeError) as error:
        reason = str(error).splitlines()[0][:80] if str(error) else type(error).__name__
        raise ClipFormatError(f"{path}: not a readable C3D file ({reason})") from None
    if points.shape[1] == 0:
        raise ClipFormatError(f"{path}: the C3D file has no frames")
    if not np.isfinite(rate) or rate <= 0:
        raise ClipFormatError(f"{path}: POINT:RATE is not a positive frame rate")
    units_value = parameters["POINT"].get("UNITS", {}).get("value", [])
    units = str(units_value[0]).strip().lower() if len(units_value) else ""
    scale = UNIT_SCALES.get(units, 1e-3)
    missing = ~np.all(np.isfinite(points), axis=-1) | (residuals < 0) | np.all(points == 0.0, axis=-1)
    up_axis, up_source = (_signed_axis(up), "argument") if up else _detect_up(parameters, points, missing)
    points = np.where(missing[..., None], 0.0, points) * scale @ _up_rotation(up_axis).T
    wanted = marker_names(marker_set) if marker_set is not None else set()
    labels = _strip_prefix((labels + [""] * len(points))[: len(points)], wanted)
    markers, dropped, gaps = {}, [], {}
    for i, label in enumerate(labels):
        if not label or label.startswith("*") or label in markers or (wanted and label not in wanted):
            dropped.append(label)
            continue
        if missing[i].all():
            dropped.append(label)
            continue
        if missing[i].any():
            gaps[label] = missing[i].copy()
        markers[label] = fill_gaps(points[i], missing[i], fill)
    if not markers:
        raise ClipFormatError(f"{path}: the C3D file has no usable markers")
    info = {
        "units": units or "mm (assumed)",
        "scale_to_metres": scale,
        "up_axis": up_axis,
        "up_axis_source": up_source,
        "frames": int(points.shape[1]),
        "dropped": dropped,
        "gap_samples": {label: int(mask.sum()) for label, mask in gaps.items()},
        "filled": gaps,
    }
    return markers, rate, info


def write_c3d(path: str | Path, markers: Mapping[str, np.ndarray], fps: float) -> Path:
    """Write {marker: (T, 3)} metres (z up) as a C3D file in millimetres.

    NaN samples are written as missing (residual -1). Atomic: a temporary
    file in the same folder is renamed over `path`.
    """
    import ezc3d

    path = Path(path)
    names = list(markers)
    if not names:
        raise ValueError("no markers to write")
    data = np.stack([np.asarray(markers[n], dtype=float) for n in names])  # (n, T, 3)
    if data.ndim != 3 or data.shape[2] != 3 or data.shape[1] == 0:
        raise ValueError(f"markers must be (T, 3) arrays with T > 0, got {data.shape[1:]}")
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    missing = ~np.all(np.isfinite(data), axis=-1)
    points = np.ones((4, len(names), data.shape[1]))
    points[:3] = np.where(missing[..., None], 0.0, data * 1000.0).transpose(2, 0, 1)
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [float(fps)]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = tuple(names)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    c3d.add_parameter("POINT", "X_SCREEN", "+X")
    c3d.add_parameter("POINT", "Y_SCREEN", "+Z")
    c3d["data"]["points"] = points
    c3d["data"]["meta_points"]["residuals"] = np.where(missing, -1.0, 0.0)[None]
    with atomic_output(path, suffix=".c3d") as tmp:
        c3d.write(str(tmp))
    return path


def load_c3d_clip(path: str | Path, marker_set: MarkerSetLike = None) -> MotionClip:
    """A human clip (landmarks as key bodies) from a C3D file and a marker set."""
    markers, fps, _ = read_c3d(path, marker_set=marker_set)
    landmarks = markers_to_landmarks(markers, marker_set, source=str(path))
    return human_clip(landmarks, fps, source=str(path))
