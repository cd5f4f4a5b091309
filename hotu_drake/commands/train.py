"""Train behavior primitives, and evaluate them.

    python -m hotu_drake.train pretrain --robot h1 --hands none --motions wave,boxing,handshake \\
        --algo dail --steps 2000000 --workers 2 --out runs/h1_upper
    python -m hotu_drake.train pretrain --out runs/h1_upper --steps 4000000 --resume
    python -m hotu_drake.train pretrain --robot udh --hands full --motions walk,hand_grasp@0 --algo dagger \
        --init runs/udh_grasps --steps 1000000 --out runs/udh_library     (from another run's networks)
    python -m hotu_drake.train evaluate runs/h1_upper [--episodes 20]
    python -m hotu_drake.train plot runs/h1_upper runs/h1_upper_amp --out curves.png [--keys style,episode_length]
    python -m hotu_drake.train trace runs/h1_upper --out trace.png [--parts shoulder,elbow] [--seed 7]
    python -m hotu_drake.train skill --task box_carry --llc runs/udh_dail --algo ours --steps 2000000 \
        --out runs/udh_box_ours     (see hotu_drake.commands.train_skill)
    python -m hotu_drake.train finetune --robot h1 --skill runs/udh_box_ours --llc runs/h1_dail --steps 300000 \
        --out runs/h1_box           (see hotu_drake.commands.train_finetune)
    python -m hotu_drake.train reach runs/udh_dail [--latents 12] [--seconds 2]   (see hotu_drake.commands.reach)

`pretrain` builds the run's demonstrations from the robot's reference clips
(on the Drake side, once), starts `--workers` environments
(`hotu_drake/Imitation-v0`, local processes or Ray actors with `--ray`),
warm-starts the policy by behavior cloning, and trains (`learning.agent`)
until `--steps` samples (`learning.trainer.train`, which keeps the run
folder: `checkpoint.pt` every `--checkpoint-every` iterations, by default
about three minutes' worth, and at the end, `policy.pt`, `metrics.jsonl`,
`run.json`, `config.yaml`, and `report.json`, the evaluation of the end).

Killed at any point, `--resume` continues from the last checkpoint with the
same counters, optimiser state and random streams; only the iterations
after that checkpoint are done again.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import torch

from hotu_drake.cli import ArgumentParser, run_cli
from hotu_drake.commands import reach, train_finetune, train_skill
from hotu_drake.commands.figures import pyplot, save_figure
from hotu_drake.commands.run_options import (
    add_run_arguments,
    check_run_arguments,
    check_workers,
    motion_list,
    report_at_end,
    resumed_settings,
)
from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.envs.runs import imitation_run
from hotu_drake.errors import InputError, check_choice, check_number
from hotu_drake.io import check_output_path
from hotu_drake.learning.agent import Agent
from hotu_drake.learning.config import ALGORITHMS, TrainConfig, config_from_dict, load_config, preset
from hotu_drake.learning.dagger import DAggerAgent
from hotu_drake.learning.evaluation import behavior_report, behavior_summary, clone_report
from hotu_drake.learning.trainer import RunFolder, run_record, train


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.train", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    pre = sub.add_parser("pretrain", help="train a behavior controller on reference motions")
    pre.add_argument("--robot", help=f"the embodiment ({', '.join(EMBODIMENT_NAMES)})")
    pre.add_argument("--hands", help="full or none (default none)")
    pre.add_argument("--motions", help="comma-separated library motions and/or .npz clips of the robot")
    pre.add_argument("--algo", help=f"{' | '.join(ALGORITHMS)} (default dail)")
    pre.add_argument("--init", help="start from this run's networks (the same robot, hands and observation)")
    add_run_arguments(pre, "the algorithm's preset (learning.config)", eval_episodes=20)
    ev = sub.add_parser("evaluate", help="evaluate a run's last checkpoint; writes its report.json")
    ev.add_argument("run", help="the run folder")
    ev.add_argument("--episodes", type=int, help="episodes (default 20; 100 for a skill run)")
    ev.add_argument("--seed", type=int, default=1000)
    ev.add_argument("--workers", type=int, default=2)
    plot = sub.add_parser("plot", help="learning curves of runs on one figure (needs matplotlib)")
    plot.add_argument("runs", nargs="+", help="run folders")
    plot.add_argument("--out", required=True, help="the PNG to write")
    plot.add_argument("--keys", default="style", help="comma-separated metrics (default: style)")
    plot.add_argument("--smooth", type=int, default=10, help="moving-average window in iterations (default 10)")
    trace = sub.add_parser("trace", help="joint traces of one evaluation episode next to the reference clips' (PNG)")
    trace.add_argument("run", help="the run folder")
    trace.add_argument("--out", required=True, help="the PNG to write")
    trace.add_argument("--parts", default="shoulder,elbow,wrist,hip,knee", help="Table I parts to draw")
    trace.add_argument("--seed", type=int, default=7, help="the episode's seed (its drop and latents)")
    trace.add_argument("--min-range", type=float, default=15.0, help="draw joints the references move this far (deg)")
    train_skill.add_parser(sub)
    train_finetune.add_parser(sub)
    reach.add_parser(sub)
    args = parser.parse_args(argv)
    commands = {
        "pretrain": pretrain,
        "evaluate": evaluate_command,
        "plot": plot_command,
        "trace": trace_command,
        "skill": train_skill.skill_command,
        "finetune": train_finetune.finetune_command,
        "reach": reach.reach_command,
    }
    return commands[args.command](args)


# -- pretrain ------------------------------------------------------------------------


def _settings(args, folder: RunFolder) -> tuple[dict, TrainConfig]:
    """The run's settings and configuration, from the command line or, on
    resume, from the run folder (the command line may not contradict them)."""
    if args.resume and args.init:
        raise InputError("--init starts a new run from another's networks; --resume continues this one")
    if args.resume:
        settings, checkpoint = resumed_settings(args, folder, ("robot", "hands", "algo"))
        return settings, config_from_dict(checkpoint["meta"]["config"], where=str(folder.checkpoint_path))
    folder.check_new()
    if not args.robot or not args.motions:
        raise InputError("pretrain needs --robot and --motions (or --resume with --out of a run)")
    robot = check_choice(args.robot, "--robot", EMBODIMENT_NAMES)
    hands = check_choice(args.hands or "none", "--hands", HANDS_VARIANTS)
    algo = check_choice(args.algo or "dail", "--algo", ALGORITHMS)
    config = load_config(args.config, algo) if args.config else preset(algo)
    settings = {
        "robot": robot,
        "hands": hands,
        "motions": motion_list(args.motions),
        "algo": algo,
        "seed": args.seed,
        "workers": args.workers or 2,
    }
    if args.init:
        _check_init(RunFolder(args.init), settings)
        settings["init"] = str(Path(args.init).resolve())
    return settings, config


def _check_init(folder: RunFolder, settings: dict) -> None:
    """`--init`: a run folder of the same robot and hands."""
    folder.check_run()
    theirs = folder.settings()
    for name in ("robot", "hands"):
        if theirs.get(name) != settings[name]:
            raise InputError(f"{folder.path}: --init is a run of {name} {theirs.get(name)}, not {settings[name]}")


def pretrain(args) -> int:
    folder = check_run_arguments(args)
    settings, config = _settings(args, folder)
    torch.set_num_threads(config.torch_threads)
    run = imitation_run(settings, config)  # bad motions fail here, before anything is written
    envs = run.vector_env(settings["workers"], args.ray)
    try:
        agent = make_agent(config, envs, run, settings["seed"])
        if settings.get("init") and not args.resume:  # (before the run folder is written: a misfit fails here)
            agent.start_from(RunFolder(settings["init"]).checkpoint()["state"], settings["init"])
        if not args.resume:
            folder.start(settings, config.to_dict())
        if args.resume:
            agent.load_state_dict(folder.checkpoint()["state"])
            counters = agent.counters
            print(
                f"resumed {folder.path} at iteration {counters['iteration']}, {counters['samples']} samples",
                file=sys.stderr,
            )

        def style(stats: dict) -> dict:  # each part group's style reward, or a clone's label losses
            if isinstance(agent, DAggerAgent):
                return {key: stats[key] for key in ("label_loss_visited", "beta", "label_weight") if key in stats}
            return {g.name: stats.get(f"style/{g.name}", float("nan")) for g in agent.groups}

        train(
            agent,
            folder,
            args.steps,
            lambda: folder.save(agent, settings, BEHAVIOR_META),
            resume=args.resume,
            checkpoint_every=args.checkpoint_every,
            shown=style,
        )
    finally:
        envs.close()
    report_at_end(args, folder, settings["workers"], evaluate_run, behavior_summary)
    return 0


BEHAVIOR_META = ("algo", "motions", "seed")  # what a behavior run's checkpoints record of its settings


def make_agent(config: TrainConfig, envs, run, seed: int) -> Agent | DAggerAgent:
    """The learner of `config.algo` over `envs` (a run's `RunEnvironments`: `run`)."""
    learner = DAggerAgent if config.algo == "dagger" else Agent
    return learner(config, envs, run.demonstrations, action_offset=run.standing_action, seed=seed)


# -- evaluate ------------------------------------------------------------------------


def evaluate_command(args) -> int:
    folder = RunFolder(args.run)
    folder.check_run()
    skill = train_skill.is_skill_run(folder)
    episodes = args.episodes or (train_skill.EVALUATION_EPISODES if skill else 20)
    check_number(episodes, "--episodes", low=1, high=10_000, integer=True)
    check_workers(args.workers)
    evaluate = train_skill.evaluate_skill_run if skill else evaluate_run
    print(json.dumps(evaluate(folder, episodes, args.seed, args.workers), indent=2))
    return 0


def _read_run(folder: RunFolder) -> tuple[dict, dict, TrainConfig]:
    """A run folder's settings, last training checkpoint and configuration."""
    checkpoint = folder.checkpoint()
    config = config_from_dict(checkpoint["meta"]["config"], where=str(folder.checkpoint_path))
    return folder.settings(), checkpoint, config


class RestoredRun:
    """A behavior run's last checkpoint, ready to evaluate: its environments
    and demonstrations (`run`), and on entering, evaluation workers and an
    agent with the checkpoint's state (closed again on leaving)."""

    def __init__(self, folder: RunFolder):
        self.settings, self.checkpoint, self.config = _read_run(folder)
        torch.set_num_threads(self.config.torch_threads)
        self.run = imitation_run(self.settings, self.config)

    def start(self, workers: int, seed: int) -> tuple[object, Agent]:
        run = self.run
        self.envs = run.vector_env(workers, evaluation=True)
        try:
            agent = make_agent(self.config, self.envs, run, seed)
            agent.load_state_dict(self.checkpoint["state"])
        except BaseException:
            self.envs.close()
            raise
        return self.envs, agent


def evaluate_run(folder: RunFolder | str | Path, episodes: int, seed: int, workers: int) -> dict:
    """Evaluate the run's last checkpoint and the standing robot
    (`learning.evaluation.behavior_report`); write and return `report.json`."""
    folder = folder if isinstance(folder, RunFolder) else RunFolder(folder)
    restored = RestoredRun(folder)
    envs, agent = restored.start(min(workers, episodes), seed)
    try:
        if isinstance(agent, DAggerAgent):
            report = _clone_evaluation(restored, agent, envs, min(workers, episodes), episodes, seed)
        else:
            report = behavior_report(agent, envs, restored.run.standing_action, episodes, seed)
    finally:
        envs.close()
    report = {**folder.settings(), **run_record(agent), **report}
    folder.write_report(report)
    return report


def _clone_evaluation(restored: RestoredRun, agent: DAggerAgent, envs, workers: int, episodes: int, seed: int) -> dict:
    """A clone's `clone_report`: on its one motion, or motion by motion
    (`evaluation.by_motion`, each on environments of that motion alone)."""
    motions, standing = restored.settings["motions"], restored.run.standing_action
    if len(motions) == 1:
        return clone_report(agent, envs, standing, episodes, seed)
    envs.close()  # the agent acts without them; each motion gets its own workers
    by_motion = {}
    # The demonstrations name each clip by its source (`envs.clip_arrays.motion_names`), in the motions' order:
    # a `.npz` motion's name there is not its path.
    for motion, demonstrated in zip(motions, agent.demos.motions):
        motion_envs = restored.run.vector_env(workers, evaluation=True, motions=[motion])
        try:
            report = clone_report(agent, motion_envs, standing, episodes, seed, [demonstrated])
            by_motion[motion] = report["evaluation"]
        finally:
            motion_envs.close()
    return {"evaluation": {"by_motion": by_motion, "episodes": episodes, "seed": seed}}


def plot_command(args) -> int:
    """One panel per metric, one line per run, against samples."""
    from hotu_drake.learning.logger import read_metrics

    keys = [k.strip() for k in args.keys.split(",") if k.strip()]
    check_number(args.smooth, "--smooth", low=1, high=10_000, integer=True)
    out = check_output_path(Path(args.out))
    curves = {}
    for run in map(Path, args.runs):
        if not (run / "metrics.jsonl").is_file():
            raise InputError(f"{run}: not a run folder (no metrics.jsonl)")
        rows = [r for r in read_metrics(run / "metrics.jsonl") if "samples_per_second" in r]
        settings = json.loads((run / "run.json").read_text()) if (run / "run.json").is_file() else {}
        curves[f"{run.name} ({settings.get('algo', '?')})"] = rows
    for key in keys:  # a run without a metric (D_I's reward of a one-level skill) is left out of its panel
        if not any(key in r for rows in curves.values() for r in rows):
            raise InputError(f"{', '.join(args.runs)}: no metric {key!r}")
    plt = pyplot("plot")
    figure, axes = plt.subplots(len(keys), 1, figsize=(7, 3 * len(keys)), squeeze=False)
    for ax, key in zip(axes[:, 0], keys):
        for label, rows in curves.items():
            points = [(r["samples"], r[key]) for r in rows if key in r and r[key] is not None]
            if not points:
                continue
            x, y = np.array(points).T
            window = min(args.smooth, len(y))
            smooth = np.convolve(y, np.ones(window) / window, mode="valid")
            ax.plot(x[window - 1 :], smooth, label=label)
        ax.set_xlabel("samples")
        ax.set_ylabel(key)
        ax.grid(alpha=0.3)
        ax.legend()
    save_figure(plt, figure, out, dpi=110)
    return 0


def trace_command(args) -> int:
    """One episode of the run's policy from a drop (as `evaluate`: the mean
    action, latents from the prior), its joints drawn against the
    references' for the joints the references move."""
    folder, out = RunFolder(args.run), check_output_path(Path(args.out))
    folder.check_run()
    if train_skill.is_skill_run(folder):
        raise InputError(
            f"{folder.path}: a skill run; trace draws a behavior run's joints (evaluate writes a skill's episode)"
        )
    check_number(args.seed, "--seed", low=0, high=2**31 - 1, integer=True)
    plt = pyplot("trace")
    restored = RestoredRun(folder)
    demos = restored.run.demonstrations
    parts = [p.strip() for p in args.parts.split(",") if p.strip()]
    for part in parts:
        if part not in demos.part_joints:
            has = ", ".join(demos.part_joints)
            raise InputError(f"--parts: {restored.settings['robot']} has no part {part!r} (has: {has})")
    envs, agent = restored.start(1, args.seed)
    try:
        columns = np.asarray(demos.meta["joint_columns"])
        observations, _ = envs.reset(seed=args.seed)
        frames, fell = [], False
        while True:
            action, _ = agent.act(observations, agent.latents.current(), deterministic=True)
            observations, _, terminated, truncated, info = envs.step(action)
            agent.latents.step(terminated | truncated)
            if terminated[0] or truncated[0]:  # the step's own state, not the next episode's first
                frames.append(info["final_obs"][0][columns])
                fell = bool(terminated[0])
                break
            frames.append(observations[0, columns])
    finally:
        envs.close()
    policy = np.degrees(np.array(frames))
    references = {name: np.degrees(m.joints) for name, m in demos.motions.items()}
    joints = [
        j
        for part in parts
        for j in demos.part_joints[part]
        if np.ptp(np.concatenate([r[:, j] for r in references.values()])) >= args.min_range
    ]
    if not joints:
        raise InputError(f"--parts: the references move none of {args.parts}'s joints by {args.min_range} degrees")
    rate = demos.control_rate
    figure, axes = plt.subplots(len(joints), 2, figsize=(10, 1.5 * len(joints) + 0.6), sharex="col", squeeze=False)
    for row, j in zip(axes, joints):
        for name, r in references.items():
            row[0].plot(np.arange(len(r)) / rate, r[:, j], label=name)
        row[1].plot(np.arange(len(policy)) / rate, policy[:, j], color="k")
        row[0].set_ylabel(demos.joint_names[j], fontsize=7)
        low = min(row[0].get_ylim()[0], row[1].get_ylim()[0])
        high = max(row[0].get_ylim()[1], row[1].get_ylim()[1])
        row[0].set_ylim(low, high)
        row[1].set_ylim(low, high)
    axes[0, 0].set_title("reference clips (degrees)")
    axes[0, 0].legend(fontsize=6)
    ending = "fell" if fell else "stayed up"
    axes[0, 1].set_title(f"{folder.path.name}: {len(policy) / rate:.0f} s from a drop, {ending}")
    axes[-1, 0].set_xlabel("s")
    axes[-1, 1].set_xlabel("s")
    save_figure(plt, figure, out, dpi=80)
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
