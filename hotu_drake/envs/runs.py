"""The Drake side of a training run: its environments, and the
demonstrations the learner gets from its reference clips.

`imitation_run` (behavior primitives) and `skill_run` (skills and
fine-tunes) turn a run's settings (robot, hands, motions, task, ...) and
configuration into `RunEnvironments`: the environment id and keywords
that rollout workers make (`learning.rollout.EnvSpec`), for training and
for evaluation, and what is learnt from, built once here in this process:

- `build_demonstrations`: each reference clip played at the environment's
  control rate through its own observation system
  (`DiagramEnv.clip_amp_frame`, `clip_observation`): the AMP frames the
  discriminators compare against, the observations and PD target actions
  of the warm start, and the joint positions the evaluation measures
  against. The result is plain arrays
  (`learning.demonstrations.Demonstrations`), cached on disk keyed by the
  clips' contents, the environment's layout and the code that made them;
- the demonstrations' (s_I, s_I') transitions for the interaction
  discriminator of a two-level skill;
- the robot's standing action (a one-level policy's offset and the
  evaluations' baseline).
"""

from __future__ import annotations

import hashlib
import json
import logging
import sys
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

from hotu_drake.embodiment.actions import ActionScaling
from hotu_drake.envs.base import DiagramEnv
from hotu_drake.errors import InputError
from hotu_drake.learning.demonstrations import Demonstrations, MotionData
from hotu_drake.learning.interaction import transitions
from hotu_drake.learning.parts import AmpLayout
from hotu_drake.learning.rollout import EnvSpec, make_vector_env
from hotu_drake.learning.skill_config import TASKS, TRANSFER_TASKS, TWO_LEVEL, SkillConfig
from hotu_drake.retarget.references import cache_dir

log = logging.getLogger("hotu_drake.envs")

IMITATION = "hotu_drake/Imitation-v0"


@dataclass
class RunEnvironments:
    """A run's environments, as rollout workers make them, and what it learns from."""

    env_id: str
    options: dict  # a training environment's keywords
    eval_options: dict  # an evaluation's: no reference-state starts (held-out references for a fine-tune)
    standing_action: np.ndarray
    demonstrations: Demonstrations | None = None  # the clips as arrays (primitives, one-level skills)
    interaction: np.ndarray | None = None  # D_I's demonstration transitions (N, 2, d_I), two-level skills

    def vector_env(self, workers: int, ray: str | None = None, evaluation: bool = False) -> gym.vector.VectorEnv:
        """`workers` environments in worker processes (or Ray actors on the cluster `ray`)."""
        spec = EnvSpec(self.env_id, self.eval_options if evaluation else self.options)
        return make_vector_env(spec, workers, backend="ray" if ray else "local", address=ray)


def imitation_run(settings: dict, config) -> RunEnvironments:
    """A behavior run's: `hotu_drake/Imitation-v0` on its robot and motions
    (`config` a `learning.config.TrainConfig`); bad motions fail here."""
    env = config.environment

    def options(evaluation: bool) -> dict:
        return {
            "robot": settings["robot"],
            "hands": settings["hands"],
            "motions": settings["motions"],
            "amp_history": env.amp_history,
            "termination_height": env.termination_height,
            "reference_init_probability": 0.0 if evaluation else env.reference_init_probability,
        }

    made = gym.make(IMITATION, **options(False))
    try:
        inner = made.unwrapped
        return RunEnvironments(
            IMITATION, options(False), options(True), inner.standing_action(), build_demonstrations(inner)
        )
    finally:
        made.close()


def skill_env_id(settings: dict) -> str:
    """A skill run's environment: the task's, or its transfer twin for a fine-tune (references to track)."""
    return TRANSFER_TASKS[settings["task"]] if settings.get("references") else TASKS[settings["task"]]


def skill_run(settings: dict, config: SkillConfig, amp_history: int) -> RunEnvironments:
    """A skill or fine-tune run's: the task environment (`amp_history`: the
    AMP window its style judges take) and, for a two-level method, D_I's
    demonstration transitions, or for a one-level one, the demonstrations;
    bad motions or task keywords fail here."""
    e = config.environment

    def options(evaluation: bool) -> dict:
        if settings.get("references"):  # a fine-tune tracks references (held-out ones in evaluation)
            clips = {"references": settings["eval_references" if evaluation else "references"]}
        else:
            clips = {"motions": settings["motions"]}
        return {
            "robot": settings["robot"],
            "hands": settings["hands"],
            **clips,
            "amp_history": amp_history,
            "termination_height": e.termination_height,
            "reference_init_probability": 0.0 if evaluation else e.reference_init_probability,
            **e.task,
        }

    env_id = skill_env_id(settings)
    try:
        made = gym.make(env_id, **options(False))
    except TypeError as error:
        raise InputError(f"the task does not take these keywords ({error})", field="environment.task") from None
    try:
        inner = made.unwrapped
        run = RunEnvironments(env_id, options(False), options(True), inner.standing_action())
        if settings["algo"] not in TWO_LEVEL:
            run.demonstrations = build_demonstrations(inner)
        elif config.uses_interaction:
            sequences = inner.interaction_sequences()
            if not sequences:
                kind = inner.object_kind
                raise InputError(f"--motions: none of {', '.join(settings['motions'])} carries a {kind} track for D_I")
            run.interaction = transitions(sequences)
        return run
    finally:
        made.close()


def motion_names(env: DiagramEnv) -> list[str]:
    """A name per reference clip of `env` (the last part of its source, e.g.
    `wave` for the library's wave; repeated names numbered)."""
    names: list[str] = []
    for clip in env.clips:
        name = Path(clip.source).stem or "clip"
        while name in names:
            name = f"{name}_{len(names)}"
        names.append(name)
    return names


def build_demonstrations(env: DiagramEnv, use_cache: bool = True) -> Demonstrations:
    """The demonstrations of `env`'s reference clips (see the module docstring)."""
    if not env.clips:
        raise InputError("the environment has no reference clips to learn from", field="motions")
    key = _cache_key(env)
    path = cache_dir() / "demonstrations" / f"{env.embodiment.name}_{env.embodiment.hands}_{key}.npz"
    if use_cache and path.is_file():
        try:
            return Demonstrations.load(path)
        except InputError:
            log.warning("%s: damaged demonstrations cache; building it again", path)
    demos = _build(env)
    if use_cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        demos.save(path)
    return demos


def _build(env: DiagramEnv) -> Demonstrations:
    emb = env.embodiment
    scaling = ActionScaling.for_embodiment(emb)
    layout = AmpLayout.from_dict(env.amp_layout())
    period = env.control_period
    motions = {}
    for index, name in enumerate(motion_names(env)):
        times = env.clip_times(index)
        frames = np.array([env.clip_amp_frame(index, t) for t in times], dtype=np.float32)
        observations = np.array([env.clip_observation(index, t) for t in times], dtype=np.float32)
        joints = np.array([env._playbacks[index].joints_at(t)[0] for t in times])
        targets = np.vstack([joints[1:], joints[-1:]])  # the next frame's pose; the last holds
        actions = np.clip(scaling.to_action(targets), -1.0, 1.0).astype(np.float32)
        amp = {key: frames[:, env.part_slices[key]] for key in layout.keys}
        motions[name] = MotionData(amp, observations, actions, joints.astype(np.float32))
    names = emb.joint_names
    part_joints = {part: [names.index(j) for j in joints] for part, joints in emb.parts.items() if joints}
    meta = {"embodiment": emb.name, "hands": emb.hands, "joint_columns": env.joint_position_columns().tolist()}
    return Demonstrations(layout, motions, list(names), part_joints, env.amp_history, 1.0 / period, meta)


def _cache_key(env: DiagramEnv) -> str:
    from hotu_drake.retarget.references import _code_key

    digest = hashlib.sha256()
    digest.update(_code_key().encode())
    from hotu_drake.envs import base
    from hotu_drake.systems import observation

    task = sys.modules[type(env).__module__].__file__  # a task environment's own observation
    for source in (__file__, base.__file__, observation.__file__, task):  # the code that makes the arrays
        with open(source, "rb") as f:
            digest.update(f.read())
    description = {
        "layout": env.amp_layout(),
        "history": env.amp_history,
        "period": env.control_period,
        "names": motion_names(env),
        "observation": int(env.observation_space.shape[0]),
    }
    digest.update(json.dumps(description, sort_keys=True).encode())
    for clip in env.clips:
        for array in (clip.joint_positions, clip.root_position, clip.root_quaternion):
            digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()[:16]
