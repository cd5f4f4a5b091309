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
  control step ahead, relative to the robot now (`REFERENCE_FEATURES`):
  joint offsets, key-body offsets and the object's offset (in the pelvis'
  heading frame), and the episode's phase;
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
from hotu_drake.motion.clip import MotionClip

TARGET_TRACK = "target_marker"  # the name of a reference's target track
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
        if isinstance(references, str):
            references = [references]
        if not references:
            raise InputError("give at least one reference clip (.npz) to track", type(self).__name__, "references")
        options.setdefault("reference_init_probability", 0.0)
        super().__init__(robot=robot, motions=[str(r) for r in references], **options)
        for clip in self.clips:
            missing = [n for n in (self._object.kind, TARGET_TRACK) if not _has_track(clip, n)]
            if missing:
                raise InputError(f"{clip.source}: no {' or '.join(missing)} track to track", type(self).__name__)
            if list(clip.key_body_names) != list(self.clips[0].key_body_names):
                raise InputError(f"{clip.source}: other key bodies than {self.clips[0].source}", type(self).__name__)
        plant, model = self.sim.plant, self.sim.model
        self._key_bodies = [plant.GetBodyByName(n, model) for n in self.clips[0].key_body_names]
        self._joint_columns = self._observer.joint_position_columns.copy()  # joint order = the clips' (checked)
        self._reference_index = 0
        self._forced_reference: int | None = None
        self._tracking: dict = {}

    @property
    def reference_size(self) -> int:
        """The length of the reference features appended to the task's observation."""
        return len(self.embodiment.joint_names) + 3 * len(self.clips[0].key_body_names) + 3 + 1

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
        clip = self.reference
        start = clip.object_poses[0, _track_index(clip, self._object.kind)]
        target = clip.object_poses[0, _track_index(clip, TARGET_TRACK), :3]
        return RigidTransform(Quaternion(start[3:] / np.linalg.norm(start[3:])), start[:3]), target.copy()

    @property
    def reference(self) -> MotionClip:
        """The reference episode this episode tracks."""
        return self.clips[self._reference_index]

    def _reference_errors(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Reference one control step ahead minus the robot now: joints
        (n,), key bodies (k, 3) and the object (3,), world frame; the phase."""
        clip = self.reference
        t = self._context.get_time() + self.control_period
        frame = min(int(round(t * clip.fps)), clip.num_frames - 1)
        robot = self._observation_port.Eval(self._context)
        joints = clip.joint_positions[frame] - robot[self._joint_columns]
        plant, context = self.sim.plant, self._plant_context
        now = np.array([plant.EvalBodyPoseInWorld(context, b).translation() for b in self._key_bodies])
        keys = clip.key_body_positions[frame] - now
        obj = clip.object_poses[frame, _track_index(clip, self._object.kind), :3] - self.object_position()
        return joints, keys, obj, min(t / max(clip.duration, 1e-9), 1.0)

    def _extra_observation(self) -> np.ndarray:
        goal = super()._extra_observation()
        joints, keys, obj, phase = self._reference_errors()
        heading = self._heading().T
        return np.concatenate([goal, joints, (keys @ heading.T).ravel(), heading @ obj, [phase]])

    def _heading(self) -> np.ndarray:
        """The pelvis' heading (yaw only) as a rotation matrix."""
        r = self.sim.plant.EvalBodyPoseInWorld(self._plant_context, self._root).rotation().matrix()
        yaw = np.arctan2(r[1, 0], r[0, 0])
        c, s = np.cos(yaw), np.sin(yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def _task_reward(self, info: dict) -> float:
        task = super()._task_reward(info)
        terms = tracking_reward(*self._reference_errors()[:3])
        info["task_reward"] = task
        info["tracking"] = {k: v for k, v in terms.items() if k != "total"}
        info["reference"] = self._reference_index
        return terms["total"]


def _has_track(clip: MotionClip, kind: str) -> bool:
    return any(n.lower().startswith(kind) for n in clip.object_names) and clip.object_poses is not None


def _track_index(clip: MotionClip, kind: str) -> int:
    return next(k for k, n in enumerate(clip.object_names) if n.lower().startswith(kind))


class BoxCarryTransferEnv(_TransferMixin, BoxCarryEnv):
    """BoxCarry-v0 on a robot, tracking retargeted UDH box-carry episodes."""


class DrillGraspTransferEnv(_TransferMixin, DrillGraspEnv):
    """DrillGrasp-v0 on a robot, tracking retargeted UDH drill-grasp episodes."""
