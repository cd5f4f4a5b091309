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
