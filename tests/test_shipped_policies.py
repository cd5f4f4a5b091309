"""The learned policies shipped in systems/policies/ load and run in their
scenarios (`make demo` replays them)."""

import numpy as np
import pytest

from hotu_drake.diagrams import run_scenario as run
from hotu_drake.learning.checkpoint import read_checkpoint
from hotu_drake.scenario import load_scenario, shipped_scenarios

LEARNED = sorted(n for n in shipped_scenarios() if n.startswith("learned_"))


def test_there_are_shipped_policies():
    assert LEARNED, "no learned_* scenario in systems/"


@pytest.mark.parametrize("name", LEARNED)
def test_a_shipped_policy_loads_and_keeps_its_robot_up(name):
    scenario = load_scenario(name)
    path = scenario.resolve(scenario.driver.checkpoint)
    checkpoint = read_checkpoint(path, kind="policy")
    assert checkpoint["embodiment"] == scenario.embodiment
    assert path.stat().st_size < 5e6  # small enough to ship
    figures = run(scenario, 2.0)
    assert not figures["fell"] and figures["max_torque_ratio"] <= 1.0 + 1e-9
    assert np.isfinite(figures["min_pelvis_height"])


def test_the_shipped_walk_follows_its_clip_without_the_teacher():
    """`learned_h1_walk` (a clone of the whole-body controller, asked for
    the walk by name) walks on its own: 4 s from the standing pose,
    upright, covering more than half the walk's travel (measured over the
    scenario's 10 s: 4.2 m of the walk's 5.1 m, RESULTS.md section 12)."""
    figures = run(load_scenario("learned_h1_walk"), 4.0)
    assert not figures["fell"] and figures["reference_travel_m"] > 1.5
    assert figures["root_travel_m"] > 0.5 * figures["reference_travel_m"], figures
