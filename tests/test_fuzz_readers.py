"""Property-based fuzzing of the readers: random mutations of valid files
(BVH, C3D, clip .npz, OptiTrack CSV, scenario YAML) give a valid result or
the project's `InputError`, never another exception, a crash or a hang.

C3D files are read by ezc3d (C++); the reader keeps it in a child process,
so a file that crashes ezc3d is one more refused input here.
"""

import contextlib
import io
import os
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hotu_drake.errors import InputError
from tests import bad_inputs
from tests.limits import time_limit

EXAMPLES = 200
TIME_LIMIT = 20  # s per example
# Derandomised: the same examples every run (a regression test, not a flaky one); `HYPOTHESIS_SEARCH=1`
# explores new ones.
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=not os.environ.get("HYPOTHESIS_SEARCH"),
    database=None,
    suppress_health_check=list(HealthCheck),
)
TOKENS = ["nan", "inf", "-1", "0", "1e309", "1e-320", "", "abc", "{", "}", "-", ":", "99999999", "\x00", "[", "]"]


def _mutate_text(text: str, edits) -> str:
    """Replace, delete, duplicate or cut at tokens (whitespace-separated) and characters."""
    for kind, where, token in edits:
        if not text:
            break
        at = where % len(text)
        if kind == "replace_token":
            end = at
            while end < len(text) and not text[end].isspace():
                end += 1
            text = text[:at] + token + text[end:]
        elif kind == "insert":
            text = text[:at] + token + text[at:]
        elif kind == "delete_line":
            start, end = text.rfind("\n", 0, at) + 1, text.find("\n", at)
            text = text[:start] + (text[end + 1 :] if end >= 0 else "")
        elif kind == "duplicate_line":
            start, end = text.rfind("\n", 0, at) + 1, text.find("\n", at)
            line = text[start : end + 1 if end >= 0 else len(text)]
            text = text[:start] + line + line + text[start + len(line) :]
        else:  # cut
            text = text[:at]
    return text


def _mutate_bytes(data: bytes, edits) -> bytes:
    data = bytearray(data)
    for kind, where, value in edits:
        if not data:
            break
        at = where % len(data)
        if kind == "flip":
            data[at] = value % 256
        elif kind == "delete":
            del data[at : at + 1 + value % 64]
        elif kind == "insert":
            data[at:at] = bytes([value % 256]) * (1 + value % 16)
        else:  # cut
            del data[at:]
    return bytes(data)


TEXT_EDITS = st.lists(
    st.tuples(
        st.sampled_from(["replace_token", "insert", "delete_line", "duplicate_line", "cut"]),
        st.integers(0, 10**9),
        st.sampled_from(TOKENS),
    ),
    min_size=1,
    max_size=6,
)
BYTE_EDITS = st.lists(
    st.tuples(
        st.sampled_from(["flip", "flip", "flip", "delete", "insert", "cut"]),
        st.integers(0, 10**9),
        st.integers(0, 10**6),
    ),
    min_size=1,
    max_size=6,
)


def _valid_or_refused(read) -> None:
    """`read()` returns, or raises InputError with a one-line message."""
    with time_limit(TIME_LIMIT), contextlib.redirect_stderr(io.StringIO()):
        try:
            read()
        except InputError as error:
            assert "\n" not in str(error).strip()


def _in_file(suffix: str, content) -> Path:
    folder = Path(tempfile.mkdtemp(prefix="fuzz_"))
    path = folder / f"input{suffix}"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8", errors="surrogateescape")
    return path


@FUZZ
@given(edits=TEXT_EDITS)
def test_bvh_reader(edits):
    from hotu_drake.motion.load import load_motion

    path = _in_file(".bvh", _mutate_text(bad_inputs.bvh_text(), edits))
    _valid_or_refused(lambda: load_motion(path))


@FUZZ
@given(edits=TEXT_EDITS)
def test_optitrack_reader(edits):
    from hotu_drake.motion.optitrack import read_optitrack_csv

    path = _in_file(".csv", _mutate_text(bad_inputs.csv_text(), edits))
    _valid_or_refused(lambda: read_optitrack_csv(path))


@FUZZ
@given(edits=TEXT_EDITS)
def test_scenario_reader(edits):
    from hotu_drake.resources import systems_dir
    from hotu_drake.scenario import load_scenario

    text = (systems_dir() / "box_udh.yaml").read_text() + "perturbations: [{time: 1.0, speed: 3.0}]\n"
    path = _in_file(".yaml", _mutate_text(text, edits))
    _valid_or_refused(lambda: load_scenario(path))


@FUZZ
@given(edits=BYTE_EDITS)
def test_clip_reader(edits):
    from hotu_drake.motion.load import load_motion

    base = bad_inputs.save_npz(Path(tempfile.mkdtemp(prefix="fuzz_")), "ok.npz").read_bytes()
    path = _in_file(".npz", _mutate_bytes(base, edits))
    _valid_or_refused(lambda: load_motion(path))


@settings(FUZZ, max_examples=EXAMPLES // 2)
@given(edits=BYTE_EDITS)
def test_c3d_reader(edits):
    """In this process: the reader itself keeps ezc3d in a child with a time and memory limit."""
    from hotu_drake.motion.load import load_motion

    path = _in_file(".c3d", _mutate_bytes(bad_inputs.c3d_bytes(), edits))
    _valid_or_refused(lambda: load_motion(path))
