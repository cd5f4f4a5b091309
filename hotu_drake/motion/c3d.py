"""C3D files: labelled marker trajectories in, a human clip out.

`read_c3d` reads labelled markers with ezc3d (metres, z up, gaps filled);
`load_c3d_clip` turns them into the human landmarks through a marker set
(`motion.marker_sets`) and returns a human `MotionClip`; `write_c3d` writes
markers (for synthetic captures and round trips).
"""

import json
import logging
import struct
import subprocess
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from hotu_drake.io import atomic_output
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.human import human_clip
from hotu_drake.motion.marker_sets import (
    BUILTIN_MARKER_SETS,
    MarkerSetLike,
    choose_marker_set,
    marker_names,
    markers_to_landmarks,
)
from hotu_drake.rotations import signed_axis, up_from_body, up_rotation

log = logging.getLogger("hotu_drake.input")

RATE_RANGE = (1.0, 10000.0)  # Hz: what a motion capture records at
CHILD_SECONDS = 10.0  # for ezc3d to read a file, plus a second per 10 MB
CHILD_MEMORY = 2 << 30  # bytes of address space for the reading child, plus 20 times the file size
UNIT_SCALES = {"mm": 1e-3, "cm": 1e-2, "dm": 0.1, "m": 1.0, "in": 0.0254, "inch": 0.0254, "ft": 0.3048}


# --- C3D files ---------------------------------------------------------------


def _check_header(path: Path) -> int:
    """The frame count the header promises; `ClipFormatError` unless `path`
    starts like a C3D file with frames."""
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
    points, analog, first, last = struct.unpack(order + "HHHH", header[2:10])
    if last < first:
        raise ClipFormatError(f"{path}: the C3D file has no frames")
    frames = last - first + 1
    # The header's own promise: stop here if the file cannot hold it (a cut
    # file, or a header that would have the reader allocate without bound).
    data_start = struct.unpack(order + "H", header[16:18])[0]
    # Float data when the scale is negative; DEC floats are not IEEE: count 2 bytes (a lower bound).
    float_data = parameters[3] != 85 and struct.unpack(order + "f", header[12:16])[0] < 0
    needed = (max(data_start, 1) - 1) * 512 + frames * (4 * points + analog) * (4 if float_data else 2)
    size = path.stat().st_size
    if size < needed:
        raise ClipFormatError(f"{path}: truncated: the header promises {frames} frames, the file holds fewer")
    return frames


def _read_in_child(path: Path) -> dict:
    """What `read_c3d` needs of a file, read by ezc3d in a process of its own
    (`c3d_child`): ezc3d is C++, and a hostile file can crash it, make it
    hang or make it allocate without bound; there, with a time and a memory
    limit, that is one error line, not the end of the program."""
    size = path.stat().st_size
    memory, seconds = CHILD_MEMORY + 20 * size, CHILD_SECONDS + size / 10e6
    with tempfile.TemporaryDirectory(prefix="hotu_drake_c3d_") as folder:
        out = Path(folder) / "c3d.npz"
        command = [sys.executable, "-m", "hotu_drake.motion.c3d_child", str(path), str(out), str(memory)]
        try:
            result = subprocess.run(command, capture_output=True, text=True, timeout=seconds)
        except subprocess.TimeoutExpired:
            raise ClipFormatError(
                f"{path}: not a readable C3D file (no answer from the reader in {seconds:.0f} s)"
            ) from None
        if result.returncode != 0 or not out.is_file():
            lines = result.stderr.strip().splitlines()
            reason = (
                lines[-1][:100] if result.returncode == 1 and lines else f"the reader failed, exit {result.returncode}"
            )
            raise ClipFormatError(f"{path}: not a readable C3D file ({reason})")
        with open(out, "rb") as f, np.load(f) as data:
            raw = {key: data[key] for key in data.files}
    return {
        "points": raw["points"],
        "residuals": raw["residuals"],
        "labels": json.loads(str(raw["labels"])),
        "rate": float(raw["rate"]),
        "declared": int(raw["declared"]),
        "units": str(raw["units"]),
        "y_screen": str(raw["y_screen"]),
    }


def _strip_prefix(labels: list[str], wanted: set[str]) -> list[str]:
    """Drop Vicon subject prefixes ("Subject:LASI" -> "LASI") when that makes names unique."""
    stripped = [label.rsplit(":", 1)[-1] for label in labels]
    if len(set(stripped)) == len(stripped) and (not wanted or len(wanted & set(stripped)) >= len(wanted & set(labels))):
        return stripped
    return labels


def _screen_hint(y_screen: str) -> str | None:
    """POINT:Y_SCREEN as a signed axis, if it is one: the axis a viewer shows
    upward, which usually, not always, is the data's up axis."""
    try:
        return signed_axis(y_screen) if y_screen else None
    except ValueError:
        return None


def _tallest_extent(markers: Mapping[str, np.ndarray]) -> str | None:
    """+axis of the largest per-frame extent of all markers, if clearly the largest."""
    points = np.stack(list(markers.values()))  # (n, T, 3)
    if len(points) < 3:
        return None
    extent = np.median(points.max(axis=0) - points.min(axis=0), axis=0)
    order = np.argsort(extent)[::-1]
    return "+" + "xyz"[order[0]] if extent[order[0]] > 1.5 * extent[order[1]] else None


def _choose_up(up, markers: Mapping[str, np.ndarray], marker_set, y_screen: str, where: str) -> tuple[str, str]:
    """(up axis, how it was found). `up` when given. Otherwise the data
    decides: the axis along which the head stands above the feet (landmarks
    of the marker set), else the clearly tallest extent of the markers;
    POINT:Y_SCREEN is only a hint, used when the data cannot tell, and a
    disagreement is said. Last resort: +z."""
    if up is not None:
        try:
            return signed_axis(up), "given"
        except ValueError as error:
            raise ClipFormatError(f"{where}: up: {error}") from None
    hint = _screen_hint(y_screen)
    found, how = None, ""
    if marker_set is not None:
        try:
            points = markers_to_landmarks(markers, marker_set, source=where, say=False)
        except ClipFormatError:
            points = {}
        if "head" in points:
            feet = [points[n] for n in ("left_ankle", "right_ankle") if n in points] or [points["chest"]]
            found, how = up_from_body(points["head"], np.mean(feet, axis=0)), "the head stands above the body"
    if found is None:
        found, how = _tallest_extent(markers), "the markers extend furthest along it"
    if found is None:
        if hint is not None:
            log.warning("%s: up axis unclear from the data; %s taken from POINT:Y_SCREEN", where, hint)
            return hint, "POINT:Y_SCREEN"
        log.warning("%s: up axis unclear from the data and the file; +z assumed (pass up to override)", where)
        return "+z", "assumed"
    if hint is not None and hint != found:
        log.info(
            "%s: up axis %s (%s); the file's POINT:Y_SCREEN says %s, a display hint, not used", where, found, how, hint
        )
    else:
        log.info("%s: up axis %s (%s)", where, found, how)
    return found, f"data ({how})"


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
    assumed if absent). The up axis is `up` if given (x, y or z, optionally
    signed), else decided from the data (`_choose_up`: where the head stands
    over the feet through the marker set, which is `marker_set` or the
    built-in set that fits the file best); `info` says which and how.
    Missing samples (negative residual, NaN or all-zero) are filled
    (`fill_gaps`); markers never seen and unlabelled ones ("*12") are
    dropped; with a marker set, so are markers it does not use.
    `info["filled"]` holds a (T,) mask of the filled samples per marker.
    A file shorter than its header says is refused as truncated.
    """
    path = Path(path)
    promised = _check_header(path)
    raw = _read_in_child(path)
    points, residuals, labels, rate = raw["points"], raw["residuals"], raw["labels"], raw["rate"]
    frames = points.shape[1]
    if frames == 0:
        raise ClipFormatError(f"{path}: the C3D file has no frames")
    declared = raw["declared"]
    expected = declared if declared > promised else promised  # POINT:FRAMES holds counts beyond 65535
    if frames < expected:
        raise ClipFormatError(f"{path}: truncated: the header promises {expected} frames, the file holds {frames}")
    if not (np.isfinite(rate) and RATE_RANGE[0] <= rate <= RATE_RANGE[1]):
        raise ClipFormatError(
            f"{path}: POINT:RATE {rate:g} Hz is not a plausible frame rate ({RATE_RANGE[0]:g}-{RATE_RANGE[1]:g} Hz)"
        )
    units = raw["units"]
    scale = UNIT_SCALES.get(units, 1e-3)
    missing = ~np.all(np.isfinite(points), axis=-1) | (residuals < 0) | np.all(points == 0.0, axis=-1)
    points = np.where(missing[..., None], 0.0, points) * scale
    labels = (labels + [""] * len(points))[: len(points)]
    chosen = marker_set if marker_set is not None else choose_marker_set(_strip_prefix(labels, set()))
    if marker_set is None and chosen is not None:
        log.info("%s: marker set %s (the built-in set the file's markers fit best)", path, chosen)
    wanted = marker_names(chosen) if chosen is not None else set()
    labels = _strip_prefix(labels, wanted)
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
    up_axis, up_source = _choose_up(up, markers, chosen, raw["y_screen"], str(path))
    rotation = up_rotation(up_axis)
    markers = {label: xyz @ rotation.T for label, xyz in markers.items()}
    info = {
        "units": units or "mm (assumed)",
        "scale_to_metres": scale,
        "up_axis": up_axis,
        "up_axis_source": up_source,
        "marker_set": chosen if isinstance(chosen, str) or chosen is None else "given",
        "frames": int(frames),
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


def load_c3d_clip(path: str | Path, marker_set: MarkerSetLike = None, up: str | None = None) -> MotionClip:
    """A human clip (landmarks as key bodies) from a C3D file and a marker set
    (default: the built-in set that fits the file's markers best)."""
    markers, fps, info = read_c3d(path, marker_set=marker_set, up=up)
    chosen = marker_set if marker_set is not None else info["marker_set"]
    if chosen is None:
        shown = ", ".join(sorted(markers)[:16])
        raise ClipFormatError(
            f"{path}: no built-in marker set fits the file's markers ({shown}{' ...' if len(markers) > 16 else ''}); "
            f"give one with --marker-set (built in: {', '.join(BUILTIN_MARKER_SETS)}) or write your own "
            "(see hotu_drake.motion.marker_sets)"
        )
    landmarks = markers_to_landmarks(markers, chosen, source=str(path))
    return human_clip(landmarks, fps, source=str(path))
