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
import sys
from pathlib import Path

import numpy as np
import torch

from hotu_drake.commands.run_options import (
    add_run_arguments,
    check_run_arguments,
    controller_robot,
    load_controller,
    motion_list,
    report_at_end,
    resumed_settings,
)
from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.envs.runs import RunEnvironments, skill_run
from hotu_drake.envs.tasks import BOX_CARRY_MOTIONS, DRILL_GRASP_MOTIONS
from hotu_drake.errors import InputError, check_choice
from hotu_drake.io import write_text_atomic
from hotu_drake.learning.agent import Agent
from hotu_drake.learning.evaluation import task_report, task_summary
from hotu_drake.learning.skill_agent import SkillAgent
from hotu_drake.learning.skill_config import (
    SKILL_ALGORITHMS,
    TASKS,
    TWO_LEVEL,
    SkillConfig,
    load_skill_config,
    skill_config_from_dict,
    skill_preset,
)
from hotu_drake.learning.trainer import RunFolder, run_record, train
from hotu_drake.systems.interaction_graph import GOAL_SIZE

# The motions each task environment learns from by default: its human-object demonstrations and a walk.
TASK_MOTIONS = {"box_carry": list(BOX_CARRY_MOTIONS), "drill_grasp": list(DRILL_GRASP_MOTIONS)}
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


def is_skill_run(folder: RunFolder) -> bool:
    """A run of `train skill` or `train finetune` (a fine-tune is a skill run on tracking)."""
    return folder.settings().get("command") in ("skill", "finetune")


def read_skill_run(folder: RunFolder) -> tuple[dict, dict, SkillConfig]:
    """A skill run's settings, training checkpoint and configuration."""
    checkpoint = folder.checkpoint()
    config = skill_config_from_dict(checkpoint["meta"]["config"], where=str(folder.checkpoint_path))
    return folder.settings(), checkpoint, config


# -- settings ---------------------------------------------------------------------


def resumed_skill_run(args, folder: RunFolder, command: str, names: tuple[str, ...]) -> tuple[dict, SkillConfig]:
    """The settings and configuration of the `command` run to resume in `folder`."""
    settings, checkpoint = resumed_settings(args, folder, names, command)
    return settings, skill_config_from_dict(checkpoint["meta"]["config"], where=str(folder.checkpoint_path))


def _settings(args, folder: RunFolder) -> tuple[dict, SkillConfig]:
    if args.resume:
        return resumed_skill_run(args, folder, "skill", ("task", "robot", "hands", "algo"))
    folder.check_new()
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
        "motions": motion_list(args.motions) if args.motions else TASK_MOTIONS[task],
        "seed": args.seed,
        "workers": args.workers or 2,
    }
    return settings, config


def environments(settings: dict, config: SkillConfig) -> RunEnvironments:
    """The run's task environments and what it learns from; the style judges
    take the controller's AMP window, or the one-level run's own."""
    if settings["algo"] in TWO_LEVEL:
        history = load_controller(settings["llc"]).history
    else:
        history = config.one_level.environment.amp_history
    return skill_run(settings, config, history)


def _one_level_config(config: SkillConfig):
    """The one-level methods' own configuration, with eq. (3)'s weights (no D_I)."""
    one = copy.deepcopy(config.one_level)
    one.task_weight, one.style.weight = config.reward.task, config.reward.style
    one.environment.termination_height = config.environment.termination_height
    one.environment.reference_init_probability = config.environment.reference_init_probability
    return one.validate()


def make_agent(settings: dict, config: SkillConfig, run: RunEnvironments, envs, seed: int) -> Agent | SkillAgent:
    """The run's learner: the high level over the frozen controller, or a one-level policy."""
    if settings["algo"] in TWO_LEVEL:
        return SkillAgent(config, envs, load_controller(settings["llc"]), run.interaction, seed=seed)
    return Agent(_one_level_config(config), envs, run.demonstrations, action_offset=run.standing_action, seed=seed)


# -- train ------------------------------------------------------------------------------


def skill_command(args) -> int:
    folder = check_run_arguments(args)
    settings, config = _settings(args, folder)
    return train_skill_run(settings, config, args, folder)


def train_skill_run(settings: dict, config: SkillConfig, args, folder: RunFolder) -> int:
    """Train (or resume) the run in `folder` to `args.steps` samples, then evaluate it."""
    torch.set_num_threads(config.torch_threads)
    run = environments(settings, config)  # bad motions or task keywords fail here
    if not args.resume:
        folder.start(settings, config.to_dict())
    envs = run.vector_env(settings["workers"], args.ray)
    try:
        agent = make_agent(settings, config, run, envs, settings["seed"])
        if args.resume:
            agent.load_state_dict(folder.checkpoint()["state"])
            print(f"resumed {folder.path} at {agent.counters['samples']} samples", file=sys.stderr)

        def shown(stats: dict) -> dict:
            keys = ("reward/task", "reward/interaction", "reward/style", "success_rate", "task", "style")
            return {k.split("/")[-1]: stats[k] for k in keys if k in stats}

        def save() -> None:
            save_skill(agent, folder, settings, config)

        train(
            agent,
            folder,
            args.steps,
            save,
            resume=args.resume,
            checkpoint_every=args.checkpoint_every,
            shown=shown,
            label="reward",
        )
    finally:
        envs.close()
    report_at_end(args, folder, settings["workers"], evaluate_skill_run, task_summary)
    return 0


def save_skill(agent: Agent | SkillAgent, folder: RunFolder, settings: dict, config: SkillConfig) -> None:
    """The training checkpoint and the high level (or one-level policy) alone next to it."""
    if settings["algo"] not in TWO_LEVEL:
        extra = {"kind": "task_policy", "task": settings["task"], "config": config.to_dict()}  # the skill's config
        folder.save(agent, settings, ("algo", "motions", "seed"), extra)
        return
    # A transfer layer's reference features (0 for a skill): what follows the goal in its observation.
    task_size = agent.task_envs.single_observation_space.shape[0]
    reference_size = int(task_size - agent.llc.observation_size - GOAL_SIZE)
    folder.save(agent, settings, ("algo", "task", "llc", "motions", "seed"), {"reference_size": reference_size})


# -- evaluate ----------------------------------------------------------------------------


def evaluate_skill_run(folder: RunFolder | str | Path, episodes: int, seed: int, workers: int) -> dict:
    """The run's last checkpoint on `episodes` seeded episodes (each its own
    start and target): success rate, normalised return, falls, next to the
    robot just standing on the same tasks (`learning.evaluation.task_report`);
    writes `report.json` and the scenario of the best episode (`best_episode.yaml`)."""
    folder = folder if isinstance(folder, RunFolder) else RunFolder(folder)
    settings, checkpoint, config = read_skill_run(folder)
    torch.set_num_threads(config.torch_threads)
    run = environments(settings, config)
    envs = run.vector_env(min(workers, episodes), evaluation=True)
    try:
        agent = make_agent(settings, config, run, envs, seed)
        agent.load_state_dict(checkpoint["state"])
        if settings["algo"] in TWO_LEVEL:
            controller = agent.controller()
        else:

            def controller(observations, interaction, started):
                return agent.act(observations, {}, deterministic=True)[0]

        task_reward = "task_reward" if settings.get("references") else None  # a fine-tune's reward is tracking
        evaluation, best = task_report(envs, controller, run.standing_action, episodes, seed, task_reward)
    finally:
        envs.close()
    report = {**settings, **run_record(agent), "evaluation": evaluation, "curriculum": config.environment.task}
    folder.write_report(report)
    if "goal" in best:
        text = episode_scenario(folder.path, settings, config, best["goal"])
        write_text_atomic(folder.path / "best_episode.yaml", text)
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
