"""Every shipped scenario builds and runs; its outcome is pinned.

tests/data/scenario_states.json holds each scenario's positions and
velocities after 0.5 s (rounded to 6 decimals); a run must end within
POSITION_TOLERANCE and VELOCITY_TOLERANCE of them. The tolerances are far
above what another machine's floating-point last bits move (a different
BLAS or FMA moves a 0.5 s standing run by about 1e-9) and far below what a
changed controller, model or reference moves (centimetres). The state's
checksum is compared only between two runs on this machine. Update the
file only deliberately, after checking why a run changed:
    python -m tests.test_scenarios
"""

import json
from pathlib import Path

import numpy as np
import pytest

from hotu_drake.diagrams import run_scenario as run
from hotu_drake.scenario import load_scenario, shipped_scenarios

STATES = Path(__file__).parent / "data" / "scenario_states.json"
SCENARIOS = sorted(shipped_scenarios())
SHORT = 0.5  # s
POSITION_TOLERANCE = 1e-3  # m, rad
VELOCITY_TOLERANCE = 1e-2  # m/s, rad/s


@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_runs_within_torque_limits_and_reproducibly(name):
    scenario = load_scenario(name)
    figures = run(scenario, SHORT, state=True)
    assert figures["max_torque_ratio"] <= 1.0 + 1e-9
    assert not figures["fell"]
    again = run(scenario, SHORT)
    assert again["checksum"] == figures["checksum"]  # the same machine: the same bits
    pinned = json.loads(STATES.read_text())[name]
    for key, tolerance in (("positions", POSITION_TOLERANCE), ("velocities", VELOCITY_TOLERANCE)):
        np.testing.assert_allclose(figures[key], pinned[key], rtol=0, atol=tolerance, err_msg=f"{name} {key}")


def _pinned(figures: dict) -> dict:
    return {key: [round(x, 6) + 0.0 for x in figures[key]] for key in ("positions", "velocities")}


def test_perturbation_scenarios_push_but_do_not_topple():
    for name in [n for n in SCENARIOS if n.startswith("perturb_")]:
        scenario = load_scenario(name)
        figures = run(scenario)
        assert not figures["fell"], name
        assert figures["max_torque_ratio"] <= 1.0 + 1e-9


def test_simulate_cli_prints_json_and_rejects_bad_files(tmp_path):
    import subprocess
    import sys

    result = subprocess.run(
        [sys.executable, "-m", "hotu_drake.simulate", "stand_bruce", "--duration", "0.2", "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    figures = json.loads(result.stdout)
    assert set(figures) >= {"realtime_factor", "fell", "min_pelvis_height", "max_torque_ratio", "checksum"}
    bad = tmp_path / "bad.yaml"
    bad.write_text("embodiment: atlas\n")
    result = subprocess.run(
        [sys.executable, "-m", "hotu_drake.simulate", str(bad)], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 2 and result.stderr.startswith(f"error: {bad}") and result.stderr.count("\n") == 1


LEGACY = sorted((Path(__file__).parent / "data" / "legacy_scenarios").glob("*.yaml"))


@pytest.mark.parametrize("path", LEGACY, ids=lambda p: p.stem)
def test_scenario_files_of_the_old_layout_load_as_the_shipped_scenario(path):
    """hotu_drake 0.1 files (plant:, reference:, policy: sections) still load, to the same diagram."""
    old, new = load_scenario(path), load_scenario(path.stem)
    old.base_dir = new.base_dir = old.source = new.source = ""
    if "time_step:" in path.read_text():  # the old file's own step is kept; the shipped one takes today's default
        assert old.plant_config.time_step in (0.005, 0.0005)
        old.plant_config.time_step = new.plant_config.time_step
    assert old.to_yaml() == new.to_yaml()


def test_scenarios_are_found_by_name_old_path_or_catalogue_entry(tmp_path):
    from hotu_drake.errors import InputError
    from hotu_drake.resources import systems_dir

    def fields(scenario):
        scenario.source = ""
        return scenario.to_yaml()

    by_name = fields(load_scenario("perturb_bruce"))
    assert fields(load_scenario(systems_dir() / "perturb_bruce.yaml")) == by_name  # 0.1's path
    assert fields(load_scenario(systems_dir() / "perturb.yaml", "perturb_bruce")) == by_name
    with pytest.raises(InputError, match="give one of perturb_udh"):
        load_scenario(systems_dir() / "perturb.yaml")
    with pytest.raises(InputError, match="no scenario 'perturb_atlas'"):
        load_scenario(systems_dir() / "perturb.yaml", "perturb_atlas")
    catalogue = tmp_path / "mine.yaml"
    catalogue.write_text("_base: &base {embodiment: bruce}\nquick: {<<: *base, duration: 0.5}\n")
    assert load_scenario(catalogue).duration == 0.5  # one entry: no name needed


def test_a_scenario_pickles_for_worker_processes():
    import pickle

    scenario = load_scenario("track_walk_h1")
    again = pickle.loads(pickle.dumps(scenario))
    assert again.to_yaml() == scenario.to_yaml() and type(again.driver).__name__ == "ReferenceTracking"


if __name__ == "__main__":
    values = {name: _pinned(run(load_scenario(name), SHORT, state=True)) for name in SCENARIOS}
    entries = [
        f'  "{name}": {{"positions": {json.dumps(v["positions"])},\n    "velocities": {json.dumps(v["velocities"])}}}'
        for name, v in values.items()
    ]
    STATES.write_text("{\n" + ",\n".join(entries) + "\n}\n")
    print(f"wrote {STATES}")
