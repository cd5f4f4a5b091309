"""A corpus of bad inputs across every reader, command line and environment keyword.

Each `Case` makes its input under a temporary folder and either runs a
command line in this process (`cli`) or calls the Python API (`api`). The
promise under test (README, "Bad input"): a command line prints exactly one
`error:` line naming the file or field (no traceback, no "internal
error"), exits with 2 and leaves no file behind; the API raises
`InputError` (a `ValueError`) naming the file or field.
"""

import json
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from hotu_drake import embodiment
from hotu_drake.motion.bvh import write_udh_bvh
from hotu_drake.motion.c3d import write_c3d
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.marker_sets import udh_markers
from hotu_drake.motion.optitrack import write_optitrack_csv
from tests.clips import udh_test_clip


@dataclass
class Case:
    id: str
    kind: str  # "cli": make returns (module, argv); "api": make returns a callable
    make: Callable[[Path], object]
    expect: str  # text the message must contain: the file, the field or the value


CASES: list[Case] = []


def case(id_: str, kind: str, expect: str):
    def add(make):
        CASES.append(Case(id_, kind, make, expect))
        return make

    return add


# --- valid inputs to mutate ------------------------------------------------------------


@cache
def _udh_clip() -> MotionClip:
    return udh_test_clip("none", frames=12, fps=30.0)


@cache
def bvh_text() -> str:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = write_udh_bvh(_udh_clip(), embodiment.load("udh", "none"), Path(folder) / "ok.bvh")
        return path.read_text()


@cache
def c3d_markers() -> dict:
    return udh_markers(embodiment.load("udh", "none"), _udh_clip())


@cache
def c3d_bytes() -> bytes:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        return write_c3d(Path(folder) / "ok.c3d", c3d_markers(), 30.0).read_bytes()


@cache
def human_npz_arrays() -> dict:
    import tempfile

    from hotu_drake.motion.human import human_clip
    from hotu_drake.motion.udh_skeleton import udh_landmarks

    clip = human_clip(udh_landmarks(embodiment.load("udh", "none"), _udh_clip()), 30.0, "ok")
    with tempfile.TemporaryDirectory() as folder:
        path = clip.save(Path(folder) / "ok.npz")
        with np.load(path) as data:
            return {k: data[k] for k in data.files}


def csv_text() -> str:
    import tempfile

    t = np.arange(10) / 30.0
    poses = np.zeros((10, 1, 7))
    poses[:, 0, 0], poses[:, 0, 2], poses[:, 0, 3] = t, 1.0, 1.0
    with tempfile.TemporaryDirectory() as folder:
        return write_optitrack_csv(Path(folder) / "ok.csv", ["box"], poses, 30.0).read_text()


def write(tmp: Path, name: str, content) -> Path:
    path = tmp / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def retarget(path: Path, *extra: str):
    return "hotu_drake.retarget", [str(path), "--robot", "bruce", "--out", str(path.parent / "out"), *extra]


def save_npz(tmp: Path, name: str, **changes) -> Path:
    arrays = dict(human_npz_arrays())
    for key, value in changes.items():
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = value
    path = tmp / name
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    return path


# --- BVH -----------------------------------------------------------------------------------


def _motion_lines(text: str) -> tuple[list[str], int]:
    lines = text.splitlines()
    return lines, next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1


def _bvh_with(replace: Callable[[list[str], int], list[str]]) -> str:
    lines, first = _motion_lines(bvh_text())
    return "\n".join(replace(lines, first)) + "\n"


def _frame_time(value: str):
    return lambda lines, first: [f"Frame Time: {value}" if line.startswith("Frame Time") else line for line in lines]


def _frames(value: str):
    return lambda lines, first: [f"Frames: {value}" if line.startswith("Frames:") else line for line in lines]


def _cell(row: int, column: int, value: str):
    def change(lines, first):
        cells = lines[first + row].split()
        cells[column] = value
        return lines[: first + row] + [" ".join(cells)] + lines[first + row + 1 :]

    return change


def _root_jump(lines, first):
    out = list(lines)
    for row in range(6, len(lines) - first):
        cells = out[first + row].split()
        cells[0] = str(float(cells[0]) + 5000.0)  # 50 m in centimetres, from frame 6 on
        out[first + row] = " ".join(cells)
    return out


BVH_MUTATIONS: dict[str, tuple[Callable[[], str | bytes], str]] = {
    "empty": (lambda: "", "empty"),
    "blank_lines": (lambda: "\n\n  \n", "empty"),
    "binary": (lambda: bytes(range(256)) * 4, "bvh"),
    "no_hierarchy": (lambda: "ROOT Hips\n{\n}\n", "HIERARCHY"),
    "hierarchy_only": (lambda: bvh_text().split("MOTION")[0], "MOTION"),
    "cut_in_hierarchy": (lambda: bvh_text()[: len(bvh_text().split("MOTION")[0]) // 2], "truncated"),
    "cut_in_motion": (lambda: bvh_text()[: int(len(bvh_text()) * 0.97)], "bvh"),
    "frame_time_zero": (lambda: _bvh_with(_frame_time("0")), "Frame Time"),
    "frame_time_negative": (lambda: _bvh_with(_frame_time("-0.033")), "Frame Time"),
    "frame_time_denormal": (lambda: _bvh_with(_frame_time("1e-320")), "Frame Time"),
    "frame_time_huge": (lambda: _bvh_with(_frame_time("1e300")), "Frame Time"),
    "frame_time_nan": (lambda: _bvh_with(_frame_time("nan")), "Frame Time"),
    "frame_time_text": (lambda: _bvh_with(_frame_time("fast")), "Frame Time"),
    "frames_text": (lambda: _bvh_with(_frames("twelve")), "Frames"),
    "frames_more": (lambda: _bvh_with(_frames("13")), "truncated"),
    "frames_fewer": (lambda: _bvh_with(_frames("11")), "Frames"),
    "frames_zero": (lambda: _bvh_with(_frames("0")), "zero frames"),
    "frames_huge": (lambda: _bvh_with(_frames("99999999999")), "truncated"),
    "nan_in_motion": (lambda: _bvh_with(_cell(3, 4, "nan")), "NaN"),
    "inf_in_motion": (lambda: _bvh_with(_cell(3, 4, "inf")), "infinite"),
    "text_in_motion": (lambda: _bvh_with(_cell(3, 4, "x")), "not a number"),
    "short_row": (
        lambda: _bvh_with(lambda lines, first: lines[:first] + [lines[first][:20]] + lines[first + 1 :]),
        "values",
    ),
    "channels_huge": (lambda: bvh_text().replace("CHANNELS 6", "CHANNELS 99999999", 1), "bvh"),
    "channels_negative": (lambda: bvh_text().replace("CHANNELS 6", "CHANNELS -6", 1), "CHANNELS"),
    "channel_unknown": (lambda: bvh_text().replace("Xposition", "Wposition", 1), "channel"),
    "offset_nan": (lambda: bvh_text().replace("OFFSET", "OFFSET nan", 1), "OFFSET"),
    "deep_hierarchy": (
        lambda: (
            "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n"
            + "JOINT j\n{\nOFFSET 0 1 0\n" * 5000
            + "}\n" * 5001
            + "MOTION\nFrames: 1\nFrame Time: 0.033\n0 0 0\n"
        ),
        "nested",
    ),
    "unknown_skeleton": (
        lambda: (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\nJOINT b\n{\n"
            "OFFSET 0 10 0\nEnd Site\n{\nOFFSET 0 10 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.033\n0 0 0\n"
        ),
        "skeleton",
    ),
    "root_teleports": (lambda: _bvh_with(_root_jump), "jumps"),
}
for _name, (_content, _expect) in BVH_MUTATIONS.items():

    def _make(tmp, content=_content, name=_name):
        return retarget(write(tmp, f"{name}.bvh", content()))

    case(f"bvh_{_name}", "cli", _expect)(_make)


@case("bvh_bad_up", "cli", "--up")
def _(tmp):
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--up", "w")


@case("bvh_missing_skeleton_map", "cli", "nowhere.yaml")
def _(tmp):
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--skeleton-map", str(tmp / "nowhere.yaml"))


@case("bvh_malformed_skeleton_map", "cli", "map.yaml")
def _(tmp):
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--skeleton-map", str(write(tmp, "map.yaml", "a: [b\n")))


@case("missing_input", "cli", "absent.bvh")
def _(tmp):
    return retarget(tmp / "absent.bvh")


@case("unsupported_suffix", "cli", "motion.fbx")
def _(tmp):
    return retarget(write(tmp, "motion.fbx", "FBX"))


@case("unknown_robot", "cli", "atlas")
def _(tmp):
    return "hotu_drake.retarget", [str(write(tmp, "ok.bvh", bvh_text())), "--robot", "atlas", "--out", str(tmp / "o")]


@case("out_is_a_file", "cli", "taken")
def _(tmp):
    return "hotu_drake.retarget", [
        str(write(tmp, "ok.bvh", bvh_text())),
        "--robot",
        "udh",
        "--out",
        str(write(tmp, "taken", "x")),
    ]


@case("report_is_a_folder", "cli", "report_dir")
def _(tmp):
    (tmp / "report_dir").mkdir()
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--report", str(tmp / "report_dir"))


@case("report_under_a_file", "cli", "report.json")
def _(tmp):
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--report", str(write(tmp, "afile", "x") / "report.json"))


@case("html_under_a_file", "cli", "replay.html")
def _(tmp):
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--html", str(write(tmp, "afile", "x") / "replay.html"))


# --- C3D -----------------------------------------------------------------------------------


def _c3d_from(tmp: Path, name: str, markers: dict, units: str | None = None, rate: float | None = None) -> Path:
    """A C3D file of `markers` with its POINT:UNITS or POINT:RATE replaced (the
    rate patched in the bytes: ezc3d will not write an impossible one)."""
    import struct

    import ezc3d

    path = write_c3d(tmp / name, markers, 30.0)
    if units is not None:
        c3d = ezc3d.c3d(str(path))
        c3d["parameters"]["POINT"]["UNITS"]["value"] = [units]
        c3d.write(str(path))
    if rate is not None:
        data = bytearray(path.read_bytes())
        at = data.find(b"RATE") + 8  # name, 2-byte offset, type, 0 dimensions, then the float
        data[at : at + 4] = struct.pack("<f", rate)
        data[20:24] = struct.pack("<f", rate)  # and the header's copy
        path.write_bytes(bytes(data))
    return path


def _without(*names: str) -> dict:
    return {k: v for k, v in c3d_markers().items() if k not in names}


def _shifted(frame: int, by: float) -> dict:
    out = {}
    for k, v in c3d_markers().items():
        v = v.copy()
        v[frame:, 0] += by
        out[k] = v
    return out


C3D_CASES: dict[str, tuple[Callable[[Path], Path], str]] = {
    "empty": (lambda tmp: write(tmp, "empty.c3d", b""), "C3D"),
    "garbage": (lambda tmp: write(tmp, "garbage.c3d", bytes(range(256)) * 8), "C3D"),
    "not_c3d_header": (lambda tmp: write(tmp, "header.c3d", b"\x02\x00" + c3d_bytes()[2:]), "C3D"),
    "cut_quarter": (lambda tmp: write(tmp, "cut25.c3d", c3d_bytes()[: len(c3d_bytes()) // 4]), "cut25.c3d"),
    "cut_half": (lambda tmp: write(tmp, "cut50.c3d", c3d_bytes()[: len(c3d_bytes()) // 2]), "truncated"),
    "cut_last_frames": (lambda tmp: write(tmp, "cut90.c3d", c3d_bytes()[: int(len(c3d_bytes()) * 0.9)]), "truncated"),
    "only_header": (lambda tmp: write(tmp, "header_only.c3d", c3d_bytes()[:512]), "C3D"),
    "rate_zero": (lambda tmp: _c3d_from(tmp, "rate0.c3d", c3d_markers(), rate=0.0), "RATE"),
    "rate_huge": (lambda tmp: _c3d_from(tmp, "rate_huge.c3d", c3d_markers(), rate=1e9), "RATE"),
    "units_metres_but_millimetres": (lambda tmp: _c3d_from(tmp, "units.c3d", c3d_markers(), units="m"), "tall"),
    "units_kilometres_as_mm": (
        lambda tmp: write_c3d(tmp / "tiny.c3d", {k: v / 1000 for k, v in c3d_markers().items()}, 30.0),
        "tall",
    ),
    "missing_knee_marker": (lambda tmp: write_c3d(tmp / "noknee.c3d", _without("LKNE"), 30.0), "LKNE"),
    "missing_chest_markers": (lambda tmp: write_c3d(tmp / "nochest.c3d", _without("T10", "STRN"), 30.0), "T10"),
    "few_markers": (
        lambda tmp: write_c3d(tmp / "few.c3d", {k: c3d_markers()[k] for k in ("LASI", "RASI", "C7")}, 30.0),
        "few.c3d",
    ),
    "all_missing": (
        lambda tmp: write_c3d(tmp / "void.c3d", {k: np.full_like(v, np.nan) for k, v in c3d_markers().items()}, 30.0),
        "no usable markers",
    ),
    "unlabelled": (
        lambda tmp: write_c3d(tmp / "anon.c3d", {f"*{i}": v for i, v in enumerate(c3d_markers().values())}, 30.0),
        "anon.c3d",
    ),
    "root_teleports": (lambda tmp: write_c3d(tmp / "jump.c3d", _shifted(5, 40.0), 30.0), "jumps"),
}
for _name, (_make_file, _expect) in C3D_CASES.items():

    def _make(tmp, make_file=_make_file):
        return retarget(make_file(tmp))

    case(f"c3d_{_name}", "cli", _expect)(_make)

MARKER_SETS = {
    "unknown_rule": ("landmarks:\n  left_knee: {rule: magic}\n", "magic"),
    "unknown_key": ("landmarks:\n  neck: [C7]\nmarkers: []\n", "unknown key"),
    "bad_mirror": ("mirror: sideways\nlandmarks:\n  neck: [C7]\n", "mirror"),
    "extends_unknown": ("extends: helen_hayes\n", "helen_hayes"),
    "hinge_missing_keys": ("landmarks:\n  left_elbow: {rule: hinge, proximal: LSHO}\n", "needs"),
    "weights_text": ("landmarks:\n  neck: {C7: heavy}\n", "weights"),
    "frame_bad_axis": (
        "frames:\n  thorax: {primary: [w, [C7], [T10]], secondary: [x, [C7], [T10]]}\nlandmarks:\n  neck: [C7]\n",
        "thorax",
    ),
    "hip_bad_side": ("landmarks:\n  left_hip: {rule: hip_joint_centre, side: middle}\n", "side"),
    "rule_stray_key": (
        "landmarks:\n  left_knee: {rule: chord, proximal: a, plane: b, lateral: c, distance: 1, colour: red}\n",
        "colour",
    ),
    "not_a_mapping": ("- LASI\n- RASI\n", "mapping"),
    "yaml_syntax": ("landmarks: [\n", "YAML"),
    "self_reference": (
        "extends: plug_in_gait\nlandmarks:\n  neck: {rule: offset, from: neck, frame: thorax, offset: [0, 0, 0]}\n",
        "itself",
    ),
}
for _name, (_text, _expect) in MARKER_SETS.items():

    def _make(tmp, text=_text, name=_name):
        c3d = write_c3d(tmp / "ok.c3d", c3d_markers(), 30.0)
        return retarget(c3d, "--marker-set", str(write(tmp, f"{name}.yaml", text)))

    case(f"marker_set_{_name}", "cli", _expect)(_make)


@case("marker_set_missing_file", "cli", "nowhere.yaml")
def _(tmp):
    return retarget(write_c3d(tmp / "ok.c3d", c3d_markers(), 30.0), "--marker-set", str(tmp / "nowhere.yaml"))


@case("c3d_bad_up", "cli", "--up")
def _(tmp):
    return retarget(write_c3d(tmp / "ok.c3d", c3d_markers(), 30.0), "--up", "sideways")


# --- retarget: a failed run writes nothing ----------------------------------------------------------
# A run whose every input is refused leaves no report and no replay (nor a
# clip); an output that cannot be written is found before any work, so no
# clip is written ahead of the report, the replay or a later clip that fails.


def _outputs(tmp: Path) -> list[str]:
    return ["--report", str(tmp / "report.json"), "--html", str(tmp / "replay.html")]


FAILED_RUNS: dict[str, tuple[Callable[[Path], Path], str]] = {
    "bvh_binary_with_report": (lambda tmp: write(tmp, "binary.bvh", bytes(range(256)) * 4), "binary.bvh"),
    "bvh_root_teleports_with_report": (lambda tmp: write(tmp, "jump.bvh", _bvh_with(_root_jump)), "jumps"),
    "c3d_giant_with_report": (lambda tmp: _c3d_from(tmp, "giant.c3d", c3d_markers(), units="m"), "tall"),
    "c3d_tiny_with_report": (
        lambda tmp: write_c3d(tmp / "tiny.c3d", {k: v / 1000 for k, v in c3d_markers().items()}, 30.0),
        "tall",
    ),
}
for _name, (_make_file, _expect) in FAILED_RUNS.items():

    def _make(tmp, make_file=_make_file):
        return retarget(make_file(tmp), *_outputs(tmp))

    case(_name, "cli", _expect)(_make)


@case("report_in_a_read_only_folder", "cli", "report.json")
def _(tmp):
    (tmp / "locked").mkdir(mode=0o555)
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--report", str(tmp / "locked" / "report.json"))


@case("html_under_a_read_only_folder", "cli", "replay.html")
def _(tmp):
    (tmp / "locked").mkdir(mode=0o555)
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--html", str(tmp / "locked" / "new" / "replay.html"))


@case("report_beyond_a_broken_link", "cli", "report.json")
def _(tmp):
    (tmp / "link").symlink_to(tmp / "gone")
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--report", str(tmp / "link" / "report.json"))


@case("out_clip_is_a_folder", "cli", "b_bruce.npz")
def _(tmp):
    (tmp / "out" / "b_bruce.npz").mkdir(parents=True)  # the second input's clip
    module, argv = retarget(write(tmp, "a.bvh", bvh_text()))
    return module, [argv[0], str(write(tmp, "b.bvh", bvh_text())), *argv[1:]]


@case("html_of_second_clip_is_a_folder", "cli", "replay_b.html")
def _(tmp):
    (tmp / "replay_b.html").mkdir()  # with two inputs, replay.html becomes replay_a.html and replay_b.html
    module, argv = retarget(write(tmp, "a.bvh", bvh_text()), "--html", str(tmp / "replay.html"))
    return module, [argv[0], str(write(tmp, "b.bvh", bvh_text())), *argv[1:]]


# --- retarget: a body that never stands upright -------------------------------------------------------
# The height checks do not see a capture of the upper body (its height is
# the arm span) laid on its side by a wrong --up, nor tell a body upside down.

LEGS = tuple(f"{side}_{name}" for side in ("left", "right") for name in ("knee", "ankle", "toe"))
LEG_MARKERS = tuple(f"{side}{name}" for side in "LR" for name in ("THI", "KNE", "TIB", "ANK", "HEE", "TOE"))


def upper_body_bvh(tmp: Path) -> tuple[Path, Path]:
    """The UDH BVH and a skeleton map that leaves its legs out (a capture of the upper body)."""
    skeleton_map = write(tmp, "upper_body.yaml", "".join(f"{name}: null\n" for name in LEGS))
    return write(tmp, "upper_body.bvh", bvh_text()), skeleton_map


@case("bvh_upper_body_on_its_side", "cli", "upright")
def _(tmp):
    bvh, skeleton_map = upper_body_bvh(tmp)
    return retarget(bvh, "--skeleton-map", str(skeleton_map), "--up", "x")  # the file is y up


@case("c3d_upper_body_on_its_side", "cli", "upright")
def _(tmp):
    return retarget(write_c3d(tmp / "upper_body.c3d", _without(*LEG_MARKERS), 30.0), "--up", "y")  # z up


@case("bvh_upside_down", "cli", "upright")
def _(tmp):
    return retarget(write(tmp, "ok.bvh", bvh_text()), "--up", "-y")  # "-y" after --up is its value


@case("bvh_upper_body_on_its_side_api", "api", "upright")
def _(tmp):
    from hotu_drake.motion.load import load_motion

    bvh, skeleton_map = upper_body_bvh(tmp)
    return lambda: load_motion(bvh, skeleton_map, up="z")


# --- clip files (.npz) -------------------------------------------------------------------------

NPZ_CASES = {
    "version_text": ({"format_version": np.array("1")}, "format_version"),
    "version_two": ({"format_version": np.array(2)}, "version"),
    "fps_text": ({"fps": np.array("thirty")}, "fps"),
    "fps_nan": ({"fps": np.array(np.nan)}, "fps"),
    "fps_negative": ({"fps": np.array(-30.0)}, "fps"),
    "fps_zero": ({"fps": np.array(0.0)}, "fps"),
    "embodiment_number": ({"embodiment": np.array(5)}, "embodiment"),
    "missing_key": ({"root_position": None}, "root_position"),
    "positions_wrong_shape": ({"root_position": np.zeros((3, 3))}, "root_position"),
    "positions_nan": ({"key_body_positions": np.full_like(human_npz_arrays()["key_body_positions"], np.nan)}, "NaN"),
    "positions_text": ({"root_position": np.full((12, 3), "a")}, "root_position"),
    "quaternion_zero": ({"root_quaternion": np.zeros((12, 4))}, "quaternion"),
    "part_index_not_json": ({"part_index": np.array("{parts")}, "part_index"),
    "part_index_list": ({"part_index": np.array("[1, 2]")}, "part_index"),
    "names_numbers": ({"key_body_names": np.arange(27)}, "key_body_names"),
    "duplicate_names": ({"key_body_names": np.array(["pelvis"] * 27)}, "repeats"),
    "labelled_udh": ({"embodiment": np.array("udh")}, "UDH"),
    "robot_clip": ({"embodiment": np.array("h1")}, "h1"),
    "not_landmarks": ({"key_body_names": np.array([f"marker{i}" for i in range(27)])}, "landmarks"),
    "contacts_not_flags": (
        {"contact_names": np.array(["left_foot"]), "contacts": np.full((12, 1), 7)},
        "contacts",
    ),
}
for _name, (_changes, _expect) in NPZ_CASES.items():

    def _make(tmp, changes=_changes, name=_name):
        return retarget(save_npz(tmp, f"{name}.npz", **changes))

    case(f"npz_{_name}", "cli", _expect)(_make)


@case("npz_not_a_zip", "cli", "junk.npz")
def _(tmp):
    return retarget(write(tmp, "junk.npz", b"PK\x03\x04 not really a zip"))


@case("npz_empty_file", "cli", "empty.npz")
def _(tmp):
    return retarget(write(tmp, "empty.npz", b""))


@case("npz_api_unknown_key_body", "api", "left_elbow_tip")
def _(tmp):
    clip = MotionClip.load(save_npz(tmp, "ok.npz"))
    return lambda: clip.key_body("left_elbow_tip")


@case("npz_api_bad_slice", "api", "slice")
def _(tmp):
    clip = MotionClip.load(save_npz(tmp, "ok.npz"))
    return lambda: clip.slice(5, 500)


# --- OptiTrack CSV ---------------------------------------------------------------------------


def _csv_rates(value: str) -> str:
    text = csv_text()
    for key in ("Capture Frame Rate", "Export Frame Rate"):
        text = text.replace(f"{key},30.000000", f"{key},{value}")
    return text


def _csv_api(tmp: Path, name: str, text: str, **keywords):
    from hotu_drake.motion.optitrack import read_optitrack_csv

    path = write(tmp, name, text)
    return lambda: read_optitrack_csv(path, **keywords)


def _csv_data_cells(change: Callable[[list[str]], list[str]]) -> str:
    lines = csv_text().splitlines()
    return "\n".join(lines[:-3] + [",".join(change(lines[-3].split(",")))] + lines[-2:]) + "\n"


CSV_CASES = {
    "empty": (lambda: "", "empty.csv"),
    "no_group_row": (lambda: "Format Version,1.23\nFrame,Time\n0,0\n", "Rotation"),
    "text_in_data": (lambda: _csv_data_cells(lambda c: c[:2] + ["abc"] + c[3:]), "not a number"),
    "nan_written": (lambda: _csv_data_cells(lambda c: c[:2] + ["nan"] + c[3:]), "finite"),
    "zero_quaternion": (lambda: _csv_data_cells(lambda c: c[:2] + ["0", "0", "0", "0"] + c[6:]), "unit quaternion"),
    "long_quaternion": (lambda: _csv_data_cells(lambda c: c[:2] + ["0", "0", "0", "2"] + c[6:]), "unit quaternion"),
    "unknown_units": (lambda: csv_text().replace("Meters", "Furlongs"), "Furlongs"),
    "no_data_rows": (lambda: "\n".join(csv_text().splitlines()[:7]) + "\n", "no data rows"),
    "rate_zero": (lambda: _csv_rates("0"), "Frame Rate"),
    "rate_huge": (lambda: _csv_rates("1e12"), "Frame Rate"),
}
for _name, (_text, _expect) in CSV_CASES.items():

    def _make(tmp, text=_text, name=_name):
        return _csv_api(tmp, f"{name}.csv", text())

    case(f"csv_{_name}", "api", _expect)(_make)


@case("csv_fps_keyword_negative", "api", "fps")
def _(tmp):
    return _csv_api(tmp, "ok.csv", csv_text(), fps=-30.0)


# --- scenario files ------------------------------------------------------------------------------

SCENARIO_FIELDS = {
    "time_step_nan": ("plant_config: {time_step: .nan}", "time_step"),
    "time_step_negative": ("plant_config: {time_step: -0.005}", "time_step"),
    "time_step_huge": ("plant_config: {time_step: 100.0}", "time_step"),
    "time_step_tiny_long_run": ("plant_config: {time_step: 0.00001}\nduration: 3000.0", "duration"),
    "time_step_text": ("plant_config: {time_step: fast}", "time_step"),
    "duration_infinite": ("duration: .inf", "duration"),
    "duration_nan": ("duration: .nan", "duration"),
    "duration_zero": ("duration: 0.0", "duration"),
    "duration_negative": ("duration: -3.0", "duration"),
    "duration_text": ("duration: long", "duration"),
    "control_rate_zero": ("control_rate: 0.0", "control_rate"),
    "control_rate_nan": ("control_rate: .nan", "control_rate"),
    "drop_height_huge": ("initial: {drop_height: 1000000.0}", "drop_height"),
    "drop_height_negative": ("initial: {drop_height: -0.1}", "drop_height"),
    "reference_time_nan": ("initial: {reference_time: .nan}", "reference_time"),
    "reference_time_between": ("initial: {reference_time: -0.5}", "reference_time"),
    "reference_time_without_motion": ("initial: {reference_time: 0.5}", "reference_time"),
    "publish_period_zero": ("visualization: {publish_period: 0.0}", "publish_period"),
    "approximation_unknown": (
        "plant_config: {discrete_contact_approximation: tamsi}",
        "discrete_contact_approximation",
    ),
    "contact_model_unknown": ("plant_config: {contact_model: magic}", "contact_model"),
    "near_rigid_negative": ("plant_config: {sap_near_rigid_threshold: -1.0}", "sap_near_rigid_threshold"),
    "controller_unknown": ("controller: pid", "controller"),
    "embodiment_unknown": ("embodiment: atlas", "embodiment"),
    "hands_unknown": ("hands: some", "hands"),
    "driver_unknown": ("driver: !Teleop {}", "bad.yaml"),
    "driver_reference_empty": ("driver: !ReferenceTracking {motion: ''}", "driver.motion"),
    "checkpoint_missing": ("driver: !PolicyCheckpoint {checkpoint: gone.pt}", "gone.pt"),
    "base_twist_explicit": ("embodiment: curi\ncontroller: explicit\ndriver: !BaseTwist {}", "BaseTwist"),
    "unknown_field": ("embodment: h1", "bad.yaml"),
    "a_list": ("- embodiment: h1", "bad.yaml"),
    "yaml_syntax": ("embodiment: [h1", "bad.yaml"),
    "object_kind": ("objects: [{kind: piano}]", "objects[0].kind"),
    "object_position_nan": ("objects: [{kind: box, position: [.nan, 0, 1]}]", "objects[0].position"),
    "object_position_short": ("objects: [{kind: box, position: [0, 1]}]", "objects[0].position"),
    "object_position_far": ("objects: [{kind: box, position: [1e9, 0, 1]}]", "objects[0].position"),
    "object_target_inf": ("objects: [{kind: box, target: [.inf, 0, 1]}]", "objects[0].target"),
    "object_yaw_nan": ("objects: [{kind: box, yaw: .nan}]", "objects[0].yaw"),
    "object_fixed_and_held": ("objects: [{kind: box, fixed: true, held: true}]", "objects[0]"),
    "objects_same_name": ("objects: [{kind: box}, {kind: box}]", "objects"),
    "perturbation_time_negative": ("perturbations: [{time: -1.0}]", "perturbations[0].time"),
    "perturbation_time_nan": ("perturbations: [{time: .nan}]", "perturbations[0].time"),
    "perturbation_time_after_end": ("duration: 2.0\nperturbations: [{time: 9.0}]", "perturbations[0].time"),
    "perturbation_mass_nan": ("perturbations: [{mass: .nan}]", "perturbations[0].mass"),
    "perturbation_speed_zero": ("perturbations: [{speed: 0.0}]", "perturbations[0].speed"),
    "perturbation_size_huge": ("perturbations: [{size: 100.0}]", "perturbations[0].size"),
    "perturbation_start_short": ("perturbations: [{start: [1.0, 0.0]}]", "perturbations[0].start"),
    "catalogue_entry_not_mapping": ("first: 5\nsecond: {embodiment: h1}", "bad.yaml"),
}
for _name, (_text, _expect) in SCENARIO_FIELDS.items():

    def _make(tmp, text=_text):
        return "hotu_drake.simulate", [str(write(tmp, "bad.yaml", text + "\n")), "--duration", "0.05"]

    case(f"scenario_{_name}", "cli", _expect)(_make)


@case("scenario_reference_time_beyond_clip", "cli", "reference_time")
def _(tmp):
    text = (
        "embodiment: h1\nfixed_base: true\ninitial: {reference_time: 1000.0}\n"
        "driver: !ReferenceTracking {motion: walk}\n"
    )
    return "hotu_drake.simulate", [str(write(tmp, "late.yaml", text)), "--duration", "0.05"]


@case("scenario_reference_unknown_motion", "cli", "moonwalk")
def _(tmp):
    text = "embodiment: h1\ndriver: !ReferenceTracking {motion: moonwalk}\n"
    return "hotu_drake.simulate", [str(write(tmp, "moon.yaml", text)), "--duration", "0.05"]


for _value, _expect in (("nan", "--duration"), ("-1", "--duration"), ("1e9", "duration"), ("soon", "--duration")):

    def _make(tmp, value=_value):
        return "hotu_drake.simulate", ["stand_bruce", "--duration", value]

    case(f"simulate_duration_{_value}", "cli", _expect)(_make)


@case("simulate_unknown_name", "cli", "stand_atlas")
def _(tmp):
    return "hotu_drake.simulate", ["stand_atlas"]


@case("simulate_html_is_a_folder", "cli", "folder")
def _(tmp):
    (tmp / "folder").mkdir()
    return "hotu_drake.simulate", ["stand_bruce", "--duration", "0.05", "--html", str(tmp / "folder")]


@case("simulate_catalogue_unknown_entry", "cli", "perturb_atlas")
def _(tmp):
    from hotu_drake.resources import systems_dir

    return "hotu_drake.simulate", [str(systems_dir() / "perturb.yaml"), "--name", "perturb_atlas"]


@case("simulate_vary_range_reversed", "cli", "vary.drop_height")
def _(tmp):
    path = tmp / "family.yaml"
    path.write_text("embodiment: h1\nvary:\n  drop_height: [0.3, 0.1]\n")
    return "hotu_drake.simulate", [str(path), "--seed", "2"]


@case("simulate_vary_start_without_a_reference", "cli", "reference motion")
def _(tmp):
    path = tmp / "family.yaml"
    path.write_text("embodiment: h1\nvary:\n  reference_time: [0.0, 0.5]\n")
    return "hotu_drake.simulate", [str(path)]


def _whole_body_run(path: Path, driver: str, more: str = "") -> tuple[str, list[str]]:
    """`simulate` for 0.1 s on H1 under `!WholeBodyTracking {driver}`, started on its clip (`more`: further YAML)."""
    text = "embodiment: h1\ncontrol_rate: 60.0\ninitial: {reference_time: 0.0}\n"
    path.write_text(text + f"driver: !WholeBodyTracking {{{driver}}}\n" + more)
    return "hotu_drake.simulate", [str(path), "--duration", "0.1"]


@case("simulate_vary_start_beyond_the_clip", "cli", "beyond the")
def _(tmp):
    return _whole_body_run(tmp / "family.yaml", "motion: squat, loop: false", "vary:\n  reference_time: [0.0, 50.0]\n")


@case("simulate_vary_task_without_object", "cli", "vary.task")
def _(tmp):
    path = tmp / "family.yaml"
    path.write_text("embodiment: h1\nvary:\n  task: true\n")
    return "hotu_drake.simulate", [str(path)]


# --- checkpoints ---------------------------------------------------------------------------------


def _checkpoint(tmp: Path, name: str, change) -> Path:
    import torch

    from hotu_drake.learning.checkpoint import save_checkpoint
    from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork

    path = save_checkpoint(tmp / name, PolicyNetwork(PolicyConfig(5, 2, {}, (4,))), "bruce", "none")
    data = torch.load(path, weights_only=True)
    change(data)
    torch.save(data, path)
    return path


def _load_checkpoint(path):
    from hotu_drake.learning.checkpoint import load_checkpoint

    return lambda: load_checkpoint(path)


CHECKPOINT_CASES = {
    "config_lacks_fields": (lambda d: d["policy"]["config"].pop("action_size"), "action_size"),
    "config_hidden_text": (lambda d: d["policy"]["config"].update(hidden="big"), "config_hidden_text.pt"),
    "config_size_negative": (lambda d: d["policy"]["config"].update(observation_size=-5), "config_size_negative.pt"),
    "offset_wrong_length": (lambda d: d["policy"]["config"].update(action_offset=[0.1] * 3), "action_offset"),
    "weights_missing": (lambda d: d["policy"]["state_dict"].clear(), "weights_missing.pt"),
    "version_old": (lambda d: d.update(format_version=0), "format version"),
    "version_one": (lambda d: d.update(format_version=1), "format version 1"),
    "kind_unknown": (lambda d: d.update(kind="weights"), "kind"),
    "no_config": (lambda d: d["policy"].pop("config"), "no_config.pt"),
    "no_policy": (lambda d: d.pop("policy"), "no_policy.pt"),
}
for _name, (_change, _expect) in CHECKPOINT_CASES.items():

    def _make(tmp, change=_change, name=_name):
        return _load_checkpoint(_checkpoint(tmp, f"{name}.pt", change))

    case(f"checkpoint_{_name}", "api", _expect)(_make)


@case("checkpoint_garbage", "api", "garbage.pt")
def _(tmp):
    return _load_checkpoint(write(tmp, "garbage.pt", b"\x80\x04 not a pickle"))


@case("checkpoint_wrong_robot_in_scenario", "cli", "drives bruce")
def _(tmp):
    path = _checkpoint(tmp, "policy.pt", lambda d: None)
    text = f"embodiment: h1\ndriver: !PolicyCheckpoint {{checkpoint: {path}}}\n"
    return "hotu_drake.simulate", [str(write(tmp, "policy.yaml", text)), "--duration", "0.05"]


# --- environments ------------------------------------------------------------------------------

ENV_KEYWORDS = {
    "robot_unknown": ({"robot": "atlas"}, "robot"),
    "hands_unknown": ({"hands": "half"}, "hands"),
    "amp_history_zero": ({"amp_history": 0}, "amp_history"),
    "amp_history_huge": ({"amp_history": 10**9}, "amp_history"),
    "amp_history_fraction": ({"amp_history": 2.5}, "amp_history"),
    "amp_history_text": ({"amp_history": "10"}, "amp_history"),
    "reference_probability_two": ({"reference_init_probability": 2.0}, "reference_init_probability"),
    "reference_probability_nan": ({"reference_init_probability": float("nan")}, "reference_init_probability"),
    "drop_height_negative": ({"drop_height": -1.0}, "drop_height"),
    "termination_height_above_one": ({"termination_height": 1.5}, "termination_height"),
    "time_step_zero": ({"time_step": 0.0}, "time_step"),
    "time_step_nan": ({"time_step": float("nan")}, "time_step"),
    "time_step_text": ({"time_step": "small"}, "time_step"),
    "control_rate_zero": ({"control_rate": 0.0}, "control_rate"),
    "control_rate_uneven": ({"control_rate": 7.0}, "control_rate"),
    "motions_unknown": ({"motions": ["moonwalk"]}, "moonwalk"),
    "motions_empty": ({"motions": []}, "motions"),
    "motions_number": ({"motions": 5}, "motions"),
    "scenario_unknown": ({"scenario": "stand_atlas"}, "stand_atlas"),
    "sampled_output_ports_text": ({"sampled_output_ports": "yes"}, "sampled_output_ports"),
}
for _name, (_keywords, _expect) in ENV_KEYWORDS.items():

    def _make(tmp, keywords=_keywords):
        import gymnasium as gym

        import hotu_drake.envs  # noqa: F401

        return lambda: gym.make("hotu_drake/Imitation-v0", **{"robot": "bruce", "motions": ["squat"], **keywords})

    case(f"env_{_name}", "api", _expect)(_make)

TASK_KEYWORDS = {
    "box_start_distance_reversed": ("BoxCarry-v0", {"start_distance": (2.0, 1.0)}, "start_distance"),
    "box_start_distance_nan": ("BoxCarry-v0", {"start_distance": (float("nan"), 1.0)}, "start_distance"),
    "box_target_bearing_short": ("BoxCarry-v0", {"target_bearing": (1.0,)}, "target_bearing"),
    "box_carry_height_text": ("BoxCarry-v0", {"carry_height": "high"}, "carry_height"),
    "drill_table_distance_negative": ("DrillGrasp-v0", {"table_distance": -1.0}, "table_distance"),
    "drill_lift_height_far": ("DrillGrasp-v0", {"lift_height": (0.1, 50.0)}, "lift_height"),
}
for _name, (_id, _keywords, _expect) in TASK_KEYWORDS.items():

    def _make(tmp, env_id=_id, keywords=_keywords):
        import gymnasium as gym

        import hotu_drake.envs  # noqa: F401

        return lambda: gym.make(f"hotu_drake/{env_id}", robot="bruce", motions=["squat"], **keywords)

    case(f"env_{_name}", "api", _expect)(_make)


@cache
def bruce_env():
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401

    return gym.make("hotu_drake/Imitation-v0", robot="bruce", motions=["squat"]).unwrapped


RESET_OPTIONS = {
    "init_sideways": ({"init": "sideways"}, "init"),
    "clip_out_of_range": ({"init": "reference", "clip": 99}, "clip"),
    "clip_negative": ({"init": "reference", "clip": -1}, "clip"),
    "clip_text": ({"init": "reference", "clip": "first"}, "clip"),
    "time_negative": ({"init": "reference", "time": -1.0}, "time"),
    "time_beyond_clip": ({"init": "reference", "time": 1e9}, "time"),
    "time_nan": ({"init": "reference", "time": float("nan")}, "time"),
    "unknown_option": ({"speed": 2.0}, "speed"),
}
for _name, (_options, _expect) in RESET_OPTIONS.items():

    def _make(tmp, options=_options):
        env = bruce_env()
        return lambda: env.reset(seed=0, options=options)

    case(f"reset_{_name}", "api", _expect)(_make)

STEP_ACTIONS = {
    "wrong_shape": (lambda n: np.zeros(n + 1), "action"),
    "nan": (lambda n: np.full(n, np.nan), "action"),
    "text": (lambda n: ["a"] * n, "action"),
}
for _name, (_action, _expect) in STEP_ACTIONS.items():

    def _make(tmp, action=_action):
        env = bruce_env()
        env.reset(seed=0)
        return lambda: env.step(action(env.action_space.shape[0]))

    case(f"step_{_name}", "api", _expect)(_make)


# --- other command lines ---------------------------------------------------------------------------

OTHER_CLI = {
    "bench_time_step_tiny": ("hotu_drake.bench", ["standing", "--time-step", "1e-9"], "--time-step"),
    "bench_steps_too_many": ("hotu_drake.bench", ["standing", "--time-step", "1e-5", "--seconds", "3000"], "--seconds"),
    "bench_seconds_nan": ("hotu_drake.bench", ["standing", "--seconds", "nan"], "--seconds"),
    "bench_robot_unknown": ("hotu_drake.bench", ["standing", "--robot", "atlas"], "atlas"),
    "bench_envs_zero": ("hotu_drake.bench", ["env", "--envs", "0"], "--envs"),
    "bench_env_seconds_huge": ("hotu_drake.bench", ["env", "--seconds", "1e9"], "--seconds"),
    "bench_retarget_missing_input": ("hotu_drake.bench", ["retarget", "--input", "/nonexistent/walk.bvh"], "walk.bvh"),
    "bench_retarget_pairs_negative": ("hotu_drake.bench", ["retarget", "--peer", "mink", "--pairs", "-1"], "--pairs"),
    "bench_readers_missing_input": ("hotu_drake.bench", ["readers", "--input", "/nonexistent/walk.bvh"], "walk.bvh"),
    "bench_readers_repeats_zero": ("hotu_drake.bench", ["readers", "--repeats", "0"], "--repeats"),
    "bench_clips_unknown_motion": ("hotu_drake.bench", ["clips", "--motions", "moonwalk"], "moonwalk"),
    "bench_clips_missing_input": ("hotu_drake.bench", ["clips", "--motions", "--input", "/nonexistent/w.bvh"], "w.bvh"),
    "bench_clips_unknown_robot": ("hotu_drake.bench", ["clips", "--robots", "atlas"], "atlas"),
    "models_export_unknown": ("hotu_drake.models", ["export", "atlas", "--format", "sdf", "--out", "x.sdf"], "atlas"),
    "models_export_height_negative": (
        "hotu_drake.models",
        ["export", "udh", "--format", "sdf", "--height", "-1", "--out", "x.sdf"],
        "--height",
    ),
    "models_export_height_giant": (
        "hotu_drake.models",
        ["export", "udh", "--format", "sdf", "--height", "40", "--out", "x.sdf"],
        "height",
    ),
}
for _name, (_module, _argv, _expect) in OTHER_CLI.items():

    def _make(tmp, module=_module, argv=_argv):
        return module, [str(tmp / a) if a == "x.sdf" else a for a in argv]

    case(_name, "cli", _expect)(_make)


# --- the trainer ---------------------------------------------------------------------------------

PRETRAIN = ["pretrain", "--robot", "bruce", "--motions", "squat", "--steps", "64", "--workers", "1"]
TRAIN_CLI = {
    "robot_unknown": (["pretrain", "--robot", "atlas", "--motions", "wave", "--steps", "10"], "atlas"),
    "motion_unknown": (["pretrain", "--robot", "bruce", "--motions", "moonwalk", "--steps", "10"], "moonwalk"),
    "algo_unknown": ([*PRETRAIN, "--algo", "gail"], "gail"),
    "steps_zero": (["pretrain", "--robot", "bruce", "--motions", "squat", "--steps", "0"], "--steps"),
    "workers_zero": ([*PRETRAIN, "--workers", "0"], "--workers"),
    "config_missing": ([*PRETRAIN, "--config", "/nonexistent/tiny.yaml"], "tiny.yaml"),
}
for _name, (_argv, _expect) in TRAIN_CLI.items():

    def _make(tmp, argv=_argv):
        return "hotu_drake.train", [*argv, "--out", str(tmp / "run")]

    case(f"train_{_name}", "cli", _expect)(_make)


@case("train_config_unknown_field", "cli", "horizn")
def _(tmp):
    config = write(tmp, "tiny.yaml", "ppo: {horizn: 32}\n")
    return "hotu_drake.train", [*PRETRAIN, "--config", str(config), "--out", str(tmp / "run")]


@case("train_config_not_a_number", "cli", "learning_rate")
def _(tmp):
    config = write(tmp, "tiny.yaml", "ppo: {learning_rate: fast}\n")
    return "hotu_drake.train", [*PRETRAIN, "--config", str(config), "--out", str(tmp / "run")]


@case("train_resume_nothing", "cli", "no run")
def _(tmp):
    return "hotu_drake.train", ["pretrain", "--steps", "10", "--resume", "--out", str(tmp / "run")]


def _run_folder(tmp: Path, robot: str, change=None) -> Path:
    """A run folder whose checkpoint holds a tiny policy (`change` edits its dictionary)."""
    import torch

    from hotu_drake.learning.checkpoint import save_checkpoint
    from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork

    run = tmp / "run"
    run.mkdir()
    settings = {"robot": robot, "hands": "none", "motions": ["squat"], "algo": "dail", "seed": 0}
    (run / "run.json").write_text(json.dumps(settings))
    path = save_checkpoint(run / "checkpoint.pt", PolicyNetwork(PolicyConfig(5, 2, {}, (4,))), robot, "none", {})
    if change is not None:
        data = torch.load(path, weights_only=True)
        change(data)
        torch.save(data, path)
    return run


@case("train_resume_old_format", "cli", "format version 1")
def _(tmp):
    run = _run_folder(tmp, "bruce", lambda d: d.update(format_version=1))
    return "hotu_drake.train", ["pretrain", "--steps", "10", "--resume", "--out", str(run)]


@case("train_resume_policy_checkpoint", "cli", "cannot resume")
def _(tmp):
    run = _run_folder(tmp, "bruce")
    return "hotu_drake.train", ["pretrain", "--steps", "10", "--resume", "--out", str(run)]


@case("train_resume_other_robot", "cli", "--robot")
def _(tmp):
    run = _run_folder(tmp, "h1", lambda d: d.update(kind="training", state={}))
    return "hotu_drake.train", ["pretrain", "--robot", "bruce", "--steps", "10", "--resume", "--out", str(run)]


@case("train_evaluate_not_a_run", "cli", "not a run folder")
def _(tmp):
    return "hotu_drake.train", ["evaluate", str(tmp)]


@case("train_trace_not_a_run", "cli", "not a run folder")
def _(tmp):
    return "hotu_drake.train", ["trace", str(tmp), "--out", str(tmp / "trace.png")]


SKILL = ["skill", "--task", "box_carry", "--steps", "16", "--workers", "1"]


def _controller_run(tmp: Path, robot: str = "udh", algo: str = "dail") -> Path:
    """A behavior run folder of `robot` whose checkpoint a skill could drive (tiny networks)."""
    import numpy as np

    from hotu_drake.learning.checkpoint import save_checkpoint
    from hotu_drake.learning.config import preset
    from hotu_drake.learning.low_level import _style_networks
    from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork
    from hotu_drake.learning.parts import PartGroup

    run = tmp / "llc"
    run.mkdir()
    config = preset(algo)
    config.latent.size, config.networks.discriminator_hidden = 4, (4,)
    groups = [PartGroup("lower_body", {"root": np.array([0, 1])})]
    meta = {"algo": algo, "groups": [g.to_dict() for g in groups], "config": config.to_dict()}
    policy = PolicyNetwork(PolicyConfig(5, 2, {"lower_body": 4}, (4,)))
    state = {"style": _style_networks(groups, config).state_dict()}
    (run / "run.json").write_text(json.dumps({"robot": robot, "hands": "none", "algo": algo}))
    save_checkpoint(run / "checkpoint.pt", policy, robot, "none", meta, state=state)
    return run


SKILL_CLI = {
    "task_unknown": (["skill", "--task", "juggle", "--steps", "16", "--algo", "amp"], "juggle"),
    "llc_missing": ([*SKILL, "--algo", "ours"], "--llc"),
    "algo_unknown": ([*SKILL, "--algo", "hrl"], "hrl"),
}
for _name, (_argv, _expect) in SKILL_CLI.items():

    def _make(tmp, argv=_argv):
        return "hotu_drake.train", [*argv, "--out", str(tmp / "run")]

    case(f"skill_{_name}", "cli", _expect)(_make)


@case("skill_llc_for_a_one_level_method", "cli", "one level")
def _(tmp):
    return "hotu_drake.train", [*SKILL, "--algo", "amp", "--llc", str(_controller_run(tmp)), "--out", str(tmp / "run")]


@case("skill_llc_of_another_robot", "cli", "a controller of udh")
def _(tmp):
    llc = str(_controller_run(tmp))
    return "hotu_drake.train", [*SKILL, "--robot", "h1", "--llc", llc, "--out", str(tmp / "run")]


@case("skill_llc_of_another_method", "cli", "a dail controller")
def _(tmp):
    return "hotu_drake.train", [*SKILL, "--algo", "ase", "--llc", str(_controller_run(tmp)), "--out", str(tmp / "run")]


@case("skill_llc_not_a_behavior_run", "cli", "not a behavior run")
def _(tmp):
    run = _run_folder(tmp, "udh", lambda d: d.update(kind="training", state={}))
    return "hotu_drake.train", [*SKILL, "--llc", str(run), "--out", str(tmp / "skill")]


@case("skill_demonstrations_without_the_drill", "cli", "carries a drill track")
def _(tmp):
    argv = ["skill", "--task", "drill_grasp", "--steps", "16", "--workers", "1", "--motions", "walk"]
    return "hotu_drake.train", [*argv, "--llc", str(_controller_run(tmp)), "--out", str(tmp / "run")]


@case("skill_config_hold_steps_zero", "cli", "hold_steps")
def _(tmp):
    config = write(tmp, "skill.yaml", "high_level: {hold_steps: 0}\n")
    return "hotu_drake.train", [*SKILL, "--algo", "amp", "--config", str(config), "--out", str(tmp / "run")]


@case("skill_task_keyword_unknown", "cli", "environment.task")
def _(tmp):
    config = write(tmp, "skill.yaml", "environment: {task: {start_distanse: [1.0, 2.0]}}\n")
    return "hotu_drake.train", [*SKILL, "--algo", "amp", "--config", str(config), "--out", str(tmp / "run")]


FINETUNE = ["finetune", "--steps", "16", "--workers", "1"]


def _skill_run(tmp: Path, algo: str = "ours") -> Path:
    """A skill run folder with what `finetune` checks before recording (the files, not trained networks)."""
    skill = tmp / "udh_box"
    skill.mkdir()
    controller = tmp / "udh_dail"
    controller.mkdir()
    (controller / "policy.pt").write_bytes(b"")
    settings = {"command": "skill", "task": "box_carry", "robot": "udh", "algo": algo, "llc": str(controller)}
    (skill / "run.json").write_text(json.dumps(settings))
    for name in ("policy.pt", "config.yaml"):
        (skill / name).write_bytes(b"")
    return skill


@case("finetune_skill_missing", "cli", "needs --skill")
def _(tmp):
    return "hotu_drake.train", [*FINETUNE, "--llc", str(_controller_run(tmp, "h1")), "--out", str(tmp / "run")]


@case("finetune_skill_not_a_run", "cli", "not a skill run folder")
def _(tmp):
    llc = str(_controller_run(tmp, "h1"))
    return "hotu_drake.train", [*FINETUNE, "--skill", str(tmp), "--llc", llc, "--out", str(tmp / "run")]


@case("finetune_skill_one_level", "cli", "not a two-level")
def _(tmp):
    skill, llc = str(_skill_run(tmp, "amp")), str(_controller_run(tmp, "h1"))
    return "hotu_drake.train", [*FINETUNE, "--skill", skill, "--llc", llc, "--out", str(tmp / "run")]


@case("finetune_llc_of_another_method", "cli", "drives a dail one")
def _(tmp):
    skill, llc = str(_skill_run(tmp)), str(_controller_run(tmp, "h1", "ase"))
    return "hotu_drake.train", [*FINETUNE, "--skill", skill, "--llc", llc, "--out", str(tmp / "run")]


@case("finetune_references_zero", "cli", "--references")
def _(tmp):
    skill, llc = str(_skill_run(tmp)), str(_controller_run(tmp, "h1"))
    argv = [*FINETUNE, "--skill", skill, "--llc", llc, "--references", "0", "--out", str(tmp / "run")]
    return "hotu_drake.train", argv


@case("evaluate_not_a_run", "cli", "not a run folder")
def _(tmp):
    return "hotu_drake.evaluate", ["primitives", "--runs", str(tmp / "none"), "--out", str(tmp / "out")]


@case("evaluate_momenta_not_numbers", "cli", "--momenta")
def _(tmp):
    argv = ["perturbation", "--runs", str(tmp), "--momenta", "2,heavy", "--out", str(tmp / "out")]
    return "hotu_drake.evaluate", argv


@case("evaluate_ablation_not_png", "cli", ".png")
def _(tmp):
    return "hotu_drake.evaluate", ["ablation", "--runs", str(tmp), "--out", str(tmp / "ablation.pdf")]


def corpus_summary() -> dict[str, int]:
    """How many cases of each family (the README records it)."""
    families: dict[str, int] = {}
    for c in CASES:
        family = c.id.split("_")[0]
        families[family] = families.get(family, 0) + 1
    return families


@case("simulate_lead_in_too_long", "cli", "lead_in")
def _(tmp):
    return _whole_body_run(tmp / "long_wait.yaml", "motion: squat, loop: false, lead_in: 600.0")


@case("simulate_lead_in_on_a_loop", "cli", "lead_in")
def _(tmp):
    return _whole_body_run(tmp / "looped_wait.yaml", "motion: walk, loop: true, lead_in: 0.5")


if __name__ == "__main__":
    print(json.dumps({"cases": len(CASES), **corpus_summary()}, indent=2))
