"""WholeBodyController: performs a clip in the plant by one QP per control step.

At each control step the controller sets its own copy of the robot's
`MultibodyPlant` to the measured state and solves the whole-body QP
(`control.whole_body_qp`): centre of mass along the clip's ZMP plan
(`control.clip_plan`, with the plan's LQR feedback), pelvis and torso
orientation, swing feet, the hands in a clip that handles an object, the
clip's joint posture, the planted soles' corners held still (one that
slides braked; a sole that turns only as its leg leans, H1's, at the edge
it stands on; a trailing foot, as it lifts, on the edge it pushes off on),
within friction pyramids and torque limits. On both feet with its capture
point outside its soles, the robot steps of its own (`control.catch_step`):
a pushed robot, or one ending a walk still moving. A robot on a wheeled base (CURI) has
no balance to keep: its tasks are the body's, the hands' and the posture. It acts
through the path a policy acts through: an action (normalised PD targets
within the joints' limits, the velocity targets zero) for the plant's PD,
the QP's torque folded into the target (`WholeBodyController.act`), so
its actions are actions a policy could output: a teacher's.
"""

from __future__ import annotations

from dataclasses import dataclass
from time import perf_counter

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import Context, DiagramBuilder, DiscreteValues, LeafSystem

from hotu_drake.control.catch_step import (
    CATCH_FOOTING_EASING,
    CATCH_FOOTING_TIME,
    CATCH_LATE,
    CATCH_MARGIN,
    CATCH_MOVED,
    CATCH_REACH,
    CATCH_SWING,
    CATCH_TOUCHDOWN,
    CATCH_WEIGHT,
    CatchStep,
    capture_point,
    catch_landing,
    outside,
)
from hotu_drake.control.clip_plan import ClipPlan, pendulum_frequency
from hotu_drake.control.footing import TOUCHING, Footing
from hotu_drake.control.footsteps import beside_capture, heading_axes, predicted_capture, side_of
from hotu_drake.control.whole_body_qp import (
    Sole,
    Solution,
    Task,
    WholeBodyQp,
    feet_soles,
    soles_on_edges,
    soles_rolling_with_legs,
)
from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.actions import ActionScaling
from hotu_drake.embodiment.spec import SIDES
from hotu_drake.motion.clip import MotionClip
from hotu_drake.plant import actuated_joint_order, actuated_state_indices, set_robot_state
from hotu_drake.retarget.balance import TorqueDemand
from hotu_drake.retarget.retargeter import foot_contacts_of


@dataclass
class TrackingGains:
    """Task weights and PD stiffnesses of the controller's tasks (each task's damping critical: 2 sqrt(stiffness))."""

    com_weight: float = 1000.0
    com_height_stiffness: float = 50.0
    # Pelvis and torso orientation, for a CoM `BODY_WEIGHT_HEIGHT` high; a robot on feet scales it by the
    # square of its CoM's height over that, so that turning the body and moving the CoM trade alike at every
    # size (a CoM accelerating at a asks the body to turn at about a / height).
    body_weight: float = 10.0
    body_stiffness: float = 100.0
    swing_weight: float = 70.0
    swing_stiffness: float = 400.0
    # A swing foot lands this share of the capture point's error (the CoM's error against the ZMP plan's
    # plus its velocity's over the pendulum's frequency) away from the clip's footstep: the step that
    # brings a pushed CoM back, where it will be as the foot lands (`STEP_LOOK_AHEAD`). The offset grows
    # with the swing, from none at liftoff.
    step_adjustment: float = 1.0
    hand_weight: float = 10.0  # the hands' positions, in a clip that handles an object
    hand_stiffness: float = 100.0
    posture_weight: float = 1.0
    posture_stiffness: float = 100.0


CONTROL_LEAD = 1e-6  # s: how long before the plant's step the controller acts (`WholeBodyController`)
STEP_LOOK_AHEAD = 0.15  # s: how far ahead a swing foot's step is placed for the capture point's growth
# m: a swing foot of the clip with a line for a sole lands at least this far on its own side of the capture
# point predicted at its touchdown (looked ahead `STEP_LOOK_AHEAD`; `control.footsteps`): landing inward of it
# leaves the body falling outward over a foot that cannot press anywhere but on its line. BRUCE, eight motions
# from four starts each: 29 of 32 up (16 without; its walks, turning walks and boxing from 0-2 of 4 to 4 of 4);
# 2 cm: 27; looked ahead to the touchdown: 19 (a long swing's prediction ran away). A sole with width presses
# across it instead: the same rule, less half the sole's width, on every robot moved H1's turning walk from 10
# to 9 of 10 starts up and nothing else.
CAPTURE_BESIDE = 0.01
NEXT_STEP = 1e-6  # s: a step this near one period after the last is the next control step
ROLLED = 0.005  # rad: a sole turned this far about its length stands on its lower edge
LEANING = 0.05  # m/s^2: the sideways CoM acceleration asked for which both flat soles of a rolling pair tip
LANDING_DEPTH = 0.005  # m: a foot the clip has down that is not yet down is drawn this far below the floor
BODY_WEIGHT_HEIGHT = 1.0  # m: the CoM height `TrackingGains.body_weight` is for (H1's 1.01; BRUCE's 0.41)
# On line feet (where only where a foot lands balances the robot) a swinging leg's joints (its hip, knee and
# ankle) hold the clip's posture at this share of the posture's weight: the swing foot's task places them. At the
# full weight the posture held BRUCE's swing foot down as it lifted (asked +10 m/s^2 up, the QP gave +1): it rose
# 1.8 of the clip's 3.3 cm and touched down at 80% of its swing, so the step adjustment, taken in over the swing,
# came after the foot could no longer move; walking backward each step landed 3-5 cm past where it was sent and
# the body fell behind its plan (walk_backward 2/4 from four starts). At 0.5: BRUCE's walk_backward 4/4 (10/10
# from ten starts, 8/10 before) and its looped walk 10 of 10 seeds (5 of 6); none (0.0) lost its walks (1/4),
# 0.3 its fast walk (1/4), 0.7 its fast walk 2/4. On every robot: H1's box carry and left turn 3/4 (4/4).
SWING_LEG_POSTURE = 0.5
# A planted foot's leg joints hold the clip's posture at this share of the posture's weight on the frames where
# the clip's own inverse dynamics (`TorqueDemand`) asks a joint of that leg for more than its torque limit: the
# leg cannot move as the clip's does there, and where its foot stands and where the body goes (the CoM's and the
# pelvis' tasks) place it. NAVIAI's leg_stretch bends the front knee to lift the foot 0.1 s before its label
# lets the foot go, its hip and ankles asked 1.3-5.8 times their limits: at the full weight the QP took the
# weight off that foot to bend it (the CoM asked back at 0.5 m/s^2, predicted forward at 2.6), the body stayed
# over the back foot's toes, and the return step landed 0.35 m ahead to catch it: every start stood, but ended
# 0.43-0.57 m from the clip's end (0.13-0.35 m now). Eased on every planted frame instead, NAVIAI ended 0.08-0.32
# m off, but the UDH's leg_stretch 0.13-0.29 (0.01-0.03), H1 fell in its looped walk (1 seed of 6) and its left
# turn (1 start of 4); eased only on two feet, or only in the 0.25 s before a lift, NAVIAI still ended 0.42-0.47
# m off and fell once. None (0.0, eased everywhere): NAVIAI fell from every start; 0.3: one start 0.46 m off.
# Not on line feet: BRUCE's clips ask past a leg's limit on under 1% of their frames, and easing those lost its
# fast walk two starts of four (BENCHMARKS.md, sixteenth session).
PLANTED_LEG_POSTURE = 0.1
LEG_PARTS = ("hip", "knee", "ankle")


def _rotation_vector(rotation) -> np.ndarray:
    """The axis times the angle of a Drake `RotationMatrix`."""
    turn = rotation.ToAngleAxis()
    return turn.axis() * turn.angle()


def _damping(stiffness: float) -> float:
    return 2.0 * np.sqrt(stiffness)


class WholeBodyController(LeafSystem):
    """Tracks a clip of its embodiment with one whole-body QP per control step.

    .. pydrake_system::

        name: WholeBodyController
        input_ports:
        - state
        output_ports:
        - desired_state
        - torques

    `state` is the robot model's [q; v]; `desired_state` the [q*; 0] of
    the plant's PD (actuator order), held between control steps, q* the
    targets of its action (`act`); `torques` the QP's torques u at the
    last step.
    """

    def __init__(
        self,
        embodiment: Embodiment,
        clip: MotionClip,
        control_period: float,
        loop: bool = True,
        gains: TrackingGains | None = None,
        start_time: float = 0.0,
        plant_step: float | None = None,
    ):
        """`start_time`: the clip's time at the diagram's time 0 (a run that
        starts partway through it); `plant_step`: the simulation's time step
        (by default the control period), over which the plant's PD holds an
        action a whole number of steps."""
        super().__init__()
        self.start_time = start_time
        self.embodiment, self.period, self.gains = embodiment, control_period, gains or TrackingGains()
        self.plant_step = control_period if plant_step is None else plant_step
        self._steps = max(1, int(round(control_period / self.plant_step)))
        plant = self._plant = MultibodyPlant(0.0)
        self._model = embodiment.add_to_plant(plant, builtin_pd=False)
        plant.Finalize()
        self._context = plant.CreateDefaultContext()
        self._reference = plant.CreateDefaultContext()
        self._reference_accelerations = np.zeros(plant.num_velocities())
        self._step = 0.5 / clip.fps
        self._shift = np.zeros(3)  # where the planted feet stand against the clip's (`control.footing`)
        self._sideways_demand = np.zeros(2)  # the ZMP plan's horizontal CoM acceleration at the last step
        self._scaling = ActionScaling.for_embodiment(embodiment)
        self.plan = ClipPlan(clip, plant, self._model, embodiment, self._reference, loop)
        self._soles = feet_soles(plant, embodiment)
        self.footing = Footing(plant, self.plan, self._soles, control_period)
        if actuated_joint_order(plant, self._model) != embodiment.joint_names:
            raise RuntimeError(f"{embodiment.name}: actuator order differs from the spec's joint order")
        self._q, self._v = actuated_state_indices(plant, self._model, embodiment.joint_names)
        self._actuated_v = self._v - plant.num_positions()  # the joints' rows of vdot
        # The floating base's linear velocities (its joint's: angular, then linear, in the world): `_com_rows_from`,
        # whose rows of M are the whole plant's linear momentum only while the plant holds the robot alone.
        if plant.num_bodies() != len(plant.GetBodyIndices(self._model)) + 1:
            raise RuntimeError(f"{embodiment.name}: the controller's plant holds more than the robot")
        self._base_linear, self._mass = None, plant.CalcTotalMass(self._context)
        if embodiment.floating_base:
            root = plant.GetBodyByName(embodiment.spec.root.name, self._model)
            self._base_linear = root.floating_velocities_start_in_v() + np.arange(3, 6)
        # A swing task asking a foot whose roll is its leg's to be level and at its sideways place asks the
        # hip's roll for both, and the compromise landed H1's feet 8-11 cm off (its walk drifting sideways).
        self._roll_follows_leg = soles_rolling_with_legs(plant, self._model, embodiment, self._soles)
        self._line_soles = {name: sole.is_line for name, sole in self._soles.items()}
        # Each corner of each sole: its side of the sole (across it, from its middle).
        self._across = {name: sole.corners[:, 1] - sole.corners[:, 1].mean() for name, sole in self._soles.items()}
        self._on_lines = bool(self._soles) and all(self._line_soles.values())
        # Each foot's leg: its side's hip, knee and ankle (the posture's rows eased while it stands where the clip
        # asks it past a torque limit, and on line feet as it swings).
        joints = embodiment.spec.joints
        self._leg_joints = {
            name: np.array([j for j, joint in enumerate(joints) if joint.part in LEG_PARTS and joint.side == side], int)
            for name in self._soles
            for side in [name.removesuffix("_foot")]
        }
        if not all(len(leg) for leg in self._leg_joints.values()):
            raise RuntimeError(f"{embodiment.name}: a foot with no hip, knee or ankle joint on its side")
        # Per foot, per frame: whether the clip's own inverse dynamics (with the clip's contacts, not the
        # controller's) asks a joint of that foot's leg for more than its torque limit (`PLANTED_LEG_POSTURE`;
        # never on line feet).
        self._leg_past_limits = {name: np.zeros(clip.num_frames, bool) for name in self._soles}
        flat = [name for name, line in self._line_soles.items() if not line]
        if flat:
            demand = TorqueDemand(embodiment, plant, self._model)
            past = demand.ratios(clip, foot_contacts_of(clip, clip.num_frames)) > 1.0
            self._leg_past_limits |= {name: past[:, self._leg_joints[name]].any(axis=1) for name in flat}
        # Soles that stand on an edge as their legs lean sideways (`contacts`).
        self._rolls_on_edges = soles_on_edges(self._roll_follows_leg, self._soles)
        self.qp = WholeBodyQp(plant, self._soles, embodiment.effort_limits)
        # At 10 whatever the size, BRUCE (its CoM 0.41 m high) fell in both sidesteps and Walker (0.70 m) in
        # leg_stretch from every start, turning the body where the CoM needed moving (BENCHMARKS.md).
        scale = (self.plan.height / BODY_WEIGHT_HEIGHT) ** 2 if self._soles else 1.0
        self._body_weight = self.gains.body_weight * scale
        # The posture task's Jacobian: it selects the joints' rows of vdot.
        self._joint_rows = np.zeros((len(self._actuated_v), plant.num_velocities()))
        self._joint_rows[np.arange(len(self._actuated_v)), self._actuated_v] = 1.0
        self._bodies = [plant.GetBodyByName(embodiment.key_bodies[name]) for name in ("pelvis", "torso")]
        self._bodies = list({body.index(): body for body in self._bodies}.values())
        # The hands held in the world throughout a clip that handles an object (in any other the posture places
        # them: held in the world, a walk's swinging hands would pull the body they should balance).
        self._hands = [
            plant.GetBodyByName(embodiment.key_bodies[f"{side}_hand"])
            for side in SIDES
            if f"{side}_hand" in embodiment.key_bodies and clip.object_names
        ]
        self.last: Solution | None = None
        # Wall seconds in `act` and in its QP's solve, the calls, and the solves that failed (the last good one used).
        self.timings = {"act": 0.0, "qp": 0.0, "calls": 0, "failures": 0}
        self.last_action: np.ndarray | None = None
        # A catch step under way (`_catching`), and the (start time, foot) of each taken since `reset` (that
        # moved its foot `CATCH_MOVED` or more: one whose foot the robot could not lift is no step).
        self._catch: CatchStep | None = None
        self.catches: list[tuple[float, str]] = []
        self._caught_until = -np.inf  # the footing follows the feet faster until then (`act`)
        self._standing_width = self._feet_apart_standing()
        self.swing_goals: dict[str, np.ndarray] = {}  # where each swing foot was last sent (world, its origin)
        # The QP's model checked against what the robot did: at each control step that follows the last by one
        # period, the CoM acceleration the last solution predicted less the one the robot had (`prediction_error`).
        self._predicted: tuple[float, np.ndarray, np.ndarray] | None = None  # time, CoM velocity, its prediction
        self._prediction_errors: list[np.ndarray] = []
        n = len(embodiment.joint_names)
        self._state = self.DeclareVectorInputPort("state", plant.num_multibody_states())
        # The PD's desired state [q*; 0] and the QP's torques: each a discrete state group, each an output port.
        self._desired_state = self.DeclareDiscreteState(np.r_[embodiment.standing_pose, np.zeros(n)])
        self._torques = self.DeclareDiscreteState(n)
        # Once at the start (before the plant's first step), then every period after it, a moment before the
        # plant's step at that time: a discrete plant's state already holds where its last step took it, and
        # events at one time all read the state before them, so acting with the plant would act a period late.
        self.DeclareInitializationDiscreteUpdateEvent(self._Update)
        self.DeclarePeriodicDiscreteUpdateEvent(control_period, control_period - CONTROL_LEAD, self._Update)
        self.DeclareStateOutputPort("desired_state", self._desired_state)
        self.DeclareStateOutputPort("torques", self._torques)

    def catch_steps(self) -> list[list]:
        """The catch steps taken since `reset`, as a report lists them: [start time (s, rounded), foot]."""
        return [[round(at, 3), foot] for at, foot in self.catches]

    def _feet_apart_standing(self) -> float:
        """How far apart (m) the soles' anchors are in the standing pose (0 with fewer than two soles)."""
        plant, scratch = self._plant, self._plant.CreateDefaultContext()
        set_robot_state(plant, scratch, self._model, self.embodiment)
        anchors = [
            plant.EvalBodyPoseInWorld(scratch, sole.body).multiply(self.plan.anchors[name])[:2]
            for name, sole in self._soles.items()
        ]
        return float(np.linalg.norm(anchors[0] - anchors[1])) if len(anchors) == 2 else 0.0

    @property
    def soles(self) -> dict[str, Sole]:
        """The feet's contact corners (per contact name) the controller stands on."""
        return self._soles

    def _Update(self, context: Context, discrete_state: DiscreteValues) -> None:
        now = context.get_time()
        if now == 0.0:  # a run (re)starts: nothing carried from an earlier one
            self.reset()
        time = now if now == 0.0 else now + CONTROL_LEAD
        action = self.act(self._state.Eval(context), self.start_time + time)
        self._check_prediction(self.start_time + time)
        targets = self._scaling.to_targets(action)
        discrete_state.set_value(self._desired_state, np.r_[targets, np.zeros_like(targets)])
        discrete_state.set_value(self._torques, self.last.torques)

    def act(self, x: np.ndarray, time: float) -> np.ndarray:
        """The action (normalised PD targets, in [-1, 1], as a policy's) for
        robot state `x` ([q; v]) at `time`: the QP's torque u folded into the
        target of the plant's PD, whose velocity target is zero as a policy's
        is: the target whose implicit PD, held over the period's plant steps,
        gives u on average when the joints move with the accelerations the QP
        predicts (over one step dt: q* = q + dt v' + (u + kd v') / kp, v' = v
        + dt vdot). The QP's solution is kept as `last`."""
        start = perf_counter()
        plant, emb = self._plant, self.embodiment
        plant.SetPositionsAndVelocities(self._context, x)
        dynamics = plant.CalcMassMatrix(self._context), plant.CalcBiasTerm(self._context)  # M and C(q, v) v
        self._com_rows = self._com_rows_from(*dynamics)  # for the CoM's task and `_check_prediction`
        self.plan.set_reference(self._reference, time)
        self._reference_accelerations = self._accelerations_at(time)
        # Every body's spatial acceleration in the reference (world frame), for the body tasks' feed-forward.
        self._goal_accelerations = plant.CalcSpatialAccelerationsFromVdot(
            self._reference, self._reference_accelerations
        )
        pushing = self.pushing_off(time)
        planted = self.planted(time, pushing)
        planted, pushing = self._catching(time, planted, pushing)
        easing = CATCH_FOOTING_EASING if time < self._caught_until else None  # a caught robot's footing: faster
        self._shift = self.footing.follow(self._shift, self._context, self._reference, planted, easing)
        tasks = self.tasks(time, planted)
        held, lifting = self.contacts(planted, pushing)
        solving = perf_counter()
        solution = self.qp.solve(self._context, tasks, held, lifting, dynamics)
        self.timings["qp"] += perf_counter() - solving
        if not solution.success and self.last is not None:
            self.timings["failures"] += 1
            solution = Solution(self.last.accelerations, self.last.forces, self.last.torques, False)
        self.last = solution
        q, v = x[self._q], x[self._v]
        a, dt, n = solution.accelerations[self._actuated_v], self.plant_step, self._steps
        # Held over n implicit steps of dt, the PD's mean torque is u when the joints move as predicted
        # (q_i = q + i dt v + dt^2 a i (i + 1) / 2, v_i = v + i dt a for the steps i = 1..n).
        mean_step, mean_square = (n + 1) / 2.0, (n + 1) * (n + 2) / 6.0
        targets = (
            q
            + dt * mean_step * v
            + dt * dt * mean_square * a
            + (solution.torques + emb.kd * (v + dt * mean_step * a)) / emb.kp
        )
        self.last_action = np.clip(self._scaling.to_action(targets), -1.0, 1.0)
        self.timings["act"] += perf_counter() - start
        self.timings["calls"] += 1
        return self.last_action

    def _com_rows_from(self, mass: np.ndarray, coriolis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The CoM's Jacobian (3, nv) and Jdot v (world) at the state in the
        controller's context, whose mass matrix and C(q, v) v are given. On a
        floating base, the base's linear rows of both over the mass: those of
        M map v to the whole body's linear momentum, the mass times the CoM's
        velocity, and those of C v are its rate with no acceleration (equal
        to rounding to Drake's CoM Jacobian and bias, which cost a thirteenth
        of H1's control step). On another base (CURI's), Drake's own, read
        from the context (the arguments unused)."""
        if self._base_linear is None:
            plant, context, world, kv = self._plant, self._context, self._plant.world_frame(), JacobianWrtVariable.kV
            return (
                plant.CalcJacobianCenterOfMassTranslationalVelocity(context, kv, world, world),
                plant.CalcBiasCenterOfMassTranslationalAcceleration(context, kv, world, world),
            )
        return mass[self._base_linear] / self._mass, coriolis[self._base_linear] / self._mass

    @property
    def predictions_checked(self) -> int:
        """How many control steps' predictions have been checked since `reset` (`prediction_error`)."""
        return len(self._prediction_errors)

    def prediction_error(self, skip: int = 0) -> np.ndarray | None:
        """The median (m/s^2, world x, y, z; over the control steps since
        `reset` but the first `skip` checked, say a lead-in's; None before
        two) of how far the CoM acceleration each solution predicted was
        from the one the robot had over the next period, at the diagram's
        control steps: where the QP's model of the robot and its contacts is
        wrong (H1's sideways lean on flat soles: its soft contacts let the
        QP sink one held edge and lift the other, `whole_body_qp.CONTACT_WEIGHT`).
        The median, as a landing's impact is no error of the model's."""
        errors = self._prediction_errors[skip:]
        if not errors:
            return None
        return np.median(np.abs(errors), axis=0)

    def _check_prediction(self, time: float) -> None:
        """At a control step of the diagram (the state `act` set in the
        controller's context, the solution it kept): what the robot's CoM did
        over the period since the last step, against what that step's solution
        predicted; then this step's prediction. Only the diagram's own steps
        count: a teacher's label for another state (an environment's) would
        compare its prediction with what the student's action did."""
        jacobian, bias = self._com_rows
        velocity = jacobian @ self._plant.GetVelocities(self._context)
        if self._predicted is not None and abs(time - self._predicted[0] - self.period) < NEXT_STEP:
            realized = (velocity - self._predicted[1]) / (time - self._predicted[0])
            self._prediction_errors.append(self._predicted[2] - realized)
        self._predicted = (time, velocity, jacobian @ self.last.accelerations + bias)

    def reference_travel(self, duration: float) -> float:
        """How far (m, horizontally) the clip's pelvis moves over `duration` s
        from the controller's start (a loop carrying its root motion on)."""
        return self.plan.pelvis_travel(self.start_time, duration)

    @property
    def plant(self) -> MultibodyPlant:
        """The controller's own plant (the robot alone)."""
        return self._plant

    @property
    def reference_context(self) -> Context:
        """The controller's context of the reference (`plan.set_reference` sets it; `act` sets it anew)."""
        return self._reference

    @property
    def footing_shift(self) -> np.ndarray:
        """Where the clip is tracked from against where it is (m, horizontal,
        in the clip's world): the planted feet's offset from the clip's, eased
        (`control.footing`)."""
        return self._shift.copy()

    def reset(self) -> None:
        """Forget what the controller carried from step to step (the QP's warm
        start, where the feet stood): a new episode."""
        self._shift = np.zeros(3)
        self._predicted, self._prediction_errors, self.swing_goals = None, [], {}
        self._sideways_demand = np.zeros(2)
        self._catch, self.catches, self._caught_until = None, [], -np.inf
        self.qp.reset()

    def _accelerations_at(self, time: float) -> np.ndarray:
        """The reference's generalized accelerations at `time` (a central difference of its velocities)."""
        step = self._step
        before, after = self.plan.velocities(max(time - step, 0.0)), self.plan.velocities(time + step)
        return (after - before) / (time + step - max(time - step, 0.0))

    # --- the tasks -----------------------------------------------------------------

    def planted(self, time: float, pushing: dict[str, np.ndarray] | None = None) -> dict[str, bool]:
        """The soles the controller stands on at `time` (the reference set
        to it; `Footing.planted`), with the feet `pushing` off (by default
        `pushing_off(time)`)."""
        pushing = self.pushing_off(time) if pushing is None else pushing
        return self.footing.planted(self._context, time, pushing)

    def pushing_off(self, time: float) -> dict[str, np.ndarray]:
        """The feet pushing off at `time` (the reference set to it;
        `Footing.pushing_off`), each with the corners it pushes off on."""
        return self.footing.pushing_off(self._reference, time)

    def _catching(
        self, time: float, planted: dict[str, bool], pushing: dict[str, np.ndarray]
    ) -> tuple[dict[str, bool], dict[str, np.ndarray]]:
        """The soles planted and pushing off at `time` with a catch step
        under way (its foot in the air), starting one if the robot needs it
        (`_start_catch`); a catch ends as its foot lands (`CATCH_TOUCHDOWN`)
        or, landed or not, at `CATCH_LATE`."""
        if self._catch is None:
            self._catch = self._start_catch(time, planted)
        catch = self._catch
        if catch is None:
            return planted, pushing
        share = catch.share(time)
        sole = self._soles[catch.foot]
        pose = self._plant.EvalBodyPoseInWorld(self._context, sole.body)
        self._caught_until = time + CATCH_FOOTING_TIME
        if share >= CATCH_LATE or (share >= CATCH_TOUCHDOWN and pose.multiply(sole.corners.T)[2].min() < TOUCHING):
            self._catch = None
            if np.linalg.norm((pose.translation() - catch.origin)[:2]) >= CATCH_MOVED:  # a step, not a foot kept put
                self.catches.append((catch.start, catch.foot))
            return planted, pushing
        return {**planted, catch.foot: False}, {name: edge for name, edge in pushing.items() if name != catch.foot}

    def _start_catch(self, time: float, planted: dict[str, bool]) -> CatchStep | None:
        """A catch step, if the robot stands on both feet, the clip lifts
        neither for a swing's time (`CATCH_SWING`), and the capture point lies
        outside the soles (`CATCH_MARGIN`): the foot farther from it steps to
        where it will be (`catch_landing`), the nearer carries the robot."""
        plant, context = self._plant, self._context
        if len(self._soles) != 2 or not all(planted.get(name) for name in self._soles):
            return None
        if min(self.plan.until_lifting(name, time) for name in self._soles) < CATCH_SWING:
            return None
        com = plant.CalcCenterOfMassPositionInWorld(context)
        capture = capture_point(com, plant.CalcCenterOfMassTranslationalVelocityInWorld(context))
        poses = {name: plant.EvalBodyPoseInWorld(context, sole.body) for name, sole in self._soles.items()}
        soles = {name: poses[name].multiply(sole.corners.T)[:2].T for name, sole in self._soles.items()}
        if outside(capture, np.vstack(list(soles.values()))) <= CATCH_MARGIN:
            return None
        stance = min(soles, key=lambda name: outside(capture, soles[name]))
        foot = next(name for name in soles if name != stance)
        frequency = pendulum_frequency(com[2])
        landing = catch_landing(
            capture,
            frequency,
            soles[stance],
            poses[stance].multiply(self.plan.anchors[stance])[:2],
            poses[stance].rotation().matrix()[:2, 0],
            side_of(foot),
            self._standing_width,
            CATCH_REACH * self.plan.height,
        )
        swing = poses[foot]
        anchor = swing.rotation().multiply(self.plan.anchors[foot])
        origin = swing.translation()
        goal = np.append(landing - anchor[:2], origin[2] - LANDING_DEPTH)
        return CatchStep(foot, time, CATCH_SWING, origin, goal, swing.rotation())

    def contacts(self, planted: dict[str, bool], pushing: dict[str, np.ndarray] | None = None) -> tuple[dict, dict]:
        """Which corners of each planted sole the QP holds, and which may lift
        (by name, (K,) bools). A foot pushing off (`pushing`, by name the
        corners it pushes off on: `pushing_off`) is held on that whole edge,
        even on a sole rolled about its length (held at the one corner of
        the edge on its lower side, H1's walks lost pace and its box carry
        fell). A sole that rolls on an edge (`_rolls_on_edges`) and is
        turned about its length stands on its lower edge: held there, its
        other corners free to lift. Flat, with both feet down and the ZMP
        plan asking the CoM sideways, both such soles are held at their edge
        on that side, so the legs can lean as a parallelogram (the body's
        only way sideways with both feet flat and no ankle roll)."""
        plant, context = self._plant, self._context
        held, lifting = {}, {}
        both = sum(bool(planted.get(name)) for name in self._soles) > 1
        for name, sole in self._soles.items():
            if not planted.get(name):
                continue
            held[name] = np.ones(len(sole.corners), bool)
            if name in (pushing or {}):
                held[name], lifting[name] = pushing[name], ~pushing[name]
                continue
            if not self._rolls_on_edges[name]:
                continue
            rotation = plant.EvalBodyPoseInWorld(context, sole.body).rotation().matrix()
            across = self._across[name]
            tilt = rotation[2, 1]  # the sole's left side up (+) or down (-)
            if abs(tilt) > np.sin(ROLLED):
                held[name] = across * tilt < 0.0  # the lower edge
            elif both and abs(self._sideways_demand @ rotation[:2, 1]) > LEANING:
                held[name] = across * (self._sideways_demand @ rotation[:2, 1]) > 0.0
            lifting[name] = ~held[name]
        return held, lifting

    def tasks(self, time: float, planted: dict[str, bool] | None = None) -> list[Task]:
        """The tracking tasks at `time`, for the state set in the controller's
        context, with the soles `planted` (by default `planted(time)`), the
        reference, its accelerations and the CoM's rows as `act` sets them,
        and the footing as `act` last left it: on feet, the CoM and the swing
        feet (balance); the pelvis' and torso's orientation, the hands, the
        joints' posture."""
        gains, planted = self.gains, self.planted(time) if planted is None else planted
        tasks = self._balance_tasks(time, planted) if self._soles else []
        for body in self._bodies:
            jacobian, bias, target = self._body_rows(body, gains.body_stiffness, position=False)
            tasks.append(Task(jacobian, bias, target, self._body_weight))
        for hand in self._hands:
            jacobian, bias, target = self._body_rows(hand, gains.hand_stiffness, position=True, offset=self._shift)
            tasks.append(Task(jacobian[3:], bias[3:], target[3:], gains.hand_weight))
        plant, context, reference = self._plant, self._context, self._reference
        q, v = plant.GetPositions(context), plant.GetVelocities(context)
        q_reference, v_reference = plant.GetPositions(reference), plant.GetVelocities(reference)
        positions, velocities = self._q, self._actuated_v
        stiffness = gains.posture_stiffness
        posture = (
            self._reference_accelerations[velocities]
            + stiffness * (q_reference[positions] - q[positions])
            + _damping(stiffness) * (v_reference[velocities] - v[velocities])
        )
        weight = np.full(len(positions), gains.posture_weight)
        frame = self.plan.frame(time)
        for name, joints in self._leg_joints.items():
            if planted.get(name):
                if self._leg_past_limits[name][frame]:
                    weight[joints] *= PLANTED_LEG_POSTURE
            elif self._on_lines:
                weight[joints] *= SWING_LEG_POSTURE
        tasks.append(Task(self._joint_rows, np.zeros(len(positions)), posture, weight))
        return tasks

    def _balance_tasks(self, time: float, planted: dict[str, bool]) -> list[Task]:
        """The CoM along the ZMP plan (its LQR's horizontal acceleration, the
        clip's height), and each swing foot to its footstep, moved by the
        capture point's error (or, one the clip has down, onto the floor)."""
        plant, context, reference, gains = self._plant, self._context, self._reference, self.gains
        com = plant.CalcCenterOfMassPositionInWorld(context)
        com_velocity = plant.CalcCenterOfMassTranslationalVelocityInWorld(context)
        shift = self._shift
        com_reference, com_reference_velocity, com_reference_acceleration = self.plan.com_reference(time)
        com_reference = com_reference + shift
        stiffness = gains.com_height_stiffness
        height = (
            com_reference_acceleration[2]
            + stiffness * (com_reference[2] - com[2])
            + _damping(stiffness) * (com_reference_velocity[2] - com_velocity[2])
        )
        target = np.append(self.plan.com_acceleration_for(time, com - shift, com_velocity), height)
        self._sideways_demand = target[:2]
        tasks = [Task(*self._com_rows, target, gains.com_weight)]
        frequency = pendulum_frequency(com_reference[2])
        planned, planned_velocity = self.plan.planned_com(time)
        capture = (com[:2] - shift[:2] - planned) + (com_velocity[:2] - planned_velocity) / frequency
        offset = shift + gains.step_adjustment * np.append(capture, 0.0)
        landing = self.plan.planted(time)
        self.swing_goals = {}
        for name, sole in self._soles.items():
            if planted.get(name):
                continue
            catch = self._catch if self._catch is not None and self._catch.foot == name else None
            if catch is not None:  # a step of the controller's own: along its swing, flat as it lifted
                still = (catch.rotation, np.zeros(3), np.zeros(3))
                jacobian, bias, target = self._pose_rows(sole.body, gains.swing_stiffness, still, catch.target(time))
                swing_goal, weight = catch.goal, gains.swing_weight * CATCH_WEIGHT
            else:
                # Where the capture point will be as the foot lands (its error grows as exp(frequency t)),
                # looked ahead at most `STEP_LOOK_AHEAD`; taken in as the swing goes (none at liftoff, all at
                # touchdown): a foot yanked toward it as it lifts kicks the body it should catch.
                ahead = min(self.plan.until_landing(name, time), STEP_LOOK_AHEAD)
                growth = np.exp(frequency * ahead)
                goal = shift + self.plan.swing_progress(name, time) * growth * (offset - shift)
                stance = [other for other in self._soles if other != name and planted.get(other)]
                if len(stance) == 1 and self._line_soles[name]:
                    now = com[:2] + com_velocity[:2] / frequency  # the capture point itself, not its error
                    moved = self._beside_capture(name, stance[0], growth * (offset - shift), now, frequency, ahead)
                    goal = shift + self.plan.swing_progress(name, time) * moved
                if landing.get(name):  # the clip has it down: onto the floor, wherever the clip's sole is
                    lowest = plant.EvalBodyPoseInWorld(reference, sole.body).multiply(sole.corners.T)[2].min()
                    goal = goal - [0.0, 0.0, lowest + LANDING_DEPTH]
                jacobian, bias, target = self._body_rows(sole.body, gains.swing_stiffness, position=True, offset=goal)
                swing_goal = plant.EvalBodyPoseInWorld(reference, sole.body).translation() + goal
                weight = gains.swing_weight
            if self._roll_follows_leg[name]:  # its roll is the leg's: only its pitch and yaw asked
                across = plant.EvalBodyPoseInWorld(context, sole.body).rotation().matrix()[:, 1:].T
                jacobian, bias, target = (
                    np.vstack([across @ jacobian[:3], jacobian[3:]]),
                    np.concatenate([across @ bias[:3], bias[3:]]),
                    np.concatenate([across @ target[:3], target[3:]]),
                )
            self.swing_goals[name] = swing_goal
            tasks.append(Task(jacobian, bias, target, weight))
        return tasks

    def _beside_capture(
        self, name: str, stance: str, adjustment: np.ndarray, capture: np.ndarray, frequency: float, ahead: float
    ) -> np.ndarray:
        """Swing foot `name`'s `adjustment` (its offset from the clip's
        footstep) moved across so that it lands on its own side of the
        capture point `ahead` s from now (`footsteps.beside_capture`), the
        pressure at the anchor of the sole `stance` stands on: by
        `CAPTURE_BESIDE`."""
        plant = self._plant
        pose = plant.EvalBodyPoseInWorld(self._context, self._soles[stance].body)
        _, left = heading_axes(pose.rotation().matrix()[:2, 0])
        predicted = predicted_capture(capture, pose.multiply(self.plan.anchors[stance])[:2], frequency, ahead)
        footstep = plant.EvalBodyPoseInWorld(self._reference, self._soles[name].body).multiply(self.plan.anchors[name])
        landing = footstep[:2] + self._shift[:2] + adjustment[:2]
        moved = beside_capture(landing, predicted, left, side_of(name), CAPTURE_BESIDE)
        return adjustment + np.append(moved - landing, 0.0)

    def _body_rows(
        self, body, stiffness: float, position: bool, offset: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A body's orientation rows (and, with `position`, its origin's) toward the reference's
        (its origin moved by `offset`): Jacobian, Jdot v and the desired acceleration (PD on the pose error)."""
        plant, reference = self._plant, self._reference
        goal = plant.EvalBodyPoseInWorld(reference, body)
        goal_velocity = plant.EvalBodySpatialVelocityInWorld(reference, body)
        goal_acceleration = self._goal_accelerations[int(body.index())]
        translation = None
        if position:
            where = goal.translation() + (0.0 if offset is None else offset)
            translation = (where, goal_velocity.translational(), goal_acceleration.translational())
        rotation = (goal.rotation(), goal_velocity.rotational(), goal_acceleration.rotational())
        return self._pose_rows(body, stiffness, rotation, translation)

    def _pose_rows(
        self, body, stiffness: float, rotation: tuple, translation: tuple | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A body's orientation rows (and, given `translation`, its origin's)
        toward a goal: `rotation` (a `RotationMatrix`, the angular velocity
        and acceleration), `translation` (position, velocity, acceleration;
        world): Jacobian, Jdot v and the desired acceleration (PD on the pose
        error plus the goal's acceleration)."""
        plant, context = self._plant, self._context
        world, frame = plant.world_frame(), body.body_frame()
        kv = JacobianWrtVariable.kV
        jacobian = plant.CalcJacobianSpatialVelocity(context, kv, frame, np.zeros(3), world, world)
        bias = plant.CalcBiasSpatialAcceleration(context, kv, frame, np.zeros(3), world, world)
        pose = plant.EvalBodyPoseInWorld(context, body)
        velocity = plant.EvalBodySpatialVelocityInWorld(context, body)
        damping = _damping(stiffness)
        goal_rotation, goal_angular_velocity, goal_angular_acceleration = rotation
        turn = _rotation_vector(goal_rotation @ pose.rotation().inverse())
        angular = (
            goal_angular_acceleration + stiffness * turn + damping * (goal_angular_velocity - velocity.rotational())
        )
        if translation is None:
            return jacobian[:3], bias.rotational(), angular
        goal_position, goal_velocity, goal_acceleration = translation
        linear = (
            goal_acceleration
            + stiffness * (goal_position - pose.translation())
            + damping * (goal_velocity - velocity.translational())
        )
        return jacobian, bias.get_coeffs(), np.concatenate([angular, linear])  # coefficients: rotational first


def AddWholeBodyController(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    model,
    embodiment: Embodiment,
    clip: MotionClip,
    control_period: float,
    loop: bool = True,
    gains: TrackingGains | None = None,
    start_time: float = 0.0,
    plant_step: float | None = None,
) -> WholeBodyController:
    """Add a `WholeBodyController` named `whole_body_controller` tracking
    `clip` (from its time `start_time` at time 0; the plant stepping every
    `plant_step`), its state input wired to
    the robot `model` of `plant`; connect its `desired_state` to the
    plant's PD (`AddPdControl`)."""
    controller = WholeBodyController(embodiment, clip, control_period, loop, gains, start_time, plant_step)
    builder.AddNamedSystem("whole_body_controller", controller)
    builder.Connect(plant.get_state_output_port(model), controller.GetInputPort("state"))
    return controller
