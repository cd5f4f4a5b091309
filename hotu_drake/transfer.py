"""Skill transfer, step one: what a UDH skill did, on a robot.

Section II-D of the method: a skill learned once on the UDH reaches a
robot through kinematic retargeting of the UDH's executed motion, which the
robot's fine-tuning layer then learns to reproduce (`train finetune`,
`envs.transfer`). Here:

- `record_skill_episodes`: the UDH skill run's deterministic two-level
  controller (`TwoLevelController`, from the two `policy.pt` files) on
  seeded task instances, each episode recorded as a clip
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
from hotu_drake.errors import InputError
from hotu_drake.motion.clip import MotionClip


def record_skill_episodes(
    skill_run: str | Path, seeds: Sequence[int], llc: str | Path | None = None, max_steps: int = 300
) -> list[MotionClip]:
    """One UDH clip per seed: the skill run's two-level controller (its
    `policy.pt` over the behavior controller's `policy.pt`: `llc`, a run
    folder or the file, by default the run's own) on the task instance that
    seed draws (the run's curriculum), from a standing start. The high
    level's mean is held for the run's hold steps, as in training."""
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401 (registers the environments)
    from hotu_drake.envs.recording import record_episode
    from hotu_drake.learning.skill_config import TASKS, load_skill_config

    run = Path(skill_run)
    settings = json.loads((run / "run.json").read_text())
    config = load_skill_config(run / "config.yaml")
    controller = TwoLevelController(run / "policy.pt", Path(llc) if llc else skill_controller(run))
    e = config.environment
    options = {"termination_height": e.termination_height, "reference_init_probability": 0.0, **e.task}
    env = gym.make(TASKS[settings["task"]], robot=settings["robot"], hands=settings["hands"], **options).unwrapped
    try:
        clips = []
        for seed in seeds:
            act = controller.episode()
            clip = record_episode(env, act, seed, max_steps, f"{run.name}/seed_{seed}", options={"init": "default"})
            clips.append(with_target(clip, env.target))
    finally:
        env.close()
    return clips


def skill_controller(skill_run: str | Path) -> Path:
    """The run folder of the behavior controller a skill run drives: the one
    its `run.json` names, else a folder of that name beside the run (a copied
    results tree); `InputError` if neither has a `policy.pt`."""
    run = Path(skill_run)
    recorded = Path(json.loads((run / "run.json").read_text())["llc"])
    for folder in (recorded, run.parent / recorded.name):
        if (folder / "policy.pt").is_file():
            return folder
    raise InputError(f"{run}: its behavior controller {recorded} (or {run.parent / recorded.name}) has no policy.pt")


class TwoLevelController:
    """A skill's high level (`skill`, a `policy.pt`) over its behavior
    controller (`llc`, a run folder or its `policy.pt`), deterministic."""

    def __init__(self, skill: Path, llc: Path):
        from hotu_drake.learning.checkpoint import load_checkpoint

        self.skill, data = load_checkpoint(skill)
        self.llc, _ = load_checkpoint(llc / "policy.pt" if llc.is_dir() else llc)
        meta = data["meta"]
        self.groups, self.latent_size, self.hold = meta["llc_groups"], meta["latent_size"], meta["hold_steps"]

    def episode(self):
        """`act(observation, info)` for one episode of one environment."""
        import torch

        from hotu_drake.learning.skill_agent import high_level_input, to_latents

        steps = [0]
        latents: dict[str, np.ndarray] = {}

        def act(observation: np.ndarray, info: dict) -> np.ndarray:
            with torch.no_grad():
                if steps[0] % self.hold == 0:
                    inputs = high_level_input(observation[None], np.asarray(info["interaction"])[None])
                    raw = self.skill.mean(torch.as_tensor(inputs)).numpy()
                    latents.update(to_latents(raw, self.groups, self.latent_size))
                steps[0] += 1
                robot = torch.as_tensor(observation[None, : self.llc.config.observation_size], dtype=torch.float32)
                return self.llc(robot, {g: torch.as_tensor(z) for g, z in latents.items()}).numpy()[0]

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
    skill_run: str | Path,
    robot: str,
    hands: str,
    seeds: Sequence[int],
    folder: Path,
    prefix: str = "reference",
    llc: str | Path | None = None,
) -> tuple[list[Path], float]:
    """Record the skill on `seeds`, retarget each episode to `robot`, and
    save both clips in `folder` (`udh_<prefix>_<seed>.npz`,
    `<prefix>_<seed>.npz`); the robot clips' paths and the seconds it took."""
    start = time.perf_counter()
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for seed, clip in zip(seeds, record_skill_episodes(skill_run, seeds, llc), strict=True):
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
