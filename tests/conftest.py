"""Shared fixtures and paths for the test suite."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"

# One core per process keeps timings and contact solves comparable.
os.environ.setdefault("OMP_NUM_THREADS", "1")


@pytest.fixture
def drake_warnings(caplog):
    """Collect Drake's log messages at warning level and above."""
    caplog.set_level("WARNING", logger="drake")
    return caplog
