"""Loco-manipulation environments of the method: BoxCarry-v0 and DrillGrasp-v0.

Both extend Imitation-v0 (same action, AMP output, starts and termination;
default embodiment the UDH, any other by `robot=`) with a task:

- goal g: the object's start pose and its target position, drawn at every
  reset within the configured ranges (relative to the robot's start,
  which faces +x); a marker shows the target. The observation appends the
  InteractionGraphSystem's `goal`: in the pelvis' heading frame, the
  object's position and the first two columns of its rotation (9 numbers)
  and the target's position (3);
- `info["interaction"]`: s_I = {d_ho, d_og, e_ho} from the
  InteractionGraphSystem (hand-object vectors, object-target vector,
  hand-object contact flags), and `info["goal"]` (start pose, target);
- task reward r_g in [0, 1] and `info["success"]` (latched: true from the
  step the task is done to the episode's end), see each class; the task's
  steps so far toward success in `info["success_steps"]`.

`clip_interaction` gives s_I at a reference clip's frame with its object
track (the interaction discriminator's demonstrations), from the same
system on a scratch context.
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RollPitchYaw

from hotu_drake import embodiment as embodiments
from hotu_drake.embodiment.spec import HAND_ROLES
from hotu_drake.envs.base import DiagramEnv, environment_scenario
from hotu_drake.errors import InputError, check_number, check_vector
from hotu_drake.motion.library.object_tasks import (
    BOX_CARRY_RANGES,
    DRILL_GRASP_RANGES,
    TABLE_DISTANCE,
    sample_box_carry,
    sample_drill_grasp,
)
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.objects import (
    SceneObject,
    object_body,
    place_target_marker,
)
from hotu_drake.plant import set_robot_state
from hotu_drake.retarget.references import reference_clips
from hotu_drake.scenario import Scenario
from hotu_drake.systems.interaction_graph import GOAL_SIZE
from hotu_drake.systems.transfer_reference import track_index

HOLD_SECONDS = 1.0  # how long the task's end state must hold for success
# The tasks' demonstrations: instances of the environment's own distribution, and a walk.
DEMONSTRATIONS = 24
BOX_CARRY_MOTIONS = ("walk", *(f"box_carry_task@{seed}" for seed in range(DEMONSTRATIONS)))
DRILL_GRASP_MOTIONS = ("walk", *(f"drill_grasp_task@{seed}" for seed in range(DEMONSTRATIONS)))


@dataclass(frozen=True)
class Range:
    low: float
    high: float

    @staticmethod
    def of(values, field: str, where: str, low: float, high: float) -> "Range":
        """A (low, high) keyword, checked: two finite numbers within [low, high], in order."""
        a, b = check_vector(values, field, where, size=2)
        for value in (a, b):
            check_number(value, field, where, low=low, high=high)
        if a > b:
            raise InputError(f"({a:g}, {b:g}): the low end is above the high end", where, field)
        return Range(a, b)

    def sample(self, rng: np.random.Generator) -> float:
        return float(rng.uniform(self.low, self.high))


class _ObjectTaskEnv(DiagramEnv):
    """One free object, a target for it, and the interaction graph."""

    def __init__(
        self,
        robot: str | None,
        hands: str | None,
        motions: Sequence[str] | str | None,
        obj: SceneObject,
        scenario: Scenario | str | None = None,
        time_step: float | None = None,
        control_rate: float | None = None,
        sampled_output_ports: bool | None = None,
        **options,
    ):
        if robot is None and scenario is None:
            robot = "udh"
        objects = self._scene_objects(obj)
        scenario = environment_scenario(scenario, robot, hands, time_step, control_rate, sampled_output_ports, objects)
        emb = embodiments.load(scenario.embodiment, scenario.hands)
        self._object = obj
        super().__init__(scenario, reference_clips(emb, motions), emb, **options)
        sim = self.sim
        self._object_body = object_body(sim.plant, sim.objects, obj)
        self._hand_bodies = [sim.plant.GetBodyByName(emb.key_bodies[r], sim.model) for r in HAND_ROLES]
        self._graph_port = sim.diagram.GetOutputPort("interaction")
        self._goal_port = sim.diagram.GetOutputPort("goal")
        self._targets = sim.systems["object_targets"]
        self._scratch_diagram = sim.diagram.CreateDefaultContext()
        self.start_pose = RigidTransform()
        self.target = np.zeros(3)
        self.hold_steps = int(round(HOLD_SECONDS / self.control_period))
        self._success_steps = 0
        self._succeeded = False

    @property
    def object_kind(self) -> str:
        """The task's object: `box` or `drill` (its track's name in a demonstration)."""
        return self._object.kind

    def _scene_objects(self, obj: SceneObject) -> list[SceneObject]:
        return [obj]

    def _bounds(self) -> dict[str, tuple[float, float]]:
        """The task's ranges as (low, high), as the library's samplers take them."""
        return {name: (r.low, r.high) for name, r in self.ranges.items()}

    @property
    def interaction_size(self) -> int:
        """The length of s_I (`info["interaction"]`)."""
        return int(self._graph_port.size())

    def _observation_size(self) -> int:
        return super()._observation_size() + GOAL_SIZE

    def _sample_goal(self) -> tuple[RigidTransform, np.ndarray]:
        raise NotImplementedError

    def _place_task(self) -> None:
        self.start_pose, self.target = self._sample_goal()
        sim = self.sim
        sim.plant.SetFreeBodyPose(self._plant_context, self._object_body, self.start_pose)
        place_target_marker(sim.plant, self._plant_context, sim.objects, self._object, self.target)
        self._set_target(self._context, self.target)
        self._success_steps, self._succeeded = 0, False

    def _set_target(self, context, target: np.ndarray) -> None:
        source = self._targets.get_mutable_source_value(self._targets.GetMyMutableContextFromRoot(context))
        source.set_value(np.asarray(target, dtype=float))

    def _extra_observation(self) -> np.ndarray:
        return np.concatenate([super()._extra_observation(), self._goal_port.Eval(self._context)])

    def clip_interaction(self, clip_index: int, time_: float) -> np.ndarray:
        """s_I at reference clip `clip_index`'s state at `time_` (its own
        world frame), its object track placing the object and the track's
        last position as the target; `InputError` if the clip carries no
        track of this task's object."""
        clip = self.clips[clip_index]
        if self._track(clip) is None:
            raise InputError(f"{clip.source}: no {self.object_kind} track (objects: {clip.object_names or 'none'})")
        return self._graph_port.Eval(self._clip_frame(clip_index, time_)).astype(np.float32)

    def clip_observation(self, clip_index: int, time_: float) -> np.ndarray:
        """The task observation at a reference clip's state (for behavior
        cloning): the robot's, then the goal at that frame if the clip
        carries a track of the object (zeros if not)."""
        robot = super().clip_observation(clip_index, time_)[: DiagramEnv._observation_size(self)]  # and the phase
        goal = np.zeros(GOAL_SIZE)
        if self._track(self.clips[clip_index]) is not None:
            goal = self._goal_port.Eval(self._clip_frame(clip_index, time_))
        return np.concatenate([robot, goal]).astype(np.float32)

    def _clip_frame(self, clip_index: int, time_: float):
        """The scratch diagram context at the clip's frame (robot, object, target)."""
        clip = self.clips[clip_index]
        sim = self.sim
        context = self._scratch_diagram
        plant_context = sim.plant.GetMyMutableContextFromRoot(context)
        set_robot_state(sim.plant, plant_context, sim.model, self.embodiment, ClipPlayback(clip, loop=False), time_)
        k = self._track(clip)
        if k is not None:
            frame = min(int(round(time_ * clip.fps)), clip.num_frames - 1)
            pose = clip.object_poses[frame, k]
            sim.plant.SetFreeBodyPose(plant_context, self._object_body, RigidTransform(Quaternion(pose[3:]), pose[:3]))
            self._set_target(context, clip.object_poses[-1, k, :3])
        return context

    def interaction_sequences(self) -> list[np.ndarray]:
        """s_I of every reference clip with a track of the object, at the
        control rate: the interaction discriminator's demonstrations."""
        sequences = []
        for index in self.interaction_clips():
            sequences.append(np.array([self.clip_interaction(index, t) for t in self.clip_times(index)]))
        return sequences

    def interaction_clips(self) -> list[int]:
        """The indices of the reference clips with a track of this task's object."""
        return [i for i, c in enumerate(self.clips) if self._track(c) is not None]

    def _track(self, clip) -> int | None:
        """The index of the clip's track of this task's object: the first object
        whose name starts with the object's kind, in any case (`box`, `Box1`,
        an OptiTrack rigid body `box_small`), or None."""
        return track_index(clip, self.object_kind)

    def _count_success(self, info: dict, done: bool) -> None:
        """Count consecutive steps in the task's end state into
        `info["success_steps"]`; `info["success"]` is true (and stays true)
        once they reach `hold_steps` (1 s)."""
        self._success_steps = self._success_steps + 1 if done else 0
        self._succeeded = self._succeeded or self._success_steps >= self.hold_steps
        info["success"], info["success_steps"] = self._succeeded, self._success_steps

    def object_position(self) -> np.ndarray:
        return self.sim.plant.EvalBodyPoseInWorld(self._plant_context, self._object_body).translation()

    def object_velocity(self) -> np.ndarray:
        """The object's linear velocity (world, m/s)."""
        velocity = self.sim.plant.EvalBodySpatialVelocityInWorld(self._plant_context, self._object_body)
        return velocity.translational()

    def hand_positions(self) -> np.ndarray:
        plant = self.sim.plant
        return np.array([plant.EvalBodyPoseInWorld(self._plant_context, b).translation() for b in self._hand_bodies])

    def _info(self, terminated: bool) -> dict:
        info = super()._info(terminated)
        interaction = self._graph_port.Eval(self._context)
        info["interaction"] = interaction.astype(np.float32)
        info["hand_contacts"] = interaction[-2:].copy()  # e_ho: left, right
        info["success_steps"] = self._success_steps
        start = self.start_pose
        info["goal"] = {
            "start_position": start.translation().copy(),
            "start_yaw": float(RollPitchYaw(start.rotation()).yaw_angle()),
            "target": self.target.copy(),
        }
        return info


class BoxCarryEnv(_ObjectTaskEnv):
    """Carry a box to a target: the box floats in front of the robot at the
    start (held in the air until the robot touches it, as in the method).
    Its starts and targets are drawn from `BOX_CARRY_RANGES`, the library's
    task demonstrations (`box_carry_task@<seed>`) from the same ranges:
    by default D_I learns from `DEMONSTRATIONS` of them, beside a walk.

    r_g = 0.2 exp(-2 |hands' midpoint - box|^2) (approach)
        + 0.3 [both hands touch the box and it is above `carry_height`] (carrying)
        + 0.5 exp(-0.5 |box - target|^2) (delivery);
    success: the box within `success_distance` (0.1 m) of the target and
    resting there (slower than `rest_speed`, 0.1 m/s) for 1 s.
    """

    def __init__(
        self,
        robot: str | None = None,
        hands: str | None = None,
        motions: Sequence[str] | None = BOX_CARRY_MOTIONS,
        start_distance: tuple[float, float] = BOX_CARRY_RANGES["start_distance"],
        start_bearing: tuple[float, float] = BOX_CARRY_RANGES["start_bearing"],
        start_height: tuple[float, float] = BOX_CARRY_RANGES["start_height"],
        target_distance: tuple[float, float] = BOX_CARRY_RANGES["target_distance"],
        target_bearing: tuple[float, float] = BOX_CARRY_RANGES["target_bearing"],
        target_height: tuple[float, float] = BOX_CARRY_RANGES["target_height"],
        carry_height: float = 0.3,
        success_distance: float = 0.1,
        rest_speed: float = 0.1,
        **options,
    ):
        where = type(self).__name__
        self.success_distance = check_number(success_distance, "success_distance", where, low=0.0, high=10.0, unit="m")
        self.rest_speed = check_number(rest_speed, "rest_speed", where, low=0.0, high=10.0, unit="m/s")
        self.ranges = {
            "start_distance": Range.of(start_distance, "start_distance", where, 0.0, 10.0),
            "start_bearing": Range.of(start_bearing, "start_bearing", where, -np.pi, np.pi),
            "start_height": Range.of(start_height, "start_height", where, 0.0, 3.0),
            "target_distance": Range.of(target_distance, "target_distance", where, 0.0, 20.0),
            "target_bearing": Range.of(target_bearing, "target_bearing", where, -np.pi, np.pi),
            "target_height": Range.of(target_height, "target_height", where, 0.0, 3.0),
        }
        self.carry_height = check_number(carry_height, "carry_height", where, low=0.0, high=3.0, unit="m")
        obj = SceneObject(kind="box", name="box", position=[0.6, 0.0, 0.9], held=True, target=[1.5, 0.0, 0.8])
        super().__init__(robot, hands, motions, obj, **options)

    def _sample_goal(self) -> tuple[RigidTransform, np.ndarray]:
        task = sample_box_carry(self.np_random, self._bounds())  # the library's demonstrations draw the same way
        return RigidTransform(RollPitchYaw(0.0, 0.0, task.start_yaw), list(task.start)), np.array(task.target)

    def _task_reward(self, info: dict) -> float:
        box, hands = self.object_position(), self.hand_positions()
        approach = np.exp(-2.0 * np.sum((hands.mean(axis=0) - box) ** 2))
        carrying = float(info["hand_contacts"].all() and box[2] > self.carry_height)
        delivery = np.exp(-0.5 * np.sum((box - self.target) ** 2))
        speed = np.linalg.norm(self.object_velocity())
        there = np.linalg.norm(box - self.target) < self.success_distance and speed < self.rest_speed
        self._count_success(info, bool(there))
        info["reward_terms"] = {"approach": approach, "carrying": carrying, "delivery": delivery}
        return float(0.2 * approach + 0.3 * carrying + 0.5 * delivery)


class DrillGraspEnv(_ObjectTaskEnv):
    """Walk to a drill on a table, grasp it, lift it and hold it up.

    The table stands `table_distance` ahead (0.65 m: within reach; further
    makes the robot walk first), the drill on it; the target is above the
    drill's start. Drawn from `DRILL_GRASP_RANGES`, as the library's task
    demonstrations (`drill_grasp_task@<seed>`) are: by default D_I learns
    from `DEMONSTRATIONS` of them, beside a walk.

    r_g = 0.3 exp(-5 |right hand - drill|^2) (reach)
        + 0.2 [the right hand touches the drill] (grasp)
        + 0.5 exp(-10 |drill - target|^2) (lift to the target);
    success: the drill `lift_success` (0.1 m) or more above its start, a
    hand touching it, for 1 s. With the full hands by default (on the
    environment's own scenario): the finger primitives are what the
    method's task is about.
    """

    def __init__(
        self,
        robot: str | None = None,
        hands: str | None = None,
        motions: Sequence[str] | None = DRILL_GRASP_MOTIONS,
        table_distance: float = TABLE_DISTANCE,
        drill_offset: tuple[float, float] = DRILL_GRASP_RANGES["drill_offset"],
        drill_yaw: tuple[float, float] = DRILL_GRASP_RANGES["drill_yaw"],
        lift_height: tuple[float, float] = DRILL_GRASP_RANGES["lift_height"],
        lift_success: float = 0.1,
        **options,
    ):
        where = type(self).__name__
        self.lift_success = check_number(lift_success, "lift_success", where, low=0.0, high=2.0, unit="m")
        self.table_distance = check_number(table_distance, "table_distance", where, low=0.3, high=10.0, unit="m")
        self.ranges = {
            "drill_offset": Range.of(drill_offset, "drill_offset", where, -0.4, 0.4),
            "drill_yaw": Range.of(drill_yaw, "drill_yaw", where, -np.pi, np.pi),
            "lift_height": Range.of(lift_height, "lift_height", where, 0.0, 1.0),
        }
        obj = SceneObject(kind="drill", name="drill", target=[0.5, 0.0, 1.0])
        if hands is None and options.get("scenario") is None:
            hands = "full"
        super().__init__(robot, hands, motions, obj, **options)

    def _scene_objects(self, obj: SceneObject) -> list[SceneObject]:
        table = SceneObject(kind="table", name="table", position=[self.table_distance + 0.15, 0.0, 0.0], fixed=True)
        return [table, obj]

    def _sample_goal(self) -> tuple[RigidTransform, np.ndarray]:
        task = sample_drill_grasp(self.np_random, self._bounds(), self.table_distance)  # as the library draws
        return RigidTransform(RollPitchYaw(0.0, 0.0, task.start_yaw), list(task.start)), np.array(task.target)

    def _task_reward(self, info: dict) -> float:
        drill, right = self.object_position(), self.hand_positions()[1]
        reach = np.exp(-5.0 * np.sum((right - drill) ** 2))
        grasp = float(info["hand_contacts"][1] > 0.5)
        lift = np.exp(-10.0 * np.sum((drill - self.target) ** 2))
        lifted = drill[2] >= self.start_pose.translation()[2] + self.lift_success
        self._count_success(info, bool(lifted and info["hand_contacts"].any()))
        info["reward_terms"] = {"reach": reach, "grasp": grasp, "lift": lift}
        return float(0.3 * reach + 0.2 * grasp + 0.5 * lift)
