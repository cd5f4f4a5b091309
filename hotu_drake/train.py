"""Train behavior primitives, and evaluate them.

    python -m hotu_drake.train pretrain --robot h1 --hands none --motions wave,boxing,handshake \\
        --algo dail --steps 2000000 --workers 2 --out runs/h1_upper
    python -m hotu_drake.train pretrain --out runs/h1_upper --steps 4000000 --resume
    python -m hotu_drake.train evaluate runs/h1_upper [--episodes 20]
    python -m hotu_drake.train plot runs/h1_upper runs/h1_upper_amp --out curves.png [--keys style,episode_length]
    python -m hotu_drake.train trace runs/h1_upper --out trace.png [--parts shoulder,elbow] [--seed 7]
    python -m hotu_drake.train skill --task box_carry --llc runs/udh_dail --algo ours --steps 2000000 \
        --out runs/udh_box_ours     (see hotu_drake.train_skill)
    python -m hotu_drake.train finetune --robot h1 --skill runs/udh_box_ours --llc runs/h1_dail --steps 300000 \
        --out runs/h1_box           (see hotu_drake.train_finetune)

`pretrain` builds the run's demonstrations from the robot's reference clips
(on the Drake side, once), starts `--workers` environments
(`hotu_drake/Imitation-v0`, local processes or Ray actors with `--ray`),
warm-starts the policy by behavior cloning, and trains (`learning.agent`)
until `--steps` samples. The run folder gets:

- `checkpoint.pt`: everything to resume (every `--checkpoint-every`
  iterations, by default about three minutes' worth, and at the end);
- `policy.pt`: the policy alone, for a scenario's `!PolicyCheckpoint`;
- `metrics.jsonl` (one line of scalars per iteration; `tb/` too when
  TensorBoard is installed), `run.json` (the command's settings),
  `config.yaml` (the training configuration);
- `report.json`: the evaluation of the end (`evaluate`).

Killed at any point, `--resume` continues from the last checkpoint with the
same counters, optimiser state and random streams; only the iterations
after that checkpoint are done again.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from datetime import date
from pathlib import Path

import numpy as np
import torch
import yaml

from hotu_drake.cli import ArgumentParser, run_cli
from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.errors import InputError, check_choice, check_number
from hotu_drake.io import atomic_output, check_output_path, write_text_atomic
from hotu_drake.learning.checkpoint import read_checkpoint, save_checkpoint
from hotu_drake.learning.config import ALGORITHMS, TrainConfig, config_from_dict, load_config, preset

ENV_ID = "hotu_drake/Imitation-v0"
CHECKPOINT_SECONDS = 180.0  # the default checkpoint interval, as wall-clock


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.train", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    pre = sub.add_parser("pretrain", help="train a behavior controller on reference motions")
    pre.add_argument("--robot", help=f"the embodiment ({', '.join(EMBODIMENT_NAMES)})")
    pre.add_argument("--hands", help="full or none (default none)")
    pre.add_argument("--motions", help="comma-separated library motions and/or .npz clips of the robot")
    pre.add_argument("--algo", help=f"{' | '.join(ALGORITHMS)} (default dail)")
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
    from hotu_drake import train_finetune, train_skill

    train_skill.add_parser(sub)
    train_finetune.add_parser(sub)
    args = parser.parse_args(argv)
    if args.command == "skill":
        return train_skill.skill_command(args)
    if args.command == "finetune":
        return train_finetune.finetune_command(args)
    if args.command == "trace":
        return trace_command(args)
    if args.command == "pretrain":
        return pretrain(args)
    if args.command == "plot":
        return plot_command(args)
    return evaluate_command(args)


# -- pretrain ------------------------------------------------------------------------


def add_run_arguments(parser, preset_help: str, eval_episodes: int) -> None:
    """The options every training command takes (`pretrain`, `skill`, `finetune`)."""
    parser.add_argument("--steps", type=int, required=True, help="samples (control steps) to train for in total")
    parser.add_argument(
        "--workers", type=int, help="environment worker processes (default 2; on --resume, the run's own number)"
    )
    parser.add_argument(
        "--ray", metavar="ADDRESS", help="run the workers as Ray actors on this cluster ('auto', host:port)"
    )
    parser.add_argument("--out", required=True, help="the run folder (runs/NAME)")
    parser.add_argument("--config", help=f"a YAML file overriding {preset_help}")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--resume", action="store_true", help="continue the run in --out from its last checkpoint")
    parser.add_argument(
        "--checkpoint-every", type=int, help="iterations between checkpoints (default: ~3 minutes' worth)"
    )
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=eval_episodes,
        help=f"evaluation episodes at the end (default {eval_episodes}; 0: none)",
    )


def _settings(args) -> tuple[dict, TrainConfig]:
    """The run's settings and configuration, from the command line or, on
    resume, from the run folder (the command line may not contradict them)."""
    out = check_run_arguments(args)
    if args.resume:
        settings, checkpoint = resumed_run(out)
        for name in ("robot", "hands", "algo"):
            given = getattr(args, name)
            if given is not None and given != settings[name]:
                raise InputError(f"--{name} {given!r}: the run in {out} has {settings[name]!r}")
        if args.motions is not None and _motions(args.motions) != settings["motions"]:
            raise InputError(f"--motions: the run in {out} has {','.join(settings['motions'])}")
        if args.config:
            raise InputError(f"--config: the run in {out} keeps its configuration (config.yaml)")
        config = config_from_dict(checkpoint["meta"]["config"], where=str(out / "checkpoint.pt"))
        settings["workers"] = args.workers or settings.get("workers", 2)
        return settings, config
    if (out / "checkpoint.pt").exists() or (out / "run.json").exists():
        raise InputError(f"{out}: a run is already here (add --resume to continue it, or choose another --out)")
    check_output_path(out, folder=True)
    if not args.robot or not args.motions:
        raise InputError("pretrain needs --robot and --motions (or --resume with --out of a run)")
    robot = check_choice(args.robot, "--robot", EMBODIMENT_NAMES)
    hands = check_choice(args.hands or "none", "--hands", HANDS_VARIANTS)
    algo = check_choice(args.algo or "dail", "--algo", ALGORITHMS)
    config = load_config(args.config, algo) if args.config else preset(algo)
    settings = {
        "robot": robot,
        "hands": hands,
        "motions": _motions(args.motions),
        "algo": algo,
        "seed": args.seed,
        "workers": args.workers or 2,
    }
    return settings, config


def check_run_arguments(args) -> Path:
    """The numbers every training command takes, checked; the run folder."""
    check_number(args.steps, "--steps", low=1, high=10**10, integer=True)
    if args.workers is not None:
        check_number(args.workers, "--workers", low=1, high=64, integer=True)
    check_number(args.seed, "--seed", low=0, high=2**31 - 1, integer=True)
    check_number(args.eval_episodes, "--eval-episodes", low=0, high=100_000, integer=True)
    if args.checkpoint_every is not None:
        check_number(args.checkpoint_every, "--checkpoint-every", low=1, high=10**6, integer=True)
    return Path(args.out)


def resumed_run(out: Path) -> tuple[dict, dict]:
    """The settings and last training checkpoint of the run to resume in `out`."""
    if not (out / "checkpoint.pt").is_file() or not (out / "run.json").is_file():
        raise InputError(f"{out}: no run to resume here (no checkpoint.pt and run.json)")
    return json.loads((out / "run.json").read_text()), read_checkpoint(out / "checkpoint.pt", kind="training")


def _motions(text: str) -> list[str]:
    """Library names as given, clip paths made absolute (worker processes may start elsewhere)."""
    motions = [m.strip() for m in text.split(",") if m.strip()]
    if not motions:
        raise InputError("--motions: give at least one motion")
    return [str(Path(m).resolve()) if m.endswith(".npz") else m for m in motions]


def _env_options(settings: dict, config: TrainConfig, evaluation: bool = False) -> dict:
    env = config.environment
    options = {
        "robot": settings["robot"],
        "hands": settings["hands"],
        "motions": settings["motions"],
        "amp_history": env.amp_history,
        "termination_height": env.termination_height,
        "reference_init_probability": 0.0 if evaluation else env.reference_init_probability,
    }
    return options


def _demonstrations(settings: dict, config: TrainConfig):
    """The run's demonstrations and the observation's joint columns (Drake side, once)."""
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401 (registers the environments)
    from hotu_drake.envs.demonstrations import build_demonstrations

    env = gym.make(ENV_ID, **_env_options(settings, config))
    try:
        return build_demonstrations(env.unwrapped), env.unwrapped.standing_action()
    finally:
        env.close()


def _vector_env(settings: dict, config: TrainConfig, workers: int, ray: str | None, evaluation: bool = False):
    from hotu_drake.learning.rollout import EnvSpec, make_vector_env

    spec = EnvSpec(ENV_ID, _env_options(settings, config, evaluation))
    return make_vector_env(spec, workers, backend="ray" if ray else "local", address=ray)


def pretrain(args) -> int:
    from hotu_drake.learning.agent import Agent
    from hotu_drake.learning.logger import MetricsLog, Progress

    settings, config = _settings(args)
    torch.set_num_threads(config.torch_threads)
    demos, standing = _demonstrations(settings, config)  # bad motions fail here, before anything is written
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.resume:
        write_text_atomic(out / "run.json", json.dumps(settings, indent=2) + "\n")
        write_text_atomic(out / "config.yaml", yaml.safe_dump(config.to_dict(), sort_keys=False))
    envs = _vector_env(settings, config, settings["workers"], args.ray)
    try:
        agent = Agent(config, envs, demos, action_offset=standing, seed=settings["seed"])
        if args.resume:
            agent.load_state_dict(read_checkpoint(out / "checkpoint.pt", kind="training")["state"])
            print(
                f"resumed {out} at iteration {agent.counters['iteration']}, {agent.counters['samples']} samples",
                file=sys.stderr,
            )
        log = MetricsLog(out, agent.counters["iteration"] if args.resume else None)
        if not agent.counters["warm_started"]:
            start = time.perf_counter()
            stats = agent.warm_start()
            agent.counters["seconds"] += time.perf_counter() - start
            log.write(0, {**stats, "samples": 0, "warm_start_seconds": time.perf_counter() - start})
        _train(agent, args, settings, out, log, Progress(args.steps))
        log.close()
    finally:
        envs.close()
    if args.eval_episodes:
        report = evaluate_run(out, args.eval_episodes, seed=1000, workers=settings["workers"])
        print(json.dumps({k: report[k] for k in ("samples", "wall_clock_seconds")} | _summary(report)), file=sys.stderr)
    return 0


def _train(agent, args, settings: dict, out: Path, log, progress, save=None, shown=None) -> None:
    """Iterate until `args.steps` samples, logging every iteration and
    checkpointing (`save(agent, settings, out)`) about every
    `CHECKPOINT_SECONDS` and at the end; the progress line shows
    `shown(stats)` (default: each part group's style reward)."""
    save = save or _save
    shown = shown or (lambda stats: {g.name: stats.get(f"style/{g.name}", float("nan")) for g in agent.groups})
    every = args.checkpoint_every
    since = 0
    terms: dict[str, float] = {}
    while agent.counters["samples"] < args.steps:
        stats = agent.iteration()
        iteration = agent.counters["iteration"]
        log.write(iteration, stats)
        terms = shown(stats)
        progress.update(agent.counters["samples"], stats["samples_per_second"], terms)
        if every is None:  # about CHECKPOINT_SECONDS of iterations, from the first one's pace
            every = max(1, round(CHECKPOINT_SECONDS / max(stats["rollout_seconds"] + stats["update_seconds"], 1e-3)))
        since += 1
        if since >= every:
            save(agent, settings, out)
            since = 0
    save(agent, settings, out)
    progress.update(
        agent.counters["samples"], agent.counters["samples"] / max(agent.counters["seconds"], 1e-9), terms, done=True
    )


def _save(agent, settings: dict, out: Path, extra_meta: dict | None = None) -> None:
    """The training checkpoint, and the policy alone next to it."""
    latent = agent.config.latent
    prior = {"size": latent.size, "resample_min": latent.resample_min, "resample_max": latent.resample_max}
    meta = {
        "algo": settings["algo"],
        "motions": settings["motions"],
        "seed": settings["seed"],
        "groups": [g.to_dict() for g in agent.groups],
        "layout": agent.demos.layout.to_dict(),
        "samples": agent.counters["samples"],
        "iteration": agent.counters["iteration"],
        "config": agent.config.to_dict(),
        **(extra_meta or {}),
    }
    policy = agent.model.policy
    robot, hands, rate = settings["robot"], settings["hands"], agent.demos.control_rate
    save_checkpoint(
        out / "checkpoint.pt", policy, robot, hands, meta, latent=prior, control_rate=rate, state=agent.state_dict()
    )
    save_checkpoint(out / "policy.pt", policy, robot, hands, meta, latent=prior, control_rate=rate)


# -- evaluate ------------------------------------------------------------------------


def evaluate_command(args) -> int:
    from hotu_drake import train_skill

    run = _run_folder(args.run)
    skill = train_skill.is_skill_run(run)
    episodes = args.episodes or (train_skill.EVALUATION_EPISODES if skill else 20)
    check_number(episodes, "--episodes", low=1, high=10_000, integer=True)
    if args.workers is not None:
        check_number(args.workers, "--workers", low=1, high=64, integer=True)
    evaluate = train_skill.evaluate_skill_run if skill else evaluate_run
    report = evaluate(run, episodes, args.seed, args.workers)
    print(json.dumps(report, indent=2))
    return 0


def _run_folder(path: str) -> Path:
    """`path` as a run folder: one with a training checkpoint and its settings."""
    run = Path(path)
    if not (run / "checkpoint.pt").is_file() or not (run / "run.json").is_file():
        raise InputError(f"{run}: not a run folder (no checkpoint.pt and run.json)")
    return run


def _read_run(run: Path) -> tuple[dict, dict, TrainConfig]:
    """A run folder's settings, last training checkpoint and configuration."""
    settings = json.loads((run / "run.json").read_text())
    checkpoint = read_checkpoint(run / "checkpoint.pt", kind="training")
    config = config_from_dict(checkpoint["meta"]["config"], where=str(run / "checkpoint.pt"))
    return settings, checkpoint, config


def evaluate_run(run: Path, episodes: int, seed: int, workers: int) -> dict:
    """Evaluate the run's last checkpoint and the standing robot (see
    `learning.evaluation`); write and return `report.json`."""
    from hotu_drake.learning.agent import Agent
    from hotu_drake.learning.evaluation import evaluate, standing_policy

    settings, checkpoint, config = _read_run(run)
    torch.set_num_threads(config.torch_threads)
    demos, standing = _demonstrations(settings, config)
    envs = _vector_env(settings, config, min(workers, episodes), None, evaluation=True)
    try:
        agent = Agent(config, envs, demos, action_offset=standing, seed=seed)
        agent.load_state_dict(checkpoint["state"])
        columns = np.asarray(demos.meta["joint_columns"])

        def style(amp: dict) -> np.ndarray:
            return agent.combine(agent.group_style_rewards(agent.group_windows(amp)))

        latent = config.latent
        groups = list(agent.model.policy.config.latent_sizes)
        common = {"episodes": episodes, "seed": seed}
        learned = evaluate(
            envs,
            lambda obs, z: agent.act(obs, z, deterministic=True)[0],
            demos,
            columns,
            style,
            latent_groups=groups,
            latent_size=latent.size,
            resample=(latent.resample_min, latent.resample_max),
            **common,
        )
        baseline = evaluate(envs, standing_policy(standing), demos, columns, style, **common)
    finally:
        envs.close()
    report = {
        **settings,
        "samples": agent.counters["samples"],
        "iterations": agent.counters["iteration"],
        "wall_clock_seconds": round(agent.counters["seconds"], 1),
        "evaluation": {"policy": learned, "standing": baseline, "episodes": episodes, "seed": seed},
        "closer_than_standing_deg": {
            part: round(baseline["joint_distance_deg"][part] - learned["joint_distance_deg"][part], 2)
            for part in learned["joint_distance_deg"]
        },
        "better_coverage_than_standing_deg": {
            part: round(baseline["coverage_deg"][part] - learned["coverage_deg"][part], 2)
            for part in learned["coverage_deg"]
        },
        "machine": {"cpu_cores": _cores(), "python": platform.python_version(), "date": date.today().isoformat()},
    }
    write_text_atomic(run / "report.json", json.dumps(report, indent=2) + "\n")
    return report


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
    plt = _pyplot("plot")
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
    _save_figure(plt, figure, out, dpi=110)
    return 0


def _pyplot(command: str):
    """matplotlib's pyplot without a display, or the error that says how to get it."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError(f"{command} needs matplotlib (pip install matplotlib)") from None
    return plt


def _save_figure(plt, figure, out: Path, dpi: int) -> None:
    """`figure` as a PNG at `out`, written whole or not at all."""
    figure.tight_layout()
    with atomic_output(out) as tmp:
        figure.savefig(tmp, format="png", dpi=dpi)
    plt.close(figure)
    print(f"wrote {out}", file=sys.stderr)


def trace_command(args) -> int:
    """One episode of the run's policy from a drop (as `evaluate`: the mean
    action, latents from the prior), its joints drawn against the
    references' for the joints the references move."""
    from hotu_drake import train_skill
    from hotu_drake.learning.agent import Agent

    run, out = _run_folder(args.run), check_output_path(Path(args.out))
    if train_skill.is_skill_run(run):
        raise InputError(f"{run}: a skill run; trace draws a behavior run's joints (evaluate writes a skill's episode)")
    check_number(args.seed, "--seed", low=0, high=2**31 - 1, integer=True)
    plt = _pyplot("trace")
    settings, checkpoint, config = _read_run(run)
    demos, standing = _demonstrations(settings, config)
    parts = [p.strip() for p in args.parts.split(",") if p.strip()]
    for part in parts:
        if part not in demos.part_joints:
            raise InputError(f"--parts: {settings['robot']} has no part {part!r} (has: {', '.join(demos.part_joints)})")
    envs = _vector_env(settings, config, 1, None, evaluation=True)
    try:
        agent = Agent(config, envs, demos, action_offset=standing, seed=args.seed)
        agent.load_state_dict(checkpoint["state"])
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
    axes[0, 1].set_title(f"{run.name}: {len(policy) / rate:.0f} s from a drop, {ending}")
    axes[-1, 0].set_xlabel("s")
    axes[-1, 1].set_xlabel("s")
    _save_figure(plt, figure, out, dpi=80)
    return 0


def _summary(report: dict) -> dict:
    policy, standing = report["evaluation"]["policy"], report["evaluation"]["standing"]
    return {
        "fall_rate": policy["fall_rate"],
        "normalized_return": round(policy["normalized_return"], 3),
        "standing_normalized_return": round(standing["normalized_return"], 3),
        "joint_distance_deg": round(policy["joint_distance_deg"]["all"], 2),
        "standing_joint_distance_deg": round(standing["joint_distance_deg"]["all"], 2),
        "coverage_deg": round(policy["coverage_deg"]["all"], 2),
        "standing_coverage_deg": round(standing["coverage_deg"]["all"], 2),
    }


def _cores() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


if __name__ == "__main__":
    sys.exit(run_cli(main))
