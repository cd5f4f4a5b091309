"""Bad input never crashes, hangs or passes silently (the corpus in tests/bad_inputs.py).

Every case runs under a time limit. A command line must print exactly one
`error:` line naming the file or field, no traceback and no "internal
error", exit with 2, and leave no new file behind; the Python API must
raise `InputError` naming the file or field.
"""

import contextlib
import importlib
import io

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
