"""Bad input never crashes, hangs or passes silently (the corpus in tests/bad_inputs.py).

Every case runs under a time limit. A command line must print exactly one
`error:` line naming the file or field, no traceback and no "internal
error", exit with 2, and leave no new file behind; the Python API must
raise `InputError` naming the file or field.
"""

import contextlib
import dataclasses
import importlib
import io
import json

import numpy as np
import pytest

from hotu_drake.cli import run_cli
from hotu_drake.errors import InputError
from tests.bad_inputs import CASES
from tests.limits import time_limit

TIME_LIMIT = 60  # s per case: a hang fails the case instead of the suite


def _files(folder) -> set:
    return {p for p in folder.rglob("*") if p.is_file()}


def _main(module: str):
    try:
        return importlib.import_module(f"{module}.__main__").main
    except ModuleNotFoundError:
        return importlib.import_module(module).main


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_refused_in_one_line(case, tmp_path):
    made = case.make(tmp_path)
    before = _files(tmp_path)
    if case.kind == "api":
        with time_limit(TIME_LIMIT), pytest.raises(InputError) as refused:
            made()
        message = str(refused.value)
        assert "\n" not in message.strip(), message
    else:
        module, argv = made
        stderr, stdout = io.StringIO(), io.StringIO()
        with time_limit(TIME_LIMIT), contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(stdout):
            code = run_cli(_main(module), argv)
        lines = stderr.getvalue().splitlines()
        errors = [line for line in lines if line.startswith("error:")]
        assert code == 2, stderr.getvalue()
        assert len(errors) == 1, stderr.getvalue()
        assert "Traceback" not in stderr.getvalue() and "internal error" not in errors[0]
        message = errors[0]
    assert case.expect in message, message
    assert _files(tmp_path) == before, "a file was left behind"


def test_the_corpus_is_large_and_covers_every_boundary():
    from tests.bad_inputs import corpus_summary

    families = corpus_summary()
    assert len(CASES) >= 150
    assert {"bvh", "c3d", "npz", "csv", "scenario", "marker", "env", "reset", "step", "checkpoint", "bench"} <= set(
        families
    )


def _retarget(argv: list[str]) -> tuple[int, list[str]]:
    """Run the retarget command in this process: its exit code and `error:` lines."""
    stderr = io.StringIO()
    with time_limit(TIME_LIMIT), contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        code = run_cli(_main("hotu_drake.retarget"), argv)
    return code, [line for line in stderr.getvalue().splitlines() if line.startswith("error:")]


def test_a_run_whose_every_input_is_refused_writes_nothing(tmp_path):
    from tests.bad_inputs import bvh_text, write

    bad = [write(tmp_path, "empty.bvh", ""), write(tmp_path, "cut.bvh", bvh_text()[:200])]
    before = _files(tmp_path)
    argv = [*map(str, bad), "--robot", "bruce", "--out", str(tmp_path / "out")]
    code, errors = _retarget([*argv, "--report", str(tmp_path / "report.json"), "--html", str(tmp_path / "r.html")])
    assert code == 2 and len(errors) == 2 and "empty.bvh" in errors[0] and "cut.bvh" in errors[1], errors
    assert _files(tmp_path) == before


def test_a_bad_input_among_good_ones_is_skipped_and_reported(tmp_path):
    """Some inputs read: their clips and the report (with the refusals) are written, and the exit code is 2."""
    from tests.bad_inputs import bvh_text, write

    good, bad = write(tmp_path, "good.bvh", bvh_text()), write(tmp_path, "bad.bvh", "")
    report = tmp_path / "report.json"
    argv = [str(good), str(bad), "--robot", "bruce", "--out", str(tmp_path / "out"), "--report", str(report)]
    code, errors = _retarget(argv)
    assert code == 2 and len(errors) == 1 and "bad.bvh" in errors[0], errors
    assert {p.name for p in (tmp_path / "out").iterdir()} == {"good_bruce.npz"}
    figures = json.loads(report.read_text())
    assert list(figures["clips"]) == ["good"] and len(figures["errors"]) == 1 and "bad.bvh" in figures["errors"][0]


def test_allow_implausible_takes_a_body_on_its_side(tmp_path):
    from tests.bad_inputs import upper_body_bvh

    bvh, skeleton_map = upper_body_bvh(tmp_path)
    argv = [str(bvh), "--robot", "udh", "--out", str(tmp_path / "out"), "--skeleton-map", str(skeleton_map)]
    code, errors = _retarget([*argv, "--up", "x"])
    assert code == 2 and len(errors) == 1 and "upright" in errors[0], errors
    assert _retarget([*argv, "--up", "x", "--allow-implausible"]) == (0, [])
    assert (tmp_path / "out" / "upper_body_udh.npz").is_file()


def test_a_body_that_stands_up_at_some_time_is_upright():
    """A capture that lies down, or gets up, passes; one upright in no frame does not (upper body only: its
    height is the arm span, so only the upright check can refuse it)."""
    import numpy as np

    from hotu_drake.motion.human import human_clip, landmarks_of
    from hotu_drake.motion.library.generate import generate
    from hotu_drake.motion.load import check_human_motion
    from tests.bad_inputs import LEGS

    clip = generate("squat", fps=120.0)
    points = {name: p for name, p in landmarks_of(clip).items() if name not in LEGS}
    turn = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # a quarter turn about x
    pelvis = points["pelvis"]
    lying = {name: np.einsum("ij,tj->ti", turn, p - pelvis) + pelvis for name, p in points.items()}
    for standing, upright in ((0, False), (1, True), (clip.num_frames // 2, True)):
        mixed = human_clip({n: np.concatenate([p[:standing], lying[n][standing:]]) for n, p in points.items()}, 30, "m")
        if upright:
            check_human_motion(mixed, "mixed")
        else:
            with pytest.raises(InputError, match="mixed: .*upright"):
                check_human_motion(mixed, "mixed")


def test_library_motions_are_plausible():
    """Every generated motion (box_carry leans almost 50 degrees to lift the box) passes the input checks."""
    from hotu_drake.motion.library.generate import MOTIONS, generate
    from hotu_drake.motion.load import check_human_motion

    for name in MOTIONS:
        check_human_motion(generate(name), name)


def test_an_output_that_cannot_be_made_is_refused_before_the_work(tmp_path, monkeypatch):
    """What permission bits do not show (a full or read-only file system) is found by trying: the folders
    the try made are removed again."""
    import errno
    import tempfile

    from hotu_drake.io import check_output_path

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    assert check_output_path(tmp_path / "new" / "report.json") == tmp_path / "new" / "report.json"
    monkeypatch.setattr(tempfile, "mkstemp", full)
    with pytest.raises(InputError, match="report.json: cannot write here .No space left on device"):
        check_output_path(tmp_path / "new" / "deeper" / "report.json")
    with pytest.raises(InputError, match="out: cannot write here"):
        check_output_path(tmp_path / "out", folder=True)
    assert list(tmp_path.iterdir()) == []


def test_a_write_that_fails_removes_the_other_outputs(tmp_path, monkeypatch):
    import errno

    from hotu_drake.retarget import replay
    from tests.bad_inputs import bvh_text, write

    def full(path, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(replay, "write_replay", full)
    bvh = write(tmp_path, "ok.bvh", bvh_text())
    before = _files(tmp_path)
    argv = [str(bvh), "--robot", "bruce", "--out", str(tmp_path / "out"), "--report", str(tmp_path / "report.json")]
    code, errors = _retarget([*argv, "--html", str(tmp_path / "replay.html")])
    assert code == 2 and errors == [f"error: {tmp_path / 'replay.html'}: No space left on device"], errors
    assert _files(tmp_path) == before


def test_a_capture_s_jumping_first_frame_is_dropped_and_said(tmp_path, caplog):
    """A human clip whose first frame has the wrists half a metre off (a
    conversion's T-pose frame) loads without it, and a note says so; a clip
    without one keeps every frame."""
    import logging

    from hotu_drake.motion.library import generate
    from hotu_drake.motion.load import MAX_LANDMARK_SPEED, load_motion

    clip = generate("squat", fps=120.0)
    keys = clip.key_body_positions.copy()
    for name in ("left_wrist", "right_wrist", "left_hand", "right_hand"):
        keys[0, clip.key_body_names.index(name), 2] += 0.5  # arms out
    glitched = dataclasses.replace(clip, key_body_positions=keys)
    assert 0.5 * clip.fps > MAX_LANDMARK_SPEED
    with caplog.at_level(logging.INFO, logger="hotu_drake.input"):
        loaded = load_motion(glitched.save(tmp_path / "glitched.npz"))
    assert loaded.num_frames == clip.num_frames - 1
    np.testing.assert_allclose(loaded.key_body_positions, clip.key_body_positions[1:])
    assert any("its first 1 frame(s) dropped" in record.getMessage() for record in caplog.records)
    assert load_motion(clip.save(tmp_path / "calm.npz")).num_frames == clip.num_frames
