"""Train loco-manipulation skills, and evaluate them (`python -m hotu_drake.train skill`).

    python -m hotu_drake.train skill --task box_carry --robot udh --llc runs/udh_dail --algo ours \\
        --steps 2000000 --workers 2 --out runs/udh_box_ours
    python -m hotu_drake.train skill --task box_carry --robot udh --algo amp --steps 2000000 --out runs/udh_box_amp
    python -m hotu_drake.train skill --out runs/udh_box_ours --steps 4000000 --resume
    python -m hotu_drake.train evaluate runs/udh_box_ours [--episodes 100]

`ours` and `ase` train a high-level policy over a frozen behavior run
(`--llc`, trained by `train pretrain` on the same robot; DAIL for `ours`,
ASE for `ase`), `amp` and `pmp` a one-level policy from scratch with the
task reward and their own discriminators (`learning.skill_config`). The
environment is the task's (`hotu_drake/BoxCarry-v0`, `DrillGrasp-v0`),
with the curriculum of the configuration's `environment.task`.

The run folder has the `train pretrain` layout (`checkpoint.pt`,
`policy.pt`, `metrics.jsonl` with every reward term per iteration,
`run.json`, `config.yaml`, `report.json`) plus `best_episode.yaml`: a
scenario of the evaluation's best episode (its start and target, the
run's checkpoints), which `python -m hotu_drake.simulate ... --html`
turns into a Meshcat replay.
"""

from __future__ import annotations

import copy
import functools
import json
import platform
import sys
from datetime import date
from pathlib import Path

import numpy as np
import torch
import yaml

from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.errors import InputError, check_choice
from hotu_drake.io import check_output_path, write_text_atomic
from hotu_drake.learning.checkpoint import CheckpointError, read_checkpoint, save_checkpoint
from hotu_drake.learning.skill_config import (
    SKILL_ALGORITHMS,
    TASKS,
    TRANSFER_TASKS,
    TWO_LEVEL,
    SkillConfig,
    load_skill_config,
    skill_config_from_dict,
    skill_preset,
)
from hotu_drake.train import (
    CHECKPOINT_SECONDS,
    _cores,
    _motions,
    _save,
    _train,
    add_run_arguments,
    check_run_arguments,
    resumed_run,
)

# The motions each task environment learns from by default: its human-object demonstration and a walk.
TASK_MOTIONS = {"box_carry": ["walk", "box_carry"], "drill_grasp": ["walk", "drill_grasp"]}
# The hands a one-level method's robot has by default: the drill grasp is about the fingers.
TASK_HANDS = {"box_carry": "none", "drill_grasp": "full"}
# Which behavior controller each two-level method drives.
CONTROLLER_ALGO = {"ours": "dail", "ase": "ase"}
EVALUATION_EPISODES = 100


def add_parser(sub) -> None:
    skill = sub.add_parser("skill", help="train a loco-manipulation skill (two-level over --llc, or one-level)")
    skill.add_argument("--task", help=f"{' | '.join(TASKS)}")
    skill.add_argument("--robot", help=f"the embodiment ({', '.join(EMBODIMENT_NAMES)}; default: the --llc's)")
    skill.add_argument("--hands", help="full or none (default: the --llc's, else none; full for drill_grasp)")
    skill.add_argument("--llc", help="the behavior run a two-level method drives (a run folder of train pretrain)")
    skill.add_argument("--algo", help=f"{' | '.join(SKILL_ALGORITHMS)} (default ours)")
    skill.add_argument("--motions", help="the demonstrations (default: the task's, e.g. walk,box_carry)")
    add_run_arguments(skill, "the method's preset (learning.skill_config)", EVALUATION_EPISODES)


def is_skill_run(run: Path) -> bool:
    """A run of `train skill` or `train finetune` (a fine-tune is a skill run on tracking)."""
    settings = json.loads((run / "run.json").read_text())
    return settings.get("command") in ("skill", "finetune")


def read_skill_run(run: Path) -> tuple[dict, dict, SkillConfig]:
    """A skill run's settings, training checkpoint and configuration."""
    settings = json.loads((run / "run.json").read_text())
    checkpoint = read_checkpoint(run / "checkpoint.pt", kind="training")
    return settings, checkpoint, skill_config_from_dict(checkpoint["meta"]["config"], where=str(run / "checkpoint.pt"))


# -- settings ---------------------------------------------------------------------


@functools.lru_cache(maxsize=4)
def load_controller(path: str):
    """The frozen behavior controller of `--llc`, or the error that names it (read once per path)."""
    from hotu_drake.learning.low_level import LowLevelController

    try:
        return LowLevelController.load(Path(path))
    except CheckpointError as error:
        raise InputError(f"--llc: {error}") from None


def controller_robot(args, wanted: str, who: str) -> tuple[str, str]:
    """The robot and hands of `--llc` (a `wanted` controller, which `who`
    drives), as `--robot` and `--hands` may also say; `InputError` otherwise."""
    controller = load_controller(args.llc)
    if controller.config.algo != wanted:
        raise InputError(f"--llc {args.llc}: a {controller.config.algo} controller; {who} drives a {wanted} one")
    robot = check_choice(args.robot or controller.embodiment, "--robot", EMBODIMENT_NAMES)
    hands = check_choice(args.hands or controller.hands, "--hands", HANDS_VARIANTS)
    if (robot, hands) != (controller.embodiment, controller.hands):
        raise InputError(
            f"--llc {args.llc}: a controller of {controller.embodiment} hands={controller.hands}, "
            f"not of {robot} hands={hands}"
        )
    return robot, hands


def resumed_skill_run(args, command: str, names: tuple[str, ...]) -> tuple[dict, SkillConfig]:
    """The settings and configuration of the `command` run to resume in
    `args.out`; `InputError` if the arguments in `names` (or `--llc`,
    `--config`) ask for something else than the run has."""
    out = Path(args.out)
    settings, checkpoint = resumed_run(out)
    if settings.get("command") != command:
        raise InputError(f"{out}: not a {command} run (resume it with train {settings.get('command', 'pretrain')})")
    for name in names:
        given = getattr(args, name)
        if given is not None and given != settings[name]:
            raise InputError(f"--{name} {given!r}: the run in {out} has {settings[name]!r}")
    if args.llc is not None and str(Path(args.llc).resolve()) != settings["llc"]:
        raise InputError(f"--llc: the run in {out} drives {settings['llc']}")
    if args.config:
        raise InputError(f"--config: the run in {out} keeps its configuration (config.yaml)")
    config = skill_config_from_dict(checkpoint["meta"]["config"], where=str(out / "checkpoint.pt"))
    settings["workers"] = args.workers or settings.get("workers", 2)
    return settings, config


def _settings(args) -> tuple[dict, SkillConfig]:
    out = check_run_arguments(args)
    if args.resume:
        return resumed_skill_run(args, "skill", ("task", "robot", "hands", "algo"))
    if (out / "checkpoint.pt").exists() or (out / "run.json").exists():
        raise InputError(f"{out}: a run is already here (add --resume to continue it, or choose another --out)")
    check_output_path(out, folder=True)
    if not args.task:
        raise InputError("skill needs --task (or --resume with --out of a run)")
    task = check_choice(args.task, "--task", tuple(TASKS))
    algo = check_choice(args.algo or "ours", "--algo", SKILL_ALGORITHMS)
    config = load_skill_config(args.config, algo) if args.config else skill_preset(algo)
    llc = None
    if algo in TWO_LEVEL:
        if not args.llc:
            raise InputError(f"--algo {algo} drives a behavior controller: give --llc (a train pretrain run folder)")
        robot, hands = controller_robot(args, CONTROLLER_ALGO[algo], f"--algo {algo}")
        llc = str(Path(args.llc).resolve())
    else:
        if args.llc:
            raise InputError(f"--llc: {algo} is one level (its policy sets the PD targets); --llc is for ours and ase")
        robot = check_choice(args.robot or "udh", "--robot", EMBODIMENT_NAMES)
        hands = check_choice(args.hands or TASK_HANDS[task], "--hands", HANDS_VARIANTS)
    settings = {
        "command": "skill",
        "task": task,
        "robot": robot,
        "hands": hands,
        "algo": algo,
        "llc": llc,
        "motions": _motions(args.motions) if args.motions else TASK_MOTIONS[task],
        "seed": args.seed,
        "workers": args.workers or 2,
    }
    return settings, config


def _history(settings: dict, config: SkillConfig) -> int:
    """The AMP window the style judges take: the controller's, or the one-level run's own."""
    if settings["algo"] in TWO_LEVEL:
        return load_controller(settings["llc"]).history
    return config.one_level.environment.amp_history


def env_id(settings: dict) -> str:
    """The run's environment: the task's, or its transfer twin for a fine-tune (references to track)."""
    return TRANSFER_TASKS[settings["task"]] if settings.get("references") else TASKS[settings["task"]]


def _env_options(settings: dict, config: SkillConfig, evaluation: bool = False) -> dict:
    e = config.environment
    if settings.get("references"):  # a fine-tune tracks references (held-out ones in evaluation)
        clips = {"references": settings["eval_references" if evaluation else "references"]}
    else:
        clips = {"motions": settings["motions"]}
    return {
        "robot": settings["robot"],
        "hands": settings["hands"],
        **clips,
        "amp_history": _history(settings, config),
        "termination_height": e.termination_height,
        "reference_init_probability": 0.0 if evaluation else e.reference_init_probability,
        **e.task,
    }


def make_env(settings: dict, config: SkillConfig, evaluation: bool = False):
    """One task environment in this process (Drake side); a task keyword
    the environment does not take is the configuration's error."""
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401 (registers the environments)

    try:
        return gym.make(env_id(settings), **_env_options(settings, config, evaluation))
    except TypeError as error:
        raise InputError(f"the task does not take these keywords ({error})", field="environment.task") from None


def _demonstrations(settings: dict, config: SkillConfig):
    """What the run learns from, built once here: the demonstrations' s_I
    transitions (two-level) or the clips' arrays (one-level), and the
    robot's standing action (the one-level policy's offset, and the
    evaluation's baseline)."""
    from hotu_drake.envs.demonstrations import build_demonstrations
    from hotu_drake.learning.interaction import transitions

    env = make_env(settings, config)
    try:
        inner = env.unwrapped
        if settings["algo"] in TWO_LEVEL and not config.uses_interaction:
            return None, inner.standing_action()
        if settings["algo"] in TWO_LEVEL:
            sequences = inner.interaction_sequences()
            if config.uses_interaction and not sequences:
                kind = inner._object.kind
                raise InputError(f"--motions: none of {', '.join(settings['motions'])} carries a {kind} track for D_I")
            return (transitions(sequences) if sequences else None), inner.standing_action()
        return build_demonstrations(inner), inner.standing_action()
    finally:
        env.close()


def _vector_env(settings: dict, config: SkillConfig, workers: int, ray: str | None, evaluation: bool = False):
    from hotu_drake.learning.rollout import EnvSpec, make_vector_env

    spec = EnvSpec(env_id(settings), _env_options(settings, config, evaluation))
    return make_vector_env(spec, workers, backend="ray" if ray else "local", address=ray)


def _one_level_config(config: SkillConfig):
    """The one-level methods' own configuration, with eq. (3)'s weights (no D_I)."""
    one = copy.deepcopy(config.one_level)
    one.task_weight, one.style.weight = config.reward.task, config.reward.style
    one.environment.termination_height = config.environment.termination_height
    one.environment.reference_init_probability = config.environment.reference_init_probability
    return one.validate()


def _agent(settings: dict, config: SkillConfig, envs, demos, standing, seed: int):
    if settings["algo"] in TWO_LEVEL:
        from hotu_drake.learning.skill_agent import SkillAgent

        return SkillAgent(config, envs, load_controller(settings["llc"]), demos, seed=seed)
    from hotu_drake.learning.agent import Agent

    return Agent(_one_level_config(config), envs, demos, action_offset=standing, seed=seed)


# -- train ------------------------------------------------------------------------------


def skill_command(args) -> int:
    settings, config = _settings(args)
    return train_skill_run(settings, config, args)


def train_skill_run(settings: dict, config: SkillConfig, args) -> int:
    """Train (or resume) the run in `args.out` to `args.steps` samples, then evaluate it."""
    from hotu_drake.learning.logger import MetricsLog, Progress

    torch.set_num_threads(config.torch_threads)
    demos, standing = _demonstrations(settings, config)  # bad motions or task keywords fail here
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.resume:
        write_text_atomic(out / "run.json", json.dumps(settings, indent=2) + "\n")
        write_text_atomic(out / "config.yaml", yaml.safe_dump(config.to_dict(), sort_keys=False))
    envs = _vector_env(settings, config, settings["workers"], args.ray)
    try:
        agent = _agent(settings, config, envs, demos, standing, settings["seed"])
        if args.resume:
            agent.load_state_dict(read_checkpoint(out / "checkpoint.pt", kind="training")["state"])
            print(f"resumed {out} at {agent.counters['samples']} samples", file=sys.stderr)
        log = MetricsLog(out, agent.counters["iteration"] if args.resume else None)
        if settings["algo"] not in TWO_LEVEL and not agent.counters["warm_started"]:
            log.write(0, {**agent.warm_start(), "samples": 0})

        def shown(stats: dict) -> dict:
            keys = ("reward/task", "reward/interaction", "reward/style", "success_rate", "task", "style")
            return {k.split("/")[-1]: stats[k] for k in keys if k in stats}

        def save(agent, settings: dict, out: Path) -> None:
            _save_skill(agent, settings, out, config)

        _train(agent, args, settings, out, log, Progress(args.steps, label="reward"), save, shown)
        log.close()
    finally:
        envs.close()
    if args.eval_episodes:
        report = evaluate_skill_run(out, args.eval_episodes, seed=1000, workers=settings["workers"])
        print(json.dumps({k: report[k] for k in ("samples", "wall_clock_seconds")} | summary(report)), file=sys.stderr)
    return 0


def _save_skill(agent, settings: dict, out: Path, config: SkillConfig) -> None:
    """The training checkpoint and the high level (or one-level policy) alone next to it."""
    from hotu_drake.systems.interaction_graph import GOAL_SIZE

    if settings["algo"] not in TWO_LEVEL:
        _save(agent, settings, out, {"kind": "task_policy", "task": settings["task"], "config": config.to_dict()})
        return
    meta = {
        "kind": "skill",
        "algo": settings["algo"],
        "task": settings["task"],
        "llc": settings["llc"],
        "llc_groups": list(agent.groups),
        "latent_size": agent.latent_size,
        "hold_steps": config.high_level.hold_steps,
        "interaction_size": int(agent._interaction.shape[1]),
        # A transfer layer's reference features (0 for a skill): what follows the goal in its observation.
        "reference_size": int(agent.envs.single_observation_space.shape[0]) - agent.llc.observation_size - GOAL_SIZE,
        "motions": settings["motions"],
        "seed": settings["seed"],
        "samples": agent.counters["samples"],
        "iteration": agent.counters["iteration"],
        "config": config.to_dict(),
    }
    policy, robot, hands = agent.model.policy, settings["robot"], settings["hands"]
    save_checkpoint(out / "checkpoint.pt", policy, robot, hands, meta, latent={}, state=agent.state_dict())
    save_checkpoint(out / "policy.pt", policy, robot, hands, meta, latent={})


# -- evaluate ----------------------------------------------------------------------------


def evaluate_skill_run(run: Path, episodes: int, seed: int, workers: int) -> dict:
    """The run's last checkpoint on `episodes` seeded episodes (each its own
    start and target): success rate, normalised return, falls, next to the
    robot just standing on the same tasks; writes `report.json` and the
    scenario of the best episode (`best_episode.yaml`)."""
    from hotu_drake.learning.evaluation import evaluate_task, standing_policy

    settings, checkpoint, config = read_skill_run(run)
    torch.set_num_threads(config.torch_threads)
    demos, standing = _demonstrations(settings, config)
    envs = _vector_env(settings, config, min(workers, episodes), None, evaluation=True)
    try:
        agent = _agent(settings, config, envs, demos, standing, seed)
        agent.load_state_dict(checkpoint["state"])
        if settings["algo"] in TWO_LEVEL:
            from hotu_drake.learning.skill_agent import SkillController

            controller = SkillController(agent)
        else:

            def controller(observations, interaction, started):
                return agent.act(observations, {}, deterministic=True)[0]

        task_reward = "task_reward" if settings.get("references") else None  # a fine-tune's reward is tracking
        result = evaluate_task(envs, controller, episodes, seed, task_reward=task_reward)
        standing_result = evaluate_task(envs, standing_policy(standing), episodes, seed, task_reward=task_reward)
    finally:
        envs.close()
    standing_result.pop("episodes_detail")
    detail = result.pop("episodes_detail")
    best = max(range(len(detail)), key=lambda i: (detail[i]["success"], detail[i]["return"]))
    report = {
        **settings,
        "samples": agent.counters["samples"],
        "iterations": agent.counters["iteration"],
        "wall_clock_seconds": round(agent.counters["seconds"], 1),
        "evaluation": {**result, "seed": seed, "best_episode": detail[best], "standing": standing_result},
        "curriculum": config.environment.task,
        "machine": {"cpu_cores": _cores(), "python": platform.python_version(), "date": date.today().isoformat()},
    }
    write_text_atomic(run / "report.json", json.dumps(report, indent=2) + "\n")
    if "goal" in detail[best]:
        write_text_atomic(run / "best_episode.yaml", episode_scenario(run, settings, config, detail[best]["goal"]))
    return report


def episode_scenario(run: Path, settings: dict, config: SkillConfig, goal: dict) -> str:
    """A scenario (YAML) of one evaluation episode's task: the robot dropped
    as at an episode's start, the object at its start, the target marker,
    and the run's checkpoints driving the robot for the episode's 10 s."""
    from hotu_drake.objects import SceneObject
    from hotu_drake.scenario import InitialCondition, PolicyCheckpoint, Scenario, SkillCheckpoint

    start, target = [float(x) for x in goal["start_position"]], [float(x) for x in goal["target"]]
    objects = []
    if settings["task"] == "box_carry":
        objects.append(SceneObject("box", "box", start, float(goal["start_yaw"]), held=True, target=target))
    else:
        table = float(config.environment.task.get("table_distance", 0.65))
        objects.append(SceneObject("table", "table", [table + 0.15, 0.0, 0.0], fixed=True))
        objects.append(SceneObject("drill", "drill", start, float(goal["start_yaw"]), target=target))
    if settings["algo"] in TWO_LEVEL:
        driver = SkillCheckpoint(str((run / "policy.pt").resolve()), str(Path(settings["llc"]) / "policy.pt"))
        if settings.get("references"):  # a transfer layer: the held-out reference of this episode
            driver.reference = _episode_reference(settings["eval_references"], target)
    else:
        driver = PolicyCheckpoint(str((run / "policy.pt").resolve()), latents="zero")
    scenario = Scenario(
        embodiment=settings["robot"],
        hands=settings["hands"],
        initial=InitialCondition(drop_height=0.0),
        driver=driver,
        objects=objects,
        duration=10.0,
    )
    return f"# The best evaluation episode of {run.name}: its start and target.\n" + scenario.to_yaml()


def _episode_reference(references: list[str], target: list[float]) -> str:
    """The reference clip whose target track is `target` (its episode's)."""
    from hotu_drake.motion.clip import MotionClip
    from hotu_drake.systems.transfer_reference import TARGET_TRACK, track_index

    for path in references:
        clip = MotionClip.load(path)
        if np.allclose(clip.object_poses[0, track_index(clip, TARGET_TRACK), :3], target, atol=1e-6):
            return path
    raise ValueError(f"no reference of {references} has the target {target}")


def summary(report: dict) -> dict:
    e = report["evaluation"]
    return {
        "success_rate": e["success_rate"],
        "normalized_return": round(e["normalized_return"], 3),
        "fall_rate": e["fall_rate"],
        "mean_episode_steps": round(e["mean_episode_steps"], 1),
        "standing_success_rate": e["standing"]["success_rate"],
        "standing_normalized_return": round(e["standing"]["normalized_return"], 3),
    }


__all__ = ["CHECKPOINT_SECONDS", "add_parser", "evaluate_skill_run", "skill_command"]
