"""The Drake side of a training run: its environments, and the
demonstrations the learner gets from its reference clips.

`imitation_run` (behavior primitives) and `skill_run` (skills and
fine-tunes) turn a run's settings (robot, hands, motions, task, ...) and
configuration into `RunEnvironments`: the environment id and keywords
that rollout workers make (`learning.rollout.EnvSpec`), for training and
for evaluation, and what is learnt from, built once here in this process:

- the demonstrations (`clip_arrays.build_demonstrations`): each reference
  clip played through the environment's observation system, as arrays;
- the demonstrations' (s_I, s_I') transitions for the interaction
  discriminator of a two-level skill;
- the robot's standing action (a one-level policy's offset and the
  evaluations' baseline).
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from hotu_drake.envs.clip_arrays import build_demonstrations
from hotu_drake.errors import InputError
from hotu_drake.learning.demonstrations import Demonstrations
from hotu_drake.learning.interaction import transitions
from hotu_drake.learning.rollout import EnvSpec, make_vector_env
from hotu_drake.learning.skill_config import TASKS, TRANSFER_TASKS, TWO_LEVEL, SkillConfig
from hotu_drake.retarget.references import motion_key

IMITATION = "hotu_drake/Imitation-v0"
EPISODE_SECONDS = 10.0  # a behavior run's episodes, at any control rate (300 steps at the default 30 Hz)


@dataclass
class RunEnvironments:
    """A run's environments, as rollout workers make them, and what it learns from."""

    env_id: str
    options: dict  # a training environment's keywords
    eval_options: dict  # an evaluation's: no reference-state starts (held-out references for a fine-tune)
    standing_action: np.ndarray
    demonstrations: Demonstrations | None = None  # the clips as arrays (primitives, one-level skills)
    interaction: np.ndarray | None = None  # D_I's demonstration transitions (N, 2, d_I), two-level skills

    def vector_env(
        self, workers: int, ray: str | None = None, evaluation: bool = False, motions: list[str] | None = None
    ) -> gym.vector.VectorEnv:
        """`workers` environments in worker processes (or Ray actors on the
        cluster `ray`); with `motions`, on those of the run's motions alone
        (a behavior run's evaluation, motion by motion)."""
        options = dict(self.eval_options if evaluation else self.options)
        if motions is not None:
            options["motions"] = list(motions)
            if isinstance(options.get("loop"), list):  # those of these motions that repeat
                repeat = {motion_key(m) for m in options["loop"]}
                options["loop"] = [m for m in motions if motion_key(m) in repeat]
        return make_vector_env(EnvSpec(self.env_id, options), workers, backend="ray" if ray else "local", address=ray)


def imitation_run(settings: dict, config) -> RunEnvironments:
    """A behavior run's: `hotu_drake/Imitation-v0` on its robot and motions
    (`config` a `learning.config.TrainConfig`); bad motions fail here."""
    env = config.environment

    def options(evaluation: bool) -> dict:
        made = {
            "robot": settings["robot"],
            "hands": settings["hands"],
            "motions": settings["motions"],
            "amp_history": env.amp_history,
            "termination_height": env.termination_height,
            "reference_init_probability": 0.0 if evaluation else env.reference_init_probability,
            "control_rate": env.control_rate,
            "teacher": env.teacher,
            "phase_observation": env.phase_observation,
            "loop": env.loop,
            "tracking_reward": env.tracking_reward,
            "reference_observation": env.reference_observation,
            "pose_observation": env.pose_observation,
            "standing_follow": env.standing_follow,
            "clip_sampling": "uniform" if evaluation else env.clip_sampling,
            "clip_objects": env.clip_objects,
            "max_episode_steps": round(EPISODE_SECONDS * env.control_rate),
        }
        if evaluation and env.teacher and not env.standing_follow:  # each clip from its start
            made |= {"reference_init_probability": 1.0, "reference_start_time": 0.0}
        return made

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
