"""The plant's defaults hold their measured fidelity (bench fidelity, BENCHMARKS.md):
at the default step and near-rigid threshold, a standing, pushed and squatting
robot stays up and within the harness's bound of a fine-step reference; at
Drake's own default threshold the same step lets it fall."""

import numpy as np
import pytest

from hotu_drake.bench.fidelity import ERROR_BOUND_MM, Setting, run_trial
from hotu_drake.scenario import DEFAULT_NEAR_RIGID_THRESHOLD, DEFAULT_TIME_STEP

DEFAULT = Setting(DEFAULT_TIME_STEP, DEFAULT_NEAR_RIGID_THRESHOLD)
REFERENCE = Setting(1.0 / 720.0, DEFAULT_NEAR_RIGID_THRESHOLD)


@pytest.mark.parametrize("robot, trial", [("h1", "stand"), ("h1", "push"), ("bruce", "squat")])
def test_the_default_plant_stays_within_its_bound_of_a_fine_step(robot, trial):
    result, truth = run_trial(robot, trial, DEFAULT), run_trial(robot, trial, REFERENCE)
    assert not result["figures"]["fell"] and not truth["figures"]["fell"]
    error = 1000 * np.sqrt(np.mean(np.sum((result["track"] - truth["track"]) ** 2, axis=-1)))
    assert error <= ERROR_BOUND_MM, f"{robot} {trial}: {error:.1f} mm"


@pytest.mark.parametrize("robot, trial", [("bruce", "stand"), ("h1", "squat")])
def test_drakes_default_threshold_would_let_robots_fall_at_the_default_step(robot, trial):
    assert not run_trial(robot, trial, DEFAULT)["figures"]["fell"]
    assert run_trial(robot, trial, Setting(DEFAULT_TIME_STEP, 1.0))["figures"]["fell"]
