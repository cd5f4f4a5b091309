"""Loco-manipulation environments of the method: BoxCarry-v0 and DrillGrasp-v0.

Both extend Imitation-v0 (same action, AMP output, starts and termination;
default embodiment the UDH, any other by `robot=`) with a task:

- goal g: the object's start pose and its target position, drawn at every
  reset within the configured ranges (relative to the robot's start,
  which faces +x). The observation appends, in the root's heading frame,
  the object's position and the first two columns of its rotation (9
  numbers) and the target's position (3);
- `info["interaction"]`: s_I = {d_ho, d_og, e_ho} from the
  InteractionGraphSystem (hand-object vectors, object-target vector,
  hand-object contact flags), and `info["goal"]` (start pose, target);
- task reward r_g in [0, 1], see each class.
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw

from hotu_drake import embodiment as embodiments
from hotu_drake.embodiment.spec import HAND_ROLES
from hotu_drake.envs.base import DiagramEnv, environment_scenario
from hotu_drake.errors import InputError, check_number, check_vector
from hotu_drake.objects import DRILL_BASE, TABLE_TOP, SceneObject, object_body
from hotu_drake.retarget.references import reference_clips
from hotu_drake.rotations import heading_rotation
from hotu_drake.scenario import Scenario

GOAL_FEATURES = 3 + 6 + 3


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

    object_kind = "box"

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
        self._targets = sim.systems["object_targets"]
        self.start_pose = RigidTransform()
        self.target = np.zeros(3)

    def _scene_objects(self, obj: SceneObject) -> list[SceneObject]:
        return [obj]

    def _observation_size(self) -> int:
        return super()._observation_size() + GOAL_FEATURES

    def _sample_goal(self) -> tuple[RigidTransform, np.ndarray]:
        raise NotImplementedError

    def _place_task(self) -> None:
        self.start_pose, self.target = self._sample_goal()
        plant = self.sim.plant
        plant.SetFreeBodyPose(self._plant_context, self._object_body, self.start_pose)
        source = self._targets.get_mutable_source_value(self._targets.GetMyMutableContextFromRoot(self._context))
        source.set_value(self.target)

    def _extra_observation(self) -> np.ndarray:
        plant, context = self.sim.plant, self._plant_context
        root = plant.EvalBodyPoseInWorld(context, self._root)
        heading = heading_rotation(root.rotation().matrix()).T
        pose = plant.EvalBodyPoseInWorld(context, self._object_body)
        rotation = heading @ pose.rotation().matrix()
        return np.concatenate(
            [
                heading @ (pose.translation() - root.translation()),
                rotation[:, 0],
                rotation[:, 1],
                heading @ (self.target - root.translation()),
            ]
        )

    def object_position(self) -> np.ndarray:
        return self.sim.plant.EvalBodyPoseInWorld(self._plant_context, self._object_body).translation()

    def hand_positions(self) -> np.ndarray:
        plant = self.sim.plant
        return np.array([plant.EvalBodyPoseInWorld(self._plant_context, b).translation() for b in self._hand_bodies])

    def _info(self, terminated: bool) -> dict:
        info = super()._info(terminated)
        interaction = self._graph_port.Eval(self._context)
        info["interaction"] = interaction.astype(np.float32)
        info["hand_contacts"] = interaction[-2:].copy()  # e_ho: left, right
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

    r_g = 0.2 exp(-2 |hands' midpoint - box|^2) (approach)
        + 0.3 [both hands touch the box and it is above `carry_height`] (carrying)
        + 0.5 exp(-0.5 |box - target|^2) (delivery);
    `info["success"]` once the box is within 0.15 m of the target.
    """

    def __init__(
        self,
        robot: str | None = None,
        hands: str | None = None,
        motions: Sequence[str] | None = ("walk", "box_carry"),
        start_distance: tuple[float, float] = (0.5, 0.8),
        start_bearing: tuple[float, float] = (-0.3, 0.3),
        start_height: tuple[float, float] = (0.75, 1.0),
        target_distance: tuple[float, float] = (1.0, 3.0),
        target_bearing: tuple[float, float] = (-np.pi, np.pi),
        target_height: tuple[float, float] = (0.6, 1.0),
        carry_height: float = 0.3,
        **options,
    ):
        where = type(self).__name__
        self.ranges = {
            "start_distance": Range.of(start_distance, "start_distance", where, 0.0, 10.0),
            "start_bearing": Range.of(start_bearing, "start_bearing", where, -np.pi, np.pi),
            "start_height": Range.of(start_height, "start_height", where, 0.0, 3.0),
            "target_distance": Range.of(target_distance, "target_distance", where, 0.0, 20.0),
            "target_bearing": Range.of(target_bearing, "target_bearing", where, -np.pi, np.pi),
            "target_height": Range.of(target_height, "target_height", where, 0.0, 3.0),
        }
        self.carry_height = check_number(carry_height, "carry_height", where, low=0.0, high=3.0, unit="m")
        obj = SceneObject(kind="box", name="box", position=[0.6, 0.0, 0.9], held=True)
        super().__init__(robot, hands, motions, obj, **options)

    def _sample_goal(self) -> tuple[RigidTransform, np.ndarray]:
        r, rng = self.ranges, self.np_random
        d, bearing = r["start_distance"].sample(rng), r["start_bearing"].sample(rng)
        start = [d * np.cos(bearing), d * np.sin(bearing), r["start_height"].sample(rng)]
        yaw = bearing + float(rng.uniform(-0.3, 0.3))
        d, bearing = r["target_distance"].sample(rng), r["target_bearing"].sample(rng)
        target = np.array([d * np.cos(bearing), d * np.sin(bearing), r["target_height"].sample(rng)])
        return RigidTransform(RollPitchYaw(0.0, 0.0, yaw), start), target

    def _task_reward(self, info: dict) -> float:
        box, hands = self.object_position(), self.hand_positions()
        approach = np.exp(-2.0 * np.sum((hands.mean(axis=0) - box) ** 2))
        carrying = float(info["hand_contacts"].all() and box[2] > self.carry_height)
        delivery = np.exp(-0.5 * np.sum((box - self.target) ** 2))
        info["success"] = bool(np.linalg.norm(box - self.target) < 0.15)
        info["reward_terms"] = {"approach": approach, "carrying": carrying, "delivery": delivery}
        return float(0.2 * approach + 0.3 * carrying + 0.5 * delivery)


class DrillGraspEnv(_ObjectTaskEnv):
    """Pick a drill up from a table in front of the robot and hold it at a
    target above the table.

    r_g = 0.3 exp(-5 |right hand - drill|^2) (reach)
        + 0.2 [the right hand touches the drill] (grasp)
        + 0.5 exp(-10 |drill - target|^2) (lift to the target);
    `info["success"]` once the drill is within 0.05 m of the target.
    """

    def __init__(
        self,
        robot: str | None = None,
        hands: str | None = None,
        motions: Sequence[str] | None = ("walk", "drill_grasp"),
        table_distance: float = 0.65,
        drill_offset: tuple[float, float] = (-0.15, 0.15),
        lift_height: tuple[float, float] = (0.15, 0.35),
        **options,
    ):
        where = type(self).__name__
        self.table_distance = check_number(table_distance, "table_distance", where, low=0.3, high=3.0, unit="m")
        self.ranges = {
            "drill_offset": Range.of(drill_offset, "drill_offset", where, -0.4, 0.4),
            "lift_height": Range.of(lift_height, "lift_height", where, 0.0, 1.0),
        }
        obj = SceneObject(kind="drill", name="drill")
        super().__init__(robot, hands, motions, obj, **options)

    def _scene_objects(self, obj: SceneObject) -> list[SceneObject]:
        table = SceneObject(kind="table", name="table", position=[self.table_distance + 0.15, 0.0, 0.0], fixed=True)
        return [table, obj]

    def _sample_goal(self) -> tuple[RigidTransform, np.ndarray]:
        r, rng = self.ranges, self.np_random
        y = r["drill_offset"].sample(rng)
        height = TABLE_TOP + DRILL_BASE + 0.002
        start = [self.table_distance, y, height]
        yaw = float(rng.uniform(-0.5, 0.5))
        target = np.array([self.table_distance - 0.15, y, height + r["lift_height"].sample(rng)])
        return RigidTransform(RollPitchYaw(0.0, 0.0, yaw), start), target

    def _task_reward(self, info: dict) -> float:
        drill, right = self.object_position(), self.hand_positions()[1]
        reach = np.exp(-5.0 * np.sum((right - drill) ** 2))
        grasp = float(info["hand_contacts"][1] > 0.5)
        lift = np.exp(-10.0 * np.sum((drill - self.target) ** 2))
        info["success"] = bool(np.linalg.norm(drill - self.target) < 0.05)
        info["reward_terms"] = {"reach": reach, "grasp": grasp, "lift": lift}
        return float(0.3 * reach + 0.2 * grasp + 0.5 * lift)
