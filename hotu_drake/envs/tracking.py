"""Tracking rewards: how close the robot is to a reference, DeepMimic's way.

Each term is exp(-scale x error^2) of one kind of error, the reward their
weighted sum (in [0, 1]). Two environments use them:

- `Imitation-v0` with `tracking_reward=True` (`ClipTracking`): the
  episode's clip at the episode's clip time (a looped clip's passes
  placed, as the teacher's reference is): joint positions, hands and feet
  relative to the root (heading frame), the root's height and its
  velocity in the heading frame (not its place in the world: the
  teacher re-anchors the clip where its feet land, and its own looped
  walk is 0.45 m from the clip's root after 3 s);
- the transfer environments (`envs.transfer.tracking_reward`): joints,
  key bodies and the object of a retargeted UDH episode.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from hotu_drake.control.clip_plan import ClipPlan
from hotu_drake.embodiment import Embodiment
from hotu_drake.motion.clip import MotionClip
from hotu_drake.systems.observation import ROOT_FEATURES, ROOT_LINEAR_VELOCITY, ObservationSystem

# A clip's terms: r = 0.5 exp(-5 mean dq^2) + 0.2 exp(-10 mean |dp_key|^2) + 0.15 exp(-40 dz_root^2)
#   + 0.15 exp(-2 |dv_root|^2). MimicKit's DeepMimic weights (pose 0.5, root pose 0.15, root velocity 0.1,
# key bodies 0.15, joint velocity 0.1) without the joint velocities; the scales make a 0.3 rad, 0.2 m,
# 0.1 m, 0.5 m/s error worth about 2/3 (not tuned).
CLIP_WEIGHTS = {"joints": 0.5, "key_bodies": 0.2, "root_height": 0.15, "root_velocity": 0.15}
CLIP_SCALES = {"joints": 5.0, "key_bodies": 10.0, "root_height": 40.0, "root_velocity": 2.0}


def tracking_terms(squared_errors: dict[str, float], weights: dict[str, float], scales: dict[str, float]) -> dict:
    """Each term exp(-scale x squared error) and their weighted sum (`total`)."""
    terms = {name: float(np.exp(-scales[name] * error)) for name, error in squared_errors.items()}
    return terms | {"total": sum(weights[name] * value for name, value in terms.items())}


class ClipTracking:
    """The tracking reward of a robot (`model` of `plant`, observed by
    `observer`) against reference clips, each followed as the teacher
    follows it (`ClipPlan`: a looped clip's later passes placed where the
    last one ended). The robot and the reference are compared in the
    observation's own features (`ObservationSystem`: root height, heading-
    frame velocity, joints, hands and feet relative to the root). Plans are
    made when a clip is first tracked."""

    def __init__(
        self,
        plant: MultibodyPlant,
        model,
        embodiment: Embodiment,
        observer: ObservationSystem,
        clips: list[MotionClip],
        loops: Sequence[bool],
    ) -> None:
        self.plant, self.model, self.embodiment, self.clips, self.loops = plant, model, embodiment, clips, loops
        self.observer = observer
        self._context = plant.CreateDefaultContext()  # the reference's state
        self._observer_context = observer.CreateDefaultContext()  # its observation
        n = len(embodiment.joint_names)
        self._joints = observer.joint_position_columns
        self._keys = slice(ROOT_FEATURES + 2 * n, observer.observation_size)
        self._plans: dict[int, ClipPlan] = {}

    def plan(self, clip_index: int) -> ClipPlan:
        plan = self._plans.get(clip_index)
        if plan is None:
            clip = self.clips[clip_index]
            scratch = self.plant.CreateDefaultContext()
            plan = self._plans[clip_index] = ClipPlan(
                clip, self.plant, self.model, self.embodiment, scratch, self.loops[clip_index]
            )
        return plan

    def errors(self, observation: np.ndarray, clip_index: int, clip_time: float) -> dict[str, float]:
        """The squared errors (`CLIP_WEIGHTS`' terms) of the robot whose
        observation (`ObservationSystem`'s) is `observation` against clip
        `clip_index` at `clip_time`."""
        self.plan(clip_index).set_reference(self._context, clip_time)
        self.observer.fix_inputs_from_plant(self._observer_context, self.plant, self._context, self.model)
        reference = self.observer.GetOutputPort("observation").Eval(self._observer_context)
        keys = (reference[self._keys] - observation[self._keys]).reshape(-1, 3)
        velocity = reference[ROOT_LINEAR_VELOCITY] - observation[ROOT_LINEAR_VELOCITY]
        return {
            "joints": float(np.mean(np.square(reference[self._joints] - observation[self._joints]))),
            "key_bodies": float(np.mean(np.sum(np.square(keys), -1))) if len(keys) else 0.0,
            "root_height": float((reference[0] - observation[0]) ** 2),
            "root_velocity": float(np.sum(np.square(velocity))),
        }
