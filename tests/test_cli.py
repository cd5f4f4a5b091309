"""The `models` command line: list, export, generate; errors are one line with exit 2."""

import json
import subprocess
import sys

import pytest

from hotu_drake import embodiment
from hotu_drake.models.__main__ import main
from hotu_drake.objects import OBJECTS
from tests.test_embodiment_parts import EXPECTED


def run(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "hotu_drake.models", *args], capture_output=True, text=True, cwd=cwd, timeout=300
    )


def test_list_json_is_the_dof_table():
    result = run("list", "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout) == EXPECTED


def test_list_prints_a_table(capsys):
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[0] == "embodiment" and lines[0].split()[-1] == "total"
    assert [line.split()[0] for line in lines[1:]] == list(embodiment.EMBODIMENT_NAMES)
    assert lines[1].split()[-1] == "92"


@pytest.mark.parametrize("fmt,suffix", [("sdf", ".sdf"), ("urdf", ".urdf"), ("mjcf", ".xml")])
def test_export_writes_the_model(tmp_path, fmt, suffix, capsys):
    out = tmp_path / f"walker{suffix}"
    assert main(["export", "walker", "--format", fmt, "--hands", "none", "--out", str(out)]) == 0
    assert out.read_text() == embodiment.load("walker", "none").model_text(fmt)


def test_export_udh_with_height(tmp_path):
    out = tmp_path / "udh_tall.sdf"
    assert main(["export", "udh", "--format", "sdf", "--height", "1.85", "--out", str(out)]) == 0
    assert out.read_text() == embodiment.load("udh", "full", height=1.85).model_text("sdf")


@pytest.mark.parametrize(
    "args,message",
    [
        (["export", "atlas", "--format", "sdf"], "unknown embodiment 'atlas'"),
        (["export", "h1", "--format", "sdf", "--height", "1.7"], "--height applies to the UDH only"),
        (["export", "udh", "--format", "sdf", "--height", "7"], "height"),
    ],
)
def test_bad_export_is_one_line_and_leaves_no_file(tmp_path, args, message):
    out = tmp_path / "model.sdf"
    result = run(*args, "--out", str(out))
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("error:")
    assert message in result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_export_to_a_folder_is_refused(tmp_path):
    result = run("export", "h1", "--format", "urdf", "--out", str(tmp_path))
    assert result.returncode == 2 and "is a folder" in result.stderr


@pytest.mark.parametrize(
    "args,message",
    [
        (["export", "h1", "--format", "obj"], "invalid choice: 'obj'"),
        (["export", "udh", "--format", "sdf", "--height", "abc"], "not a number"),
        (["list", "--hands", "left"], "invalid choice: 'left'"),
    ],
)
def test_usage_errors_are_one_line(tmp_path, args, message):
    result = run(*args, "--out", str(tmp_path / "x")) if args[0] == "export" else run(*args)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("error:") and message in result.stderr


def test_unwritable_output_is_one_line():
    result = run("export", "h1", "--format", "sdf", "--out", "/proc/hotu_drake_test.sdf")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert result.stderr.startswith("error: /proc/hotu_drake_test.sdf: cannot write here")


@pytest.mark.parametrize(
    "args,message",
    [(["--seconds", "nan"], "finite number"), (["--time-step", "10"], "0.05] s"), (["--robot", "atlas"], "atlas")],
)
def test_bench_rejects_bad_input(args, message):
    result = subprocess.run(
        [sys.executable, "-m", "hotu_drake.bench", "standing", *args], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and message in result.stderr


def test_generate_writes_every_model_and_check_passes(tmp_path):
    assert main(["generate", "--out", str(tmp_path)]) == 0
    assert len(list(tmp_path.rglob("*.*"))) == 6 * 2 * 3 + len(OBJECTS)  # robots x hands x formats, objects
    assert main(["generate", "--out", str(tmp_path), "--check"]) == 0
    (tmp_path / "h1" / "h1_hands_none.urdf").write_text("stale")
    assert main(["generate", "--out", str(tmp_path), "--check"]) == 1


def test_help_explains():
    result = run("--help")
    assert result.returncode == 0 and "SDF, URDF or MJCF" in result.stdout


def test_bench_diagram_reports_every_diagram_and_system_cost():
    command = ["diagram", "--robot", "bruce", "--hands", "none", "--seconds", "0.3"]
    result = subprocess.run(
        [sys.executable, "-m", "hotu_drake.bench", *command],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    import json

    (row,) = json.loads(result.stdout)["results"]
    assert row["standing_rtf"] > 0 and row["perturbation_rtf"] > 0 and row["all_systems_rtf"] > 0
    costs = row["ms_per_control_step"]
    assert set(costs) == {"advance", "observation", "amp_observation", "interaction", "policy_forward"}
    assert all(value > 0 for value in costs.values())
    assert not row["all_systems_fell"]


def test_bench_env_reports_throughput_split_memory_and_the_mujoco_ratio(mujoco, tmp_path):
    command = ["env", "--robot", "bruce", "--envs", "1", "--seconds", "0.5", "--peer", "mujoco", "--json"]
    result = subprocess.run(
        [sys.executable, "-m", "hotu_drake.bench", *command], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    import json

    report = json.loads(result.stdout)
    assert report["env_steps_per_second"] > 0 and report["sim_seconds_per_wall_second"] > 0
    split = report["ms_per_step"]
    assert set(split) == {"physics", "observation", "amp_observation", "python_overhead", "total"}
    assert split["physics"] + split["observation"] + split["amp_observation"] <= split["total"]
    assert report["peer"]["env_steps_per_second"] > 0
    expected = report["in_process"]["env_steps_per_second"] / report["peer"]["env_steps_per_second"]
    assert report["drake_to_mujoco_ratio"] == pytest.approx(expected, rel=0.01)
    assert report["peak_memory_mb"]["this_process"] > 0 and report["peak_memory_mb"]["largest_worker"] > 0


def test_bench_env_rejects_bad_worker_counts():
    result = subprocess.run(
        [sys.executable, "-m", "hotu_drake.bench", "env", "--envs", "0"], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and "--envs" in result.stderr
