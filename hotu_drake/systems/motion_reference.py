"""MotionReference: a clip's phase, reference and joints against the robot, for a policy that follows the clip.

A controller cloned from the whole-body controller (`learning.dagger`)
may observe, besides the robot, where it is in its clip (`phase`: the
sine and cosine of an angle, `clip_phase`), where the clip's reference
is against it (`reference`: `reference_features`) and the clip's joints
against its own (`pose`: `pose_features`), as the environments gave
them in training (`phase_observation`, `reference_observation`,
`pose_observation`). This system gives the same numbers in any
diagram, without the controller's QP: the clip is placed where the
robot starts (its start over the robot's root, facing the robot's
heading) and tracked from where the robot's feet land, as the
controller tracks it (`control.footing`). A controller's catch steps are
not followed: during one the controller takes the catching foot off the
planted ones and eases its footing faster.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, DiscreteValues, LeafSystem

from hotu_drake.control.clip_plan import ClipPlan
from hotu_drake.control.footing import Footing
from hotu_drake.control.whole_body_qp import feet_soles
from hotu_drake.embodiment import Embodiment
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.plant import actuated_state_indices, alignment, move_free_body, placed_under
from hotu_drake.rotations import heading_rotation, heading_yaw

PHASE_SIZE = 2  # `clip_phase`: the sine and cosine of where the robot is in its clip
# `reference_features`: the reference's root (3), heading (2), CoM position (3) and velocity (3) and feet
# (2 x 3), against the robot's, in its heading frame
REFERENCE_SIZE = 17
EXTRAS = ("phase", "reference", "pose")  # what a clip-following policy may observe after the robot, in order


def extra_size(extra: str, embodiment: Embodiment) -> int:
    """How many numbers one of `EXTRAS` is on `embodiment`."""
    return {"phase": PHASE_SIZE, "reference": REFERENCE_SIZE}.get(extra, 2 * len(embodiment.joint_names))


def pose_features(reference: tuple[np.ndarray, np.ndarray], q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The clip's joint positions and velocities (`reference`, joint order)
    less the robot's `q` and `v`: 2 n numbers, where the clip asks each
    joint to be (the largest part of what a tracking controller does)."""
    positions, velocities = reference
    return np.r_[positions - q, velocities - v]


def clip_phase(time: float, duration: float, loop: bool) -> np.ndarray:
    """Where `time` is in a clip of `duration` s, as the sine and cosine of
    an angle: a looped clip's share of its cycle times 2 pi, another's
    share of its duration times pi (so its start and end differ)."""
    share = time / max(duration, 1e-9)
    angle = 2.0 * np.pi * (share % 1.0) if loop else np.pi * min(share, 1.0)
    return np.array([np.sin(angle), np.cos(angle)])


def reference_features(
    root: RigidTransform,
    com: np.ndarray,
    com_velocity: np.ndarray,
    reference_root: RigidTransform,
    reference_com: np.ndarray,
    reference_com_velocity: np.ndarray,
    reference_feet: Sequence[np.ndarray] | None,
    frame: RigidTransform,
    shift: np.ndarray,
) -> np.ndarray:
    """Where a clip's reference is against the robot, in the robot's
    heading frame (`REFERENCE_SIZE` numbers): the reference's root, heading
    (sine and cosine of the yaw between them), CoM position and velocity,
    and feet ((2, 3), left then right; zeros for None), each placed where
    it is tracked (the clip's world taken to the world by `frame`, then
    moved by the footing `shift` of the clip's world) minus the robot's
    (its `root` pose, `com` and `com_velocity`, in the world)."""
    turn = frame.rotation().matrix()
    moved = turn @ shift

    def placed(point: np.ndarray) -> np.ndarray:
        return frame @ point + moved

    heading = heading_rotation(root.rotation().matrix())
    yaw = heading.T @ heading_rotation(turn @ reference_root.rotation().matrix())
    feet = np.zeros(6)
    if reference_feet is not None:
        feet = np.concatenate([heading.T @ (placed(foot) - root.translation()) for foot in reference_feet])
    return np.concatenate(
        [
            heading.T @ (placed(reference_root.translation()) - root.translation()),
            [yaw[1, 0], yaw[0, 0]],
            heading.T @ (placed(reference_com) - com),
            heading.T @ (turn @ reference_com_velocity - com_velocity),
            feet,
        ]
    )


def planar_transform(x: float, y: float, yaw: float) -> RigidTransform:
    """The turn by `yaw` about z, then the shift (x, y, 0)."""
    return RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, 0.0])


class MotionReference(LeafSystem):
    """A clip's phase, reference and joints against the robot (see the module docstring).

    .. pydrake_system::

        name: MotionReference
        input_ports:
        - state
        output_ports:
        - phase
        - reference
        - pose

    `state` is the robot model's [q; v]. Discrete state: where the clip
    is placed in the world (x, y, yaw; set from the robot's root at
    initialization) and its footing shift (3, in the clip's world),
    updated every control period from the robot's feet; the outputs read
    them as the last update left them, as the environments' observations
    do.
    """

    def __init__(
        self,
        embodiment: Embodiment,
        clip: MotionClip,
        control_period: float,
        loop: bool = True,
        start_time: float = 0.0,
    ):
        """`start_time`: the clip's time at the diagram's time 0."""
        super().__init__()
        self.embodiment, self.clip, self.loop, self.start_time = embodiment, clip, loop, start_time
        plant = self._plant = MultibodyPlant(0.0)
        model = embodiment.add_to_plant(plant, builtin_pd=False)
        plant.Finalize()
        self._robot = plant.CreateDefaultContext()
        self._reference = plant.CreateDefaultContext()
        self.plan = ClipPlan(clip, plant, model, embodiment, self._reference, loop)
        self.footing = Footing(plant, self.plan, feet_soles(plant, embodiment), control_period)
        self._root = plant.GetBodyByName(embodiment.spec.root.name, model)
        self._models = [model]
        self._start = alignment(ClipPlayback(clip, loop=False), start_time)  # the clip's start at the origin
        self._playback = ClipPlayback(clip, loop)  # its joints (`pose`)
        self._joints = actuated_state_indices(plant, model, embodiment.joint_names)
        self._state = self.DeclareVectorInputPort("state", plant.num_multibody_states())
        self._placement = self.DeclareDiscreteState(3)  # x, y, yaw
        self._shift = self.DeclareDiscreteState(3)
        self.DeclareInitializationDiscreteUpdateEvent(self._Place)
        self.DeclarePeriodicDiscreteUpdateEvent(control_period, 0.0, self._Follow)
        self.DeclareVectorOutputPort("phase", PHASE_SIZE, self._CalcPhase)
        self.DeclareVectorOutputPort("reference", REFERENCE_SIZE, self._CalcReference)
        self.DeclareVectorOutputPort("pose", extra_size("pose", embodiment), self._CalcPose)

    def frame(self, context: Context) -> RigidTransform:
        """Where the clip's world is in the world (the clip's start over the robot's)."""
        x, y, yaw = context.get_discrete_state(self._placement).get_value()
        return planar_transform(x, y, yaw)

    def shift(self, context: Context) -> np.ndarray:
        """The footing shift (m, in the clip's world) as the last update left it."""
        return context.get_discrete_state(self._shift).get_value().copy()

    def reference_travel(self, duration: float) -> float:
        """How far (m, horizontally) the clip's pelvis moves over `duration` s from the start."""
        return self.plan.pelvis_travel(self.start_time, duration)

    def clip_time(self, context: Context) -> float:
        return self.start_time + context.get_time()

    def _set_robot(self, context: Context) -> None:
        self._plant.SetPositionsAndVelocities(self._robot, self._state.Eval(context))

    def _Place(self, context: Context, discrete_state: DiscreteValues) -> None:
        self._set_robot(context)
        frame = placed_under(self._plant.EvalBodyPoseInWorld(self._robot, self._root), self._start)
        discrete_state.set_value(self._placement, [*frame.translation()[:2], heading_yaw(frame.rotation().matrix())])
        discrete_state.set_value(self._shift, np.zeros(3))

    def _Follow(self, context: Context, discrete_state: DiscreteValues) -> None:
        """The footing one period on, from the robot's feet taken into the clip's world."""
        self._set_robot(context)
        plant, robot = self._plant, self._robot
        if self.embodiment.floating_base:
            move_free_body(plant, robot, self._root, self.frame(context).inverse())
        time = self.clip_time(context)
        self.plan.set_reference(self._reference, time)
        footing = self.footing
        planted = footing.planted(robot, time, footing.pushing_off(self._reference, time))
        discrete_state.set_value(self._shift, footing.follow(self.shift(context), robot, self._reference, planted))

    def _CalcPhase(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(clip_phase(self.clip_time(context), self.clip.duration, self.loop))

    def _CalcPose(self, context: Context, output: BasicVector) -> None:
        state = self._state.Eval(context)
        q, v = state[self._joints[0]], state[self._joints[1]]
        output.SetFromVector(pose_features(self._playback.joints_at(self.clip_time(context)), q, v))

    def _CalcReference(self, context: Context, output: BasicVector) -> None:
        self._set_robot(context)
        plant, robot, reference, plan = self._plant, self._robot, self._reference, self.plan
        time = self.clip_time(context)
        plan.set_reference(reference, time)
        com, com_velocity, _ = plan.com_reference(time)
        features = reference_features(
            plant.EvalBodyPoseInWorld(robot, self._root),
            plant.CalcCenterOfMassPositionInWorld(robot, self._models),
            plant.CalcCenterOfMassTranslationalVelocityInWorld(robot, self._models),
            plant.EvalBodyPoseInWorld(reference, plan.root_body),
            com,
            com_velocity,
            plan.feet_positions(reference),
            self.frame(context),
            self.shift(context),
        )
        output.SetFromVector(features)


def AddMotionReference(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    model,
    embodiment: Embodiment,
    clip: MotionClip,
    control_period: float,
    loop: bool = True,
    start_time: float = 0.0,
) -> MotionReference:
    """Add a `MotionReference` named `motion_reference` fed by `plant`'s state of the robot `model`."""
    system = builder.AddNamedSystem(
        "motion_reference", MotionReference(embodiment, clip, control_period, loop, start_time)
    )
    builder.Connect(plant.get_state_output_port(model), system.GetInputPort("state"))
    return system
