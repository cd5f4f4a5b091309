"""Every shipped scenario builds and runs; its outcome is pinned by a checksum.

The checksums in tests/data/scenario_checksums.json are of the state after
0.5 s; update them only deliberately, after checking why a run changed:
    python -m tests.test_scenarios
"""

import json
from pathlib import Path

import pytest

from hotu_drake.resources import systems_dir
from hotu_drake.scenario import load_scenario
from hotu_drake.simulate import run

CHECKSUMS = Path(__file__).parent / "data" / "scenario_checksums.json"
SCENARIOS = sorted(p.stem for p in systems_dir().glob("*.yaml"))
SHORT = 0.5  # s


@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_runs_within_torque_limits_and_reproducibly(name):
    scenario = load_scenario(systems_dir() / f"{name}.yaml")
    figures = run(scenario, SHORT)
    assert figures["max_torque_ratio"] <= 1.0 + 1e-9
    assert not figures["fell"]
    again = run(scenario, SHORT)
    assert again["checksum"] == figures["checksum"]
    assert figures["checksum"] == json.loads(CHECKSUMS.read_text())[name]


def test_perturbation_scenarios_push_but_do_not_topple():
    for name in [n for n in SCENARIOS if n.startswith("perturb_")]:
        scenario = load_scenario(systems_dir() / f"{name}.yaml")
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


if __name__ == "__main__":
    values = {name: run(load_scenario(systems_dir() / f"{name}.yaml"), SHORT)["checksum"] for name in SCENARIOS}
    CHECKSUMS.write_text(json.dumps(values, indent=2, sort_keys=True) + "\n")
    print(f"wrote {CHECKSUMS}")
