"""Transfer environments: a robot tracks a UDH skill's retargeted episodes.

The method's section II-D moves a skill learned on the UDH to a robot by
retargeting what the UDH did and fine-tuning a small layer that drives the
robot's own behavior controller to reproduce it. `BoxCarryTransfer-v0`
and `DrillGraspTransfer-v0` are the task environments with one of those
reference episodes (`references`: `.npz` clips of the robot, made by
`make_references`, below) chosen at every reset:

- the task is the reference's own: the object starts where the
  reference's track starts and its target is the reference's
  `target_marker` track (both already scaled to the robot);
- the observation appends to the task's (robot, goal) the reference one
  control step ahead relative to the robot now
  (`systems.transfer_reference.TransferReference`, which the deployed
  diagram uses too);
- the reward is tracking (`tracking_reward`), in [0, 1]; the task's own
  reward is kept in `info["task_reward"]` (and its terms, success and
  goal as in the task environment), so a transfer is judged on the task.

The references come from here too (step one of the transfer):

- `record_skill_episodes`: the UDH skill run's deterministic two-level
  controller (`TwoLevelController`, from the two `policy.pt` files) on
  seeded task instances, each episode recorded as a clip
  (`envs.recording`) with the task's target as a `target_marker` track;
- `retarget_episode`: one such clip on a robot (`retarget.pipeline.to_robot`:
  joints, root, key bodies, contacts, the object and target tracks scaled
  to the robot's size);
- `make_references`: both for a list of seeds, saved as the clips a
  fine-tune (`python -m hotu_drake.train finetune`) tracks.
"""

import dataclasses
import json
import time
from collections.abc import Sequence
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform

from hotu_drake.envs.recording import record_episode
from hotu_drake.envs.tasks import BoxCarryEnv, DrillGraspEnv
from hotu_drake.envs.tracking import tracking_terms
from hotu_drake.errors import InputError, check_number
from hotu_drake.learning import high_level_input, load_checkpoint, to_latents
from hotu_drake.learning.skill_config import TASKS, load_skill_config
from hotu_drake.motion.clip import MotionClip
from hotu_drake.retarget.pipeline import to_robot
from hotu_drake.systems.transfer_reference import TARGET_TRACK, TransferReference, reference_size

__all__ = [
    "TARGET_TRACK",
    "BoxCarryTransferEnv",
    "DrillGraspTransferEnv",
    "TwoLevelController",
    "make_references",
    "record_skill_episodes",
    "retarget_episode",
    "skill_controller",
    "skill_summary",
    "tracking_reward",
    "with_target",
]

# r = 0.5 exp(-5 mean dq^2) + 0.3 exp(-10 mean |dp_key|^2) + 0.2 exp(-10 |dp_object|^2), DeepMimic's
# form with per-frame means; the scales make a 0.3 rad, 0.2 m, 0.2 m error worth about 2/3 (not tuned).
TRACKING_WEIGHTS = {"joints": 0.5, "key_bodies": 0.3, "object": 0.2}
TRACKING_SCALES = {"joints": 5.0, "key_bodies": 10.0, "object": 10.0}


def tracking_reward(joint_error: np.ndarray, key_body_error: np.ndarray, object_error: np.ndarray) -> dict:
    """The tracking terms and their weighted sum (`total`) from the errors
    (joint radians (n,), key-body offsets (k, 3), object offset (3,))."""
    squared = {
        "joints": float(np.mean(np.square(joint_error))),
        "key_bodies": float(np.mean(np.sum(np.square(key_body_error), -1))),
        "object": float(np.sum(np.square(object_error))),
    }
    return tracking_terms(squared, TRACKING_WEIGHTS, TRACKING_SCALES)


class _TransferMixin:
    """Tracking of reference episodes over a task environment (see the module)."""

    def __init__(self, references: Sequence[str] | str = (), robot: str | None = None, **options):
        where = type(self).__name__
        if isinstance(references, str):
            references = [references]
        if not references:
            raise InputError("give at least one reference clip (.npz) to track", where, "references")
        options.setdefault("reference_init_probability", 0.0)
        super().__init__(robot=robot, motions=[str(r) for r in references], **options)
        for clip in self.clips:
            if list(clip.key_body_names) != list(self.clips[0].key_body_names):
                raise InputError(f"{clip.source}: other key bodies than {self.clips[0].source}", where)
        self._references = [TransferReference(c, self.object_kind, self.control_period) for c in self.clips]
        plant, model = self.sim.plant, self.sim.model
        self._key_bodies = [plant.GetBodyByName(n, model) for n in self.clips[0].key_body_names]
        self._joint_columns = self._observer.joint_position_columns.copy()  # joint order = the clips' (checked)
        self._reference_index = 0
        self._forced_reference: int | None = None

    @property
    def reference_size(self) -> int:
        """The length of the reference features appended to the task's observation."""
        return reference_size(self.clips[0])

    def _observation_size(self) -> int:
        return super()._observation_size() + self.reference_size

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """As the task's reset; `options["reference"]` picks the reference
        episode by index (default: drawn at random)."""
        options = dict(options or {})
        forced = options.pop("reference", None)
        if forced is not None:
            where = f"{type(self).__name__}.reset"
            check_number(forced, "options['reference']", where, low=0, high=len(self.clips) - 1, integer=True)
        self._forced_reference = None if forced is None else int(forced)
        return super().reset(seed=seed, options=options)

    def _sample_goal(self) -> tuple[RigidTransform, np.ndarray]:
        if self._forced_reference is not None:
            self._reference_index = self._forced_reference
        else:
            self._reference_index = int(self.np_random.integers(len(self.clips)))
        start, target = self._references[self._reference_index].start()
        return RigidTransform(Quaternion(start[3:] / np.linalg.norm(start[3:])), start[:3]), target

    @property
    def reference(self) -> TransferReference:
        """The reference episode this episode tracks."""
        return self._references[self._reference_index]

    def _reference_errors(self):
        """The reference one control step ahead minus the robot now (`TransferReference.errors`)."""
        plant, context = self.sim.plant, self._plant_context
        joints = self._observation_port.Eval(self._context)[self._joint_columns]
        keys = np.array([plant.EvalBodyPoseInWorld(context, b).translation() for b in self._key_bodies])
        return self.reference.errors(self._context.get_time(), joints, keys, self.object_position())

    def _extra_observation(self) -> np.ndarray:
        goal = super()._extra_observation()
        rotation = self.sim.plant.EvalBodyPoseInWorld(self._plant_context, self._root).rotation().matrix()
        return np.concatenate([goal, TransferReference.features(self._reference_errors(), rotation)])

    def _task_reward(self, info: dict) -> float:
        task = super()._task_reward(info)
        terms = tracking_reward(*self._reference_errors()[:3])
        info["task_reward"] = task
        info["tracking"] = {k: v for k, v in terms.items() if k != "total"}
        info["reference"] = self._reference_index
        return terms["total"]


class BoxCarryTransferEnv(_TransferMixin, BoxCarryEnv):
    """BoxCarry-v0 on a robot, tracking retargeted UDH box-carry episodes."""


class DrillGraspTransferEnv(_TransferMixin, DrillGraspEnv):
    """DrillGrasp-v0 on a robot, tracking retargeted UDH drill-grasp episodes."""


# -- references: a UDH skill's episodes, retargeted ------------------------------------


def record_skill_episodes(
    skill_run: str | Path, seeds: Sequence[int], llc: str | Path | None = None, max_steps: int = 300
) -> list[MotionClip]:
    """One UDH clip per seed: the skill run's two-level controller (its
    `policy.pt` over the behavior controller's `policy.pt`: `llc`, a run
    folder or the file, by default the run's own) on the task instance that
    seed draws (the run's curriculum), from a standing start. The high
    level's mean is held for the run's hold steps, as in training."""
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
        self.skill, data = load_checkpoint(skill)
        self.llc, _ = load_checkpoint(llc / "policy.pt" if llc.is_dir() else llc)
        meta = data["meta"]
        self.groups, self.latent_size, self.hold = meta["llc_groups"], meta["latent_size"], meta["hold_steps"]

    def episode(self):
        """`act(observation, info)` for one episode of one environment."""
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
