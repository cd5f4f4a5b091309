"""Skill transfer, step one: what a UDH skill did, on a robot.

Section II-D of the method: a skill learned once on the UDH reaches a
robot through kinematic retargeting of the UDH's executed motion, which the
robot's fine-tuning layer then learns to reproduce (`train finetune`,
`envs.transfer`). Here:

- `record_skill_episodes`: the UDH skill run's deterministic two-level
  controller on seeded task instances, each episode recorded as a clip
  (`envs.recording`) with the task's target as a `target_marker` track;
- `retarget_episode`: one such clip on a robot (`retarget.pipeline.to_robot`:
  joints, root, key bodies, contacts, the object and target tracks scaled
  to the robot's size).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hotu_drake.envs.transfer import TARGET_TRACK
from hotu_drake.motion.clip import MotionClip


def record_skill_episodes(skill_run: str | Path, seeds: Sequence[int], max_steps: int = 300) -> list[MotionClip]:
    """One UDH clip per seed: the skill run's controller (the high level's
    mean, held as in training, over its frozen behavior controller) on the
    task instance that seed draws, from a standing start."""
    import gymnasium as gym

    from hotu_drake import train_skill
    from hotu_drake.envs.recording import record_episode
    from hotu_drake.learning.checkpoint import read_checkpoint
    from hotu_drake.learning.skill_agent import SkillAgent, SkillController

    run = Path(skill_run)
    settings, checkpoint, config = train_skill.read_skill_run(run)
    config.reward.interaction = 0.0  # D_I only trains; the controller does not need it
    env = train_skill.make_env(settings, config, evaluation=True).unwrapped
    envs = gym.vector.SyncVectorEnv([lambda: env])
    try:
        agent = SkillAgent(config, envs, train_skill.load_controller(settings["llc"]), seed=0)
        agent.load_state_dict(read_checkpoint(run / "checkpoint.pt", kind="training")["state"])
        clips = []
        for seed in seeds:
            act = _single_env_actor(SkillController(agent))
            clip = record_episode(env, act, seed, max_steps, f"{run.name}/seed_{seed}", options={"init": "default"})
            clips.append(with_target(clip, env.target))
    finally:
        envs.close()
    return clips


def _single_env_actor(controller):
    """`act(observation, info)` of one environment over a batch `controller`,
    telling it when the episode starts (its first call)."""
    started = np.array([True])

    def act(observation: np.ndarray, info: dict) -> np.ndarray:
        interaction = np.asarray(info["interaction"], dtype=np.float32)[None]
        action = controller(observation[None], interaction, started.copy())[0]
        started[0] = False
        return action

    return act


def with_target(clip: MotionClip, target: np.ndarray) -> MotionClip:
    """`clip` with a constant `target_marker` track at `target` (the task's goal position)."""
    track = np.zeros((clip.num_frames, 1, 7))
    track[:, 0, :3], track[:, 0, 3] = target, 1.0
    poses = track if clip.object_poses is None else np.concatenate([clip.object_poses, track], axis=1)
    return dataclasses.replace(clip, object_names=[*clip.object_names, TARGET_TRACK], object_poses=poses)


def retarget_episode(udh_clip: MotionClip, robot: str, hands: str = "none") -> MotionClip:
    """A recorded UDH episode on `robot`, its object and target tracks scaled to it."""
    from hotu_drake.retarget.pipeline import to_robot

    return to_robot(udh_clip, robot, hands).clip


def make_references(
    skill_run: str | Path, robot: str, hands: str, seeds: Sequence[int], folder: Path, prefix: str = "reference"
) -> tuple[list[Path], float]:
    """Record the skill on `seeds`, retarget each episode to `robot`, and
    save both clips in `folder` (`udh_<prefix>_<seed>.npz`,
    `<prefix>_<seed>.npz`); the robot clips' paths and the seconds it took."""
    start = time.perf_counter()
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for seed, clip in zip(seeds, record_skill_episodes(skill_run, seeds), strict=True):
        clip.save(folder / f"udh_{prefix}_{seed}.npz")
        path = folder / f"{prefix}_{seed}.npz"
        retarget_episode(clip, robot, hands).save(path)
        paths.append(path)
    return paths, time.perf_counter() - start


def skill_summary(skill_run: str | Path) -> dict:
    """The UDH skill run's settings and wall-clock (for the transfer's accounting)."""
    run = Path(skill_run)
    report = run / "report.json"
    settings = json.loads((run / "run.json").read_text())
    seconds = json.loads(report.read_text()).get("wall_clock_seconds") if report.is_file() else None
    return {"run": str(run.resolve()), "task": settings["task"], "algo": settings["algo"], "seconds": seconds}
