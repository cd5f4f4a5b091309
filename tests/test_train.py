"""`python -m hotu_drake.train` on a real Drake environment (Bruce), with a
tiny configuration: the run folder, the checkpoint a scenario deploys, and
resuming after a kill."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from hotu_drake.commands.train import main
from hotu_drake.embodiment import load as load_embodiment
from hotu_drake.learning.checkpoint import load_checkpoint, read_checkpoint
from hotu_drake.scenario import InitialCondition, PolicyCheckpoint, Scenario
from hotu_drake.systems.motion_reference import REFERENCE_SIZE
from hotu_drake.systems.observation import observation_size

TINY = """\
ppo: {horizon: 32, minibatch_size: 32, epochs: 2}
networks: {policy_hidden: [32, 32], critic_hidden: [32, 32], discriminator_hidden: [32, 32]}
style: {batch_size: 32, updates: 1, replay_size: 1000}
latent: {size: 4}
warm_start: {epochs: 2}
torch_threads: 1
"""
BRUCE = ["--robot", "bruce", "--motions", "squat", "--workers", "1"]


@pytest.fixture(scope="module")
def bruce_run(tmp_path_factory):
    """A finished tiny run: 128 samples, evaluated on one episode."""
    folder = tmp_path_factory.mktemp("train")
    config = folder / "tiny.yaml"
    config.write_text(TINY)
    out = folder / "run"
    argv = ["pretrain", *BRUCE, "--steps", "128", "--out", str(out), "--config", str(config), "--eval-episodes", "1"]
    assert main(argv) == 0
    return out


def test_a_run_writes_its_folder(bruce_run):
    names = {p.name for p in bruce_run.iterdir()}
    assert {"run.json", "config.yaml", "metrics.jsonl", "checkpoint.pt", "policy.pt", "report.json"} <= names
    lines = [json.loads(line) for line in (bruce_run / "metrics.jsonl").read_text().splitlines()]
    assert [line["iteration"] for line in lines] == [0, 1, 2, 3, 4]  # the warm start, then 4 x 32 samples
    assert lines[-1]["samples"] == 128
    for key in ("style/lower_body", "discriminator/lower_body/accuracy_demo", "approx_kl", "samples_per_second"):
        assert np.isfinite(lines[-1][key]), key
    report = json.loads((bruce_run / "report.json").read_text())
    assert report["samples"] == 128 and report["robot"] == "bruce"
    policy = report["evaluation"]["policy"]
    assert 0.0 <= policy["fall_rate"] <= 1.0 and 0.0 <= policy["normalized_return"] <= 1.0
    assert set(policy["joint_distance_deg"]) >= {"hip", "knee", "all"}
    assert set(policy["coverage_deg"]) == set(policy["joint_distance_deg"])
    checkpoint = read_checkpoint(bruce_run / "checkpoint.pt", kind="training")
    assert checkpoint["embodiment"] == "bruce" and checkpoint["meta"]["algo"] == "dail"
    assert {"model", "style", "actor_optimizer", "style_optimizer", "replay", "numpy_rng"} <= set(checkpoint["state"])
    groups = [g["name"] for g in checkpoint["meta"]["groups"]]
    assert groups == ["lower_body", "left_arm", "right_arm"]  # Bruce has no torso joint


def test_a_scenario_deploys_the_checkpoint_and_it_runs(bruce_run):
    from hotu_drake.diagrams import build_simulation

    for latents in ("prior", "zero"):
        scenario = Scenario(
            embodiment="bruce",
            driver=PolicyCheckpoint(str(bruce_run / "policy.pt"), latents=latents),
            initial=InitialCondition(drop_height=0.0),
            duration=0.5,
        )
        sim = build_simulation(scenario)
        sim.simulator.AdvanceTo(0.5)
        plant_context = sim.plant.GetMyContextFromRoot(sim.simulator.get_context())
        assert np.all(np.isfinite(sim.plant.GetPositions(plant_context)))


def test_a_run_killed_and_resumed_continues_from_its_last_checkpoint(tmp_path):
    config = tmp_path / "tiny.yaml"
    config.write_text(TINY)
    out = tmp_path / "run"
    argv = ["pretrain", *BRUCE, "--out", str(out), "--config", str(config), "--eval-episodes", "0"]
    env = {**os.environ, "PYTHONPATH": os.getcwd()}
    process = subprocess.Popen(
        [sys.executable, "-m", "hotu_drake.train", *argv, "--steps", "100000", "--checkpoint-every", "2"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:  # until the second checkpoint (iteration 4) is on disk
            time.sleep(0.5)
            if (out / "checkpoint.pt").exists():
                saved = read_checkpoint(out / "checkpoint.pt", kind="training")["state"]["counters"]
                if saved["iteration"] >= 4:
                    break
        else:
            pytest.fail("no second checkpoint within 240 s")
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    saved = read_checkpoint(out / "checkpoint.pt", kind="training")["state"]
    done = saved["counters"]["iteration"]
    steps = saved["counters"]["samples"] + 2 * 32
    assert main(["pretrain", "--out", str(out), "--steps", str(steps), "--resume", "--eval-episodes", "0"]) == 0
    resumed = read_checkpoint(out / "checkpoint.pt", kind="training")["state"]
    assert resumed["counters"]["iteration"] == done + 2 and resumed["counters"]["samples"] == steps
    assert resumed["counters"]["warm_started"]
    # The optimiser carried on: Adam's step count is the saved one plus two iterations' updates.
    step = lambda s: int(s["actor_optimizer"]["state"][0]["step"])  # noqa: E731
    assert step(resumed) == step(saved) + 2 * 2  # 2 epochs x 1 minibatch per iteration
    iterations = [json.loads(line)["iteration"] for line in (out / "metrics.jsonl").read_text().splitlines()]
    assert iterations == list(range(done + 3)), "the log continues without gaps or repeats"


def test_a_finished_run_is_not_overwritten(bruce_run, capsys):
    from hotu_drake.cli import run_cli

    before = (bruce_run / "checkpoint.pt").stat().st_mtime_ns
    code = run_cli(main, ["pretrain", *BRUCE, "--steps", "64", "--out", str(bruce_run)])
    assert code == 2 and "a run is already here" in capsys.readouterr().err
    assert (bruce_run / "checkpoint.pt").stat().st_mtime_ns == before


def test_trace_draws_an_episode_against_the_references(bruce_run, tmp_path, capsys):
    from hotu_drake.cli import run_cli

    out = tmp_path / "trace.png"
    assert main(["trace", str(bruce_run), "--out", str(out), "--parts", "hip,knee"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code = run_cli(main, ["trace", str(bruce_run), "--out", str(tmp_path / "no.png"), "--parts", "torso"])
    assert code == 2 and "no part 'torso'" in capsys.readouterr().err  # Bruce has no torso joint
    assert not (tmp_path / "no.png").exists()


def test_reach_measures_where_each_latent_takes_the_hands_and_pelvis(bruce_run, tmp_path, capsys):
    from hotu_drake import embodiment
    from hotu_drake.cli import run_cli

    assert main(["reach", str(bruce_run), "--latents", "3", "--seconds", "0.5"]) == 0
    figures = json.loads(capsys.readouterr().out)
    ends = np.array(figures["ends"])
    assert ends.shape == (3, 9) and figures["latents"] == 3
    np.testing.assert_allclose(figures["spread"], ends.std(0), atol=1e-4)
    bruce = embodiment.load("bruce", "none")
    if figures["fell"] == 0:  # standing: the pelvis at its height, the hands beside and below it
        np.testing.assert_allclose(ends[:, 8], bruce.standing_pelvis_height, atol=0.1)
    hands = np.linalg.norm(ends[:, :6].reshape(3, 2, 3), axis=-1)
    assert np.all((hands > 0.05) & (hands < 0.8)), hands
    code = run_cli(main, ["reach", str(tmp_path)])
    assert code == 2 and "run:" in capsys.readouterr().err


def test_a_dagger_run_learns_from_the_teacher_and_reports_it_beside_the_teacher(tmp_path, capsys):
    """`--algo dagger` on H1's looped walk: labelled iterations in the
    metrics, and a report of 10 s episodes from the clip's start for the
    policy, the teacher and the robot standing (the teacher walks, the
    robot standing does not); after `teacher.ppo_after`, PPO iterations on
    the tracking reward."""
    config = tmp_path / "tiny.yaml"
    config.write_text(
        "environment: {loop: true, tracking_reward: true, reference_observation: true}\nppo: {horizon: 60}\n"
        "networks: {policy_hidden: [32, 32], critic_hidden: [8]}\n"
        "teacher: {updates: 5, batch_size: 32, ppo_after: 120}\ntorch_threads: 1\n"
    )
    out = tmp_path / "run"
    argv = ["pretrain", "--robot", "h1", "--motions", "walk", "--algo", "dagger", "--workers", "1"]
    assert main([*argv, "--steps", "180", "--out", str(out), "--config", str(config), "--eval-episodes", "1"]) == 0
    lines = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    assert [line["iteration"] for line in lines] == [1, 2, 3] and lines[1]["labelled"] == 120
    assert lines[0]["beta"] == 1.0 and lines[0]["label_loss_visited"] > lines[1]["label_loss_visited"]
    assert lines[2]["label_weight"] == 1.0 and "approx_kl" in lines[2] and 0.5 < lines[2]["reward"] <= 1.0
    evaluation = json.loads((out / "report.json").read_text())["evaluation"]
    assert set(evaluation) >= {"policy", "teacher", "standing"}
    teacher, standing = evaluation["teacher"], evaluation["standing"]
    assert teacher["fall_rate"] == 0.0 and teacher["mean_episode_seconds"] == pytest.approx(10.0)
    assert teacher["travel_ratio"] > 0.6 and standing["travel_ratio"] < 0.1, (teacher, standing)
    assert 0.0 < teacher["coverage_deg"] < standing["coverage_deg"], (teacher, standing)  # the walk's legs swing
    assert read_checkpoint(out / "checkpoint.pt", kind="training")["state"]["labelled"]["size"] == 120
    network, _ = load_checkpoint(out / "policy.pt")  # the robot's observation, the phase and the reference's
    assert network.config.observation_size == observation_size(load_embodiment("h1", "none")) + 2 + REFERENCE_SIZE
    headline = json.loads(capsys.readouterr().err.strip().splitlines()[-1])
    assert {"policy_fall_rate", "teacher_travel_ratio", "standing_travel_ratio"} <= set(headline)
    picture = tmp_path / "trace.png"  # a clone has no latents; its trace is drawn all the same
    assert main(["trace", str(out), "--out", str(picture), "--parts", "hip,knee"]) == 0 and picture.stat().st_size > 0


def test_a_clone_of_several_motions_is_reported_motion_by_motion(tmp_path, capsys):
    """A DAgger run over two motions (H1's walk and wave, observing the
    clips' joints): its report evaluates each motion on environments of
    that motion alone, the policy beside the teacher and the robot
    standing, and the headline names each motion's figures."""
    config = tmp_path / "tiny.yaml"
    config.write_text(
        "environment: {loop: [walk], pose_observation: true}\nppo: {horizon: 60}\n"
        "networks: {policy_hidden: [32, 32], critic_hidden: [8]}\nteacher: {updates: 5, batch_size: 32}\n"
        "torch_threads: 1\n"
    )
    out = tmp_path / "run"
    argv = ["pretrain", "--robot", "h1", "--motions", "walk,wave", "--algo", "dagger", "--workers", "1"]
    assert main([*argv, "--steps", "60", "--out", str(out), "--config", str(config), "--eval-episodes", "1"]) == 0
    evaluation = json.loads((out / "report.json").read_text())["evaluation"]
    assert set(evaluation["by_motion"]) == {"walk", "wave"}
    for motion, figures in evaluation["by_motion"].items():
        assert figures["teacher"]["fall_rate"] == 0.0 and figures["policy"]["episodes"] == 1, motion
        assert figures["teacher"]["coverage_deg"] < figures["standing"]["coverage_deg"], motion  # of its own clip
    walk, wave = evaluation["by_motion"]["walk"], evaluation["by_motion"]["wave"]
    assert walk["teacher"]["reference_travel_m"] > 3.0 > wave["teacher"]["reference_travel_m"]  # each its own clip
    headline = json.loads(capsys.readouterr().err.strip().splitlines()[-1])
    assert {"walk_policy_fall_rate", "wave_teacher_mean_episode_seconds"} <= set(headline)


def test_a_run_starts_from_another_runs_networks_when_they_fit(bruce_run, tmp_path, capsys):
    """`--init RUN`: the new run begins with RUN's weights (after one
    iteration its policy is far nearer RUN's than a fresh run's is), and
    records where it began; a run of another robot, networks of another
    shape, or `--resume` with it are refused before anything is written."""
    from hotu_drake.cli import run_cli

    config = tmp_path / "tiny.yaml"
    config.write_text(TINY)
    common = ["--steps", "32", "--config", str(config), "--eval-episodes", "0", "--seed", "1"]  # (RUN's is 0)
    assert main(["pretrain", *BRUCE, *common, "--out", str(tmp_path / "fresh")]) == 0
    assert main(["pretrain", *BRUCE, *common, "--out", str(tmp_path / "init"), "--init", str(bruce_run)]) == 0

    def first_layer(folder):
        state = read_checkpoint(folder / "checkpoint.pt", kind="training")["state"]["model"]
        return next(value for key, value in state.items() if key.endswith("weight")).numpy()

    origin = first_layer(bruce_run)
    near, fresh = (np.abs(first_layer(tmp_path / name) - origin).mean() for name in ("init", "fresh"))
    assert near < 0.1 * fresh, (near, fresh)
    assert json.loads((tmp_path / "init" / "run.json").read_text())["init"] == str(bruce_run.resolve())

    wide = tmp_path / "wide.yaml"
    wide.write_text(TINY.replace("policy_hidden: [32, 32]", "policy_hidden: [48]"))
    refused = [
        (["--robot", "h1", "--motions", "walk", *common], "a run of robot bruce, not h1"),
        ([*BRUCE, *common[:2], "--config", str(wide), "--eval-episodes", "0"], "networks do not fit"),
    ]
    for index, (argv, message) in enumerate(refused):
        out = tmp_path / f"refused{index}"
        assert run_cli(main, ["pretrain", *argv, "--out", str(out), "--init", str(bruce_run)]) == 2
        assert message in capsys.readouterr().err
        assert not (out / "run.json").exists()
    code = run_cli(
        main, ["pretrain", "--out", str(tmp_path / "init"), "--steps", "64", "--resume", "--init", str(bruce_run)]
    )
    assert code == 2 and "--resume continues" in capsys.readouterr().err
