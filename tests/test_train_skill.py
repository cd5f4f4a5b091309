"""`python -m hotu_drake.train skill` on BoxCarry-v0 with tiny configurations:
the run folder, the two-level scenario it deploys into, and the diagram's
actions against the two networks called directly."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from hotu_drake.commands.train import main
from hotu_drake.learning import high_level_input, to_latents
from hotu_drake.learning.checkpoint import load_checkpoint, read_checkpoint
from hotu_drake.scenario import load_scenario
from tests.test_train import TINY as BEHAVIOR

SKILL = """\
ppo: {horizon: 8, minibatch_size: 16, epochs: 2}
high_level: {hold_steps: 3, hidden: [32], critic_hidden: [32]}
interaction: {hidden: [32], batch_size: 32, replay_size: 1000}
one_level:
  ppo: {horizon: 32, minibatch_size: 32, epochs: 2}
  networks: {policy_hidden: [32, 32], critic_hidden: [32, 32], discriminator_hidden: [32, 32]}
  style: {batch_size: 32, updates: 1, replay_size: 1000}
  warm_start: {epochs: 2}
  torch_threads: 1
torch_threads: 1
"""


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A tiny UDH behavior run (DAIL), a tiny `ours` skill over it and a tiny `amp` one, each evaluated."""
    folder = tmp_path_factory.mktemp("skill")
    (folder / "behavior.yaml").write_text(BEHAVIOR)
    (folder / "skill.yaml").write_text(SKILL)
    llc = folder / "udh_dail"
    common = ["--steps", "48", "--workers", "1"]
    assert main(["pretrain", "--robot", "udh", "--motions", "walk,box_carry", *common, "--out", str(llc),
                 "--config", str(folder / "behavior.yaml"), "--eval-episodes", "0"]) == 0  # fmt: skip
    out = {"llc": llc}
    for algo in ("ours", "amp"):
        out[algo] = folder / f"box_{algo}"
        extra = ["--llc", str(llc)] if algo == "ours" else []
        argv = ["skill", "--task", "box_carry", "--algo", algo, *extra, *common, "--out", str(out[algo])]
        assert main([*argv, "--config", str(folder / "skill.yaml"), "--eval-episodes", "2"]) == 0
    return out


def test_a_skill_run_writes_its_folder_with_every_reward_term(runs):
    run = runs["ours"]
    assert {"run.json", "config.yaml", "metrics.jsonl", "checkpoint.pt", "policy.pt", "report.json"} <= {
        p.name for p in run.iterdir()
    }
    lines = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert lines[-1]["samples"] == 48  # 8 high-level steps x 3 control steps, twice
    for key in ("reward/task", "reward/interaction", "reward/style", "interaction_discriminator/accuracy_demo"):
        assert np.isfinite(lines[-1][key]), key
    report = json.loads((run / "report.json").read_text())
    evaluation = report["evaluation"]
    assert evaluation["episodes"] == 2 and 0.0 <= evaluation["normalized_return"] <= 1.0
    assert evaluation["success_rate"] in (0.0, 0.5, 1.0)
    standing = evaluation["standing"]  # the robot just standing, on the same two tasks
    assert standing["episodes"] == 2 and standing["fall_rate"] == 0.0 and 0.0 < standing["normalized_return"] < 1.0
    checkpoint = read_checkpoint(run / "checkpoint.pt", kind="training")
    meta = checkpoint["meta"]
    assert meta["kind"] == "skill" and meta["hold_steps"] == 3 and meta["llc"] == str(runs["llc"].resolve())
    assert meta["llc_groups"] == ["lower_body", "torso", "left_arm", "right_arm"] and meta["interaction_size"] == 11
    amp = json.loads((runs["amp"] / "report.json").read_text())
    assert amp["algo"] == "amp" and amp["llc"] is None and amp["evaluation"]["episodes"] == 2
    amp_lines = [json.loads(line) for line in (runs["amp"] / "metrics.jsonl").read_text().splitlines()]
    assert np.isfinite(amp_lines[-1]["task"]) and np.isfinite(amp_lines[-1]["style"])


@pytest.mark.parametrize("algo", ["ours", "amp"])
def test_the_best_episode_scenario_loads_the_checkpoints_and_runs(runs, algo):
    from hotu_drake.diagrams import build_simulation

    scenario = load_scenario(str(runs[algo] / "best_episode.yaml"))
    scenario.duration = 0.3
    sim = build_simulation(scenario)
    sim.simulator.AdvanceTo(0.3)
    assert np.all(np.isfinite(sim.plant.GetPositions(sim.plant_context())))


def test_the_two_level_diagram_acts_as_the_two_networks_called_directly(runs):
    from hotu_drake.diagrams import build_simulation

    scenario = load_scenario(str(runs["ours"] / "best_episode.yaml"))
    sim = build_simulation(scenario)
    context = sim.simulator.get_context()
    observation, goal, interaction = (sim.output(name) for name in ("observation", "goal", "interaction"))
    skill, data = load_checkpoint(runs["ours"] / "policy.pt")
    llc, _ = load_checkpoint(runs["llc"] / "policy.pt")
    inputs = high_level_input(np.concatenate([observation, goal])[None], interaction[None])
    with torch.no_grad():
        raw = skill.mean(torch.as_tensor(inputs)).numpy()
        latents = to_latents(raw, data["meta"]["llc_groups"], data["meta"]["latent_size"])
        expected = llc(torch.as_tensor(observation, dtype=torch.float32), {g: torch.as_tensor(z[0]) for g, z in
                       latents.items()}).numpy()  # fmt: skip
    np.testing.assert_allclose(sim.output("latents"), np.concatenate([latents[g][0] for g in latents]), atol=1e-6)
    sim.simulator.AdvanceTo(1e-4)  # the control events at t = 0 act on the state at t = 0
    np.testing.assert_allclose(sim.diagram.GetOutputPort("action").Eval(context), expected, atol=1e-5)


def test_a_skill_run_resumes_with_its_counters(runs, tmp_path):
    import shutil

    run = tmp_path / "box_ours"
    shutil.copytree(runs["ours"], run)
    assert main(["skill", "--out", str(run), "--steps", "72", "--resume", "--eval-episodes", "0"]) == 0
    lines = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert [line["samples"] for line in lines] == [24, 48, 72]


def test_plot_draws_the_reward_terms_of_every_method(runs, tmp_path):
    out = tmp_path / "terms.png"
    keys = "reward/task,reward/interaction,reward/style"
    assert main(["plot", str(runs["ours"]), str(runs["amp"]), "--out", str(out), "--keys", keys, "--smooth", "1"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from hotu_drake.errors import InputError

    with pytest.raises(InputError, match="no metric 'reward/grip'"):
        main(["plot", str(runs["amp"]), "--out", str(tmp_path / "x.png"), "--keys", "reward/grip"])


FINETUNE = """\
ppo: {horizon: 8, minibatch_size: 16, epochs: 2}
high_level: {hidden: [16], critic_hidden: [16]}
torch_threads: 1
"""


@pytest.fixture(scope="module")
def transfer(runs, tmp_path_factory):
    """The tiny UDH skill moved to H1: a tiny H1 controller, one reference and one held-out, 16 samples."""
    import gymnasium as gym

    folder = tmp_path_factory.mktemp("transfer")
    (folder / "behavior.yaml").write_text(BEHAVIOR)
    (folder / "finetune.yaml").write_text(FINETUNE)
    llc = folder / "h1_dail"
    common = ["--workers", "1", "--config"]
    assert main(["pretrain", "--robot", "h1", "--motions", "walk,box_carry", "--steps", "32", "--out", str(llc),
                 *common, str(folder / "behavior.yaml"), "--eval-episodes", "0"]) == 0  # fmt: skip
    out = folder / "h1_box"
    argv = ["finetune", "--skill", str(runs["ours"]), "--llc", str(llc), "--references", "1", "--eval-references", "1"]
    argv += ["--steps", "16", "--eval-episodes", "1", "--out", str(out), *common, str(folder / "finetune.yaml")]
    assert main(argv) == 0
    assert gym  # the environments were registered by the run
    return out


def test_a_finetune_run_records_its_references_and_judges_the_task(transfer):
    settings = json.loads((transfer / "run.json").read_text())
    assert settings["command"] == "finetune" and settings["robot"] == "h1" and settings["transfer_seconds"] > 0
    for key, name in (("references", "reference_0.npz"), ("eval_references", "eval_1000.npz")):
        assert [p.split("/")[-1] for p in settings[key]] == [name] and (transfer / "references" / name).is_file()
    assert (transfer / "references" / "udh_reference_0.npz").is_file()
    assert not (transfer / "references.partial").exists()
    report = json.loads((transfer / "report.json").read_text())
    evaluation = report["evaluation"]
    assert 0.0 <= evaluation["normalized_tracking_return"] <= 1.0 and 0.0 <= evaluation["normalized_return"] <= 1.0
    assert "normalized_tracking_return" in evaluation["standing"]
    lines = [json.loads(line) for line in (transfer / "metrics.jsonl").read_text().splitlines()]
    assert lines[-1]["samples"] == 16 and np.isfinite(lines[-1]["reward/task"])
    assert "reward/interaction" not in lines[-1]  # no D_I in a fine-tune


def test_the_fine_tuning_layer_gives_a_latent_on_each_parts_sphere(transfer):
    import gymnasium as gym

    settings = json.loads((transfer / "run.json").read_text())
    layer, data = load_checkpoint(transfer / "policy.pt")
    meta = data["meta"]
    assert meta["hold_steps"] == 1 and len(meta["llc_groups"]) == 4  # H1's part groups, a latent every step
    env = gym.make("hotu_drake/BoxCarryTransfer-v0", robot="h1", hands="none", references=settings["references"])
    observation, info = env.reset(seed=0)
    inputs = [high_level_input(observation[None], info["interaction"][None])]
    for _ in range(3):
        observation, _, _, _, info = env.step(env.action_space.sample())
        inputs.append(high_level_input(observation[None], info["interaction"][None]))
    env.close()
    with torch.no_grad():
        raw = layer.mean(torch.as_tensor(np.concatenate(inputs))).numpy()
    latents = to_latents(raw, meta["llc_groups"], meta["latent_size"])
    for group, z in latents.items():
        assert z.shape == (4, meta["latent_size"]), group
        np.testing.assert_allclose(np.linalg.norm(z, axis=1), 1.0, atol=1e-5)


def test_a_finetune_run_resumes_and_refuses_a_skill_that_is_not_two_level(transfer, runs, tmp_path):
    import shutil

    from hotu_drake.errors import InputError

    run = tmp_path / "h1_box"
    shutil.copytree(transfer, run)
    assert main(["finetune", "--out", str(run), "--steps", "24", "--resume", "--eval-episodes", "0"]) == 0
    lines = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert [line["samples"] for line in lines] == [8, 16, 24]  # 8 control steps an iteration
    settings = json.loads((transfer / "run.json").read_text())
    out = tmp_path / "bad"
    with pytest.raises(InputError, match="not a two-level train skill run"):
        main(["finetune", "--skill", str(runs["amp"]), "--llc", settings["llc"], "--steps", "8", "--out", str(out)])
    assert not out.exists()


def test_a_fine_tuned_layer_deploys_in_its_diagram_with_the_environments_reference(transfer):
    import gymnasium as gym

    from hotu_drake.diagrams import build_simulation
    from hotu_drake.systems.interaction_graph import GOAL_SIZE

    scenario = load_scenario(str(transfer / "best_episode.yaml"))
    assert scenario.driver.reference.endswith("eval_1000.npz") and scenario.embodiment == "h1"
    sim = build_simulation(scenario)
    env = gym.make("hotu_drake/BoxCarryTransfer-v0", robot="h1", hands="none", references=[scenario.driver.reference])
    inner = env.unwrapped
    inner.reset(seed=0)
    # From the diagram's start state, the environment's reference features are the diagram's.
    state = sim.plant.GetPositionsAndVelocities(sim.plant_context())
    inner.sim.plant.SetPositionsAndVelocities(inner._plant_context, state)
    np.testing.assert_allclose(sim.output("transfer_reference"), inner._extra_observation()[GOAL_SIZE:], atol=1e-9)
    env.close()
    sim.simulator.AdvanceTo(0.5)
    latents = sim.output("latents").reshape(4, -1)
    np.testing.assert_allclose(np.linalg.norm(latents, axis=1), 1.0, atol=1e-6)
