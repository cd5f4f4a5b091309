"""Transfer environments: a robot tracks a UDH skill's retargeted episodes.

The method's section II-D moves a skill learned on the UDH to a robot by
retargeting what the UDH did and fine-tuning a small layer that drives the
robot's own behavior controller to reproduce it. `BoxCarryTransfer-v0`
and `DrillGraspTransfer-v0` are the task environments with one of those
reference episodes (`references`: `.npz` clips of the robot, made by
`hotu_drake.transfer`) chosen at every reset:

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
"""

from collections.abc import Sequence

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform

from hotu_drake.envs.tasks import BoxCarryEnv, DrillGraspEnv
from hotu_drake.errors import InputError, check_number
from hotu_drake.systems.transfer_reference import TARGET_TRACK, TransferReference, reference_size

__all__ = ["TARGET_TRACK", "BoxCarryTransferEnv", "DrillGraspTransferEnv", "tracking_reward"]

# r = 0.5 exp(-5 mean dq^2) + 0.3 exp(-10 mean |dp_key|^2) + 0.2 exp(-10 |dp_object|^2), DeepMimic's
# form with per-frame means; the scales make a 0.3 rad, 0.2 m, 0.2 m error worth about 2/3 (not tuned).
TRACKING_WEIGHTS = {"joints": 0.5, "key_bodies": 0.3, "object": 0.2}
TRACKING_SCALES = {"joints": 5.0, "key_bodies": 10.0, "object": 10.0}


def tracking_reward(joint_error: np.ndarray, key_body_error: np.ndarray, object_error: np.ndarray) -> dict:
    """The tracking terms and their weighted sum (`total`) from the errors
    (joint radians (n,), key-body offsets (k, 3), object offset (3,))."""
    terms = {
        "joints": float(np.exp(-TRACKING_SCALES["joints"] * np.mean(np.square(joint_error)))),
        "key_bodies": float(np.exp(-TRACKING_SCALES["key_bodies"] * np.mean(np.sum(np.square(key_body_error), -1)))),
        "object": float(np.exp(-TRACKING_SCALES["object"] * np.sum(np.square(object_error)))),
    }
    return terms | {"total": sum(TRACKING_WEIGHTS[k] * v for k, v in terms.items())}


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
        self._references = [TransferReference(c, self._object.kind, self.control_period) for c in self.clips]
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
