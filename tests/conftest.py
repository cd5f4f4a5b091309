"""Shared fixtures and paths for the test suite."""

import os
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"

# One core per process keeps timings and contact solves comparable.
os.environ.setdefault("OMP_NUM_THREADS", "1")
# Retargeted reference clips are cached per test run, not in the user's home
# (worker processes inherit this).
os.environ.setdefault("HOTU_DRAKE_CACHE", tempfile.mkdtemp(prefix="hotu_drake_test_cache_"))


@pytest.fixture
def mujoco(tmp_path, monkeypatch):
    """MuJoCo, run in a temporary working directory (it writes MUJOCO_LOG.TXT
    into the current one when a simulation goes unstable); skips without it."""
    module = pytest.importorskip("mujoco")
    monkeypatch.chdir(tmp_path)
    return module


@pytest.fixture
def drake_warnings(caplog):
    """Collect Drake's log messages at warning level and above."""
    caplog.set_level("WARNING", logger="drake")
    return caplog
