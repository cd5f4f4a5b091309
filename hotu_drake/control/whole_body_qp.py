"""The whole-body controller's quadratic program: one per control step.

Variables: the generalized accelerations vdot (nv) and a force f_k (3) at
each corner k of each sole (its contact points). The program

    min  sum_i w_i |J_i vdot + Jdot_i v - a_i|^2 + w_c sum_planted |J_k vdot + Jdot_k v|^2
         + w_r |vdot|^2 + w_f |f|^2
    s.t. (M vdot + h - sum_k J_k' f_k)_floating = 0                 (the unactuated rows)
         -u_max <= (M vdot + h - sum_k J_k' f_k)_actuated <= u_max   (the torques, within limits)
         f_k in its friction pyramid, f_k = 0 on a foot in the air
         J_k,z vdot + Jdot_k,z v >= -kp z_k - kd zdot_k  (a corner free to lift: not into the floor)

with h = C(q, v) v - tau_g, is the operational-space / task-space
inverse-dynamics QP of DAIR Lab's OSC and of TSID (accelerations, forces
and torques, the torques eliminated through the actuated rows). A planted
sole is held at all its corners, or at some (a sole that rolls on an edge,
a foot pushing off on its toes), its others free to lift but not to sink. Its
sparsity never changes, so it is set up once in OSQP (the design card's
`osqp`, the solver inside Drake's `OsqpSolver`) and each step only updates
its values and solves, warm-started from the last solution: Drake's
`OsqpSolver` sets OSQP up anew on every call, three times the cost here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sparse
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, JointIndex, ModelInstanceIndex

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.spec import SIDES
from hotu_drake.plant import GROUND_FRICTION, actuated_state_indices, set_robot_state

CONTACT_WEIGHT = 1e3  # a planted corner's acceleration, against the tasks' (order 1-100): soft, as the
# torque limits are hard (with both hard, a clip that needs more torque than the robot has leaves no solution)
# As soft as the CoM's task, it lets the QP move a held corner where the floor would not: H1 leaning sideways
# on flat soles was planned with one held edge sinking at 0.4 m/s^2 and the other lifting, the CoM predicted
# at 1.04 m/s^2 sideways and getting 0.22. At 1e5 the predictions hold, but H1 stood in 49 of its 64 library
# starts (60 at 1e3): the tasks' weights are tuned around this softness (BENCHMARKS.md, fourteenth session).
# The friction cone the QP plans within: the floor's. Each corner's pyramid is the octagon inscribed in it
# (`WholeBodyQp`). The square |f_x|, |f_y| <= 0.8 f_z it replaces had corners 1.13 f_z out, past the floor's
# 1.0: H1's planted foot took its turning walk's forward push on a corner pushed sideways past what the floor
# holds, and turned 7-18 degrees on the floor. Tried and left out: the square inscribed in the cone (side
# 0.707; H1's looped walk fell from 2 of 20 seeds), or in a cone under the floor's (0.9; side 0.636).
FRICTION = GROUND_FRICTION
REGULARIZATION = 1e-4
# 1/s: a planted corner's desired acceleration is this times its velocity, against it (zero at rest): a
# sole that has started to slide or turn is stopped, not only kept from accelerating. At 20 (none before):
# the UDH's walk_backward and Walker's leg_stretch stand (their planted foot had turned 0.8 rad about the
# vertical), BRUCE falls in turn_in_place_right, H1 walks the looped walk from 1 of 6 starts (4 of 6).
SLIP_DAMPING = 20.0
FORCE_WEIGHT = 1e-6
# OSQP's tolerances: with its workspace (and so its duals) kept from step to step, 1e-3 and polishing walk
# as 1e-5 did (BENCHMARKS.md) in a quarter of the iterations.
SETTINGS = {"verbose": False, "polishing": True, "eps_abs": 1e-3, "eps_rel": 1e-3, "max_iter": 4000}
INFINITY = 1e30  # OSQP's
# 1/s^2 and 1/s: a corner free to lift is kept from sinking by asking its height's acceleration to be at
# least -(LIFT_STIFFNESS z + LIFT_DAMPING zdot): one at the floor stays at or above it.
LIFT_STIFFNESS, LIFT_DAMPING = 400.0, 40.0
ROLL_AXIS = 0.7  # a joint whose axis is this near a foot's length (cosine) turns the foot about it
MIN_SOLE_WIDTH = 0.01  # m: a sole narrower than this across is a line of contacts, free to roll already
SOLVED = (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)


@dataclass
class Task:
    """A desired acceleration of some coordinates: J vdot + bias -> target, weighted."""

    jacobian: np.ndarray  # (m, nv)
    bias: np.ndarray  # (m,): Jdot v
    target: np.ndarray  # (m,)
    weight: float | np.ndarray  # scalar, or one per row


@dataclass
class Sole:
    """A foot's contact corners: its body and the points (K, 3) in the body's frame."""

    body: object  # a pydrake RigidBody
    corners: np.ndarray

    @property
    def is_line(self) -> bool:
        """Whether the sole is a line of contacts along its length (narrower than `MIN_SOLE_WIDTH` across)."""
        return bool(np.ptp(self.corners[:, 1]) <= MIN_SOLE_WIDTH)


def feet_soles(plant: MultibodyPlant, embodiment: Embodiment) -> dict[str, Sole]:
    """The soles of the robot's feet in `plant`, by contact name (`left_foot`, `right_foot`; none on a base)."""
    soles = {}
    for side in SIDES:
        link = embodiment.key_bodies.get(f"{side}_foot")
        if link is not None:
            soles[f"{side}_foot"] = Sole(plant.GetBodyByName(link), sole_corners(embodiment, link))
    return soles


def soles_rolling_with_legs(
    plant: MultibodyPlant, model: ModelInstanceIndex, embodiment: Embodiment, soles: dict[str, Sole]
) -> dict[str, bool]:
    """Per sole, whether its foot turns about its length (its body's x
    axis, along which every embodiment's sole is longest) only as its leg
    leans: fewer than two of the robot's joints turn it about that axis (a
    hip roll and no ankle roll: H1, BRUCE), read from the foot's rotational
    Jacobian with the robot standing (`plant` holds it as `model`)."""
    scratch = plant.CreateDefaultContext()
    set_robot_state(plant, scratch, model, embodiment)
    _, velocities = actuated_state_indices(plant, model, embodiment.joint_names)
    joints, world, out = velocities - plant.num_positions(), plant.world_frame(), {}
    for name, sole in soles.items():
        axes = plant.CalcJacobianAngularVelocity(scratch, JacobianWrtVariable.kV, sole.body.body_frame(), world, world)
        along = plant.EvalBodyPoseInWorld(scratch, sole.body).rotation().matrix()[:, 0]
        out[name] = int((np.abs(along @ axes[:, joints]) > ROLL_AXIS).sum()) < 2
    return out


def soles_on_edges(rolling: dict[str, bool], soles: dict[str, Sole]) -> dict[str, bool]:
    """Per sole, whether it stands on an edge as its leg leans: one whose
    roll is its leg's (`rolling`, `soles_rolling_with_legs`) with width
    across (a line of contacts turns about its line already). H1's: with
    both flat, its legs cannot lean."""
    return {name: rolling[name] and not sole.is_line for name, sole in soles.items()}


def sole_corners(embodiment: Embodiment, link: str) -> np.ndarray:
    """The lowest points (K, 3) of a foot link's collision shapes, in the link's
    frame: a sphere's bottom, a box's bottom corners, a capsule's ends' bottoms."""
    points = []
    for shape in embodiment.spec.link(link).collisions:
        centre, rotation = np.asarray(shape.position, float), shape.rotation()
        if shape.shape == "box":
            half = np.asarray(shape.size, float) / 2.0
            corners = np.array(np.meshgrid(*[[-h, h] for h in half])).reshape(3, -1).T
            points += [centre + rotation @ corner for corner in corners]
        elif shape.shape == "sphere":
            points.append(centre - [0.0, 0.0, shape.size[0]])
        else:
            half = rotation @ np.array([0.0, 0.0, shape.size[1] / 2.0])
            points += [centre + half - [0.0, 0.0, shape.size[0]], centre - half - [0.0, 0.0, shape.size[0]]]
    points = np.array(points)
    return points[points[:, 2] < points[:, 2].min() + 0.01]


def _tree_structure(plant: MultibodyPlant, soles: dict[str, Sole]) -> tuple[np.ndarray, np.ndarray]:
    """Where the mass matrix (nv, nv) and the soles' corners' Jacobians (C,
    nv, a row per corner) can be nonzero, from the kinematic tree: two
    velocities share an entry of M when their joints move a body in common
    (one lies on the other's path to the world), and a corner's Jacobian
    has a column for each velocity whose joint moves its foot."""
    moved = [set() for _ in range(plant.num_velocities())]  # per velocity, the bodies its joint moves
    for index in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(index))
        if joint.num_velocities() == 0:
            continue
        bodies = {int(body) for body in plant.GetBodiesKinematicallyAffectedBy([joint.index()])}
        for velocity in range(joint.velocity_start(), joint.velocity_start() + joint.num_velocities()):
            moved[velocity] = bodies
    mass = np.array([[bool(mine & theirs) for theirs in moved] for mine in moved])
    feet = [int(sole.body.index()) for sole in soles.values() for _ in sole.corners]
    return mass, np.array([[foot in bodies for bodies in moved] for foot in feet], bool).reshape(-1, len(moved))


@dataclass
class Solution:
    accelerations: np.ndarray  # (nv,)
    forces: dict[str, np.ndarray]  # per sole, (K, 3) in the world
    torques: np.ndarray  # (na,) in actuator order
    success: bool


class WholeBodyQp:
    """The QP over one model of a (finalized, continuous or discrete) plant,
    for the soles given by name (`soles`), with the actuators' effort limits;
    any sole's corners may be left free to lift (a row each, kept from
    sinking: `solve`'s `lifting`)."""

    def __init__(
        self,
        plant: MultibodyPlant,
        soles: dict[str, Sole],
        effort_limits: np.ndarray,
        friction: float = FRICTION,
    ):
        self.plant, self.soles = plant, soles
        self.nv = nv = plant.num_velocities()
        actuation = plant.MakeActuationMatrix()  # (nv, na): each actuator drives one velocity
        self.actuated = np.argmax(np.abs(actuation), axis=0)
        self.floating = np.flatnonzero(~np.abs(actuation).any(axis=1))
        self.corners = sum(len(sole.corners) for sole in soles.values())
        forces = 3 * self.corners
        self.n = n = nv + forces
        self._limits = np.asarray(effort_limits, float)
        # Rows of the constraint matrix: the floating base's dynamics, the actuated rows (torque limits), each
        # corner's height (kept from sinking when it may lift), the friction pyramids, the forces' bounds (zero
        # off the floor, f_z >= 0 on it).
        self._rows = len(self.floating) + len(self._limits) + self.corners
        # Each corner's pyramid: the octagon inscribed in its cone ||f_xy|| <= friction f_z (faces 45 degrees
        # apart, each at friction cos(22.5) from the axis).
        faces = [np.round([np.cos(a), np.sin(a)], 12) for a in np.arange(8) * np.pi / 4]
        reach = friction * np.cos(np.pi / 8)
        pyramid = np.zeros((len(faces) * self.corners, n))
        for k in range(self.corners):  # normal . f_xy <= reach f_z
            for row, normal in enumerate(faces):
                pyramid[len(faces) * k + row, nv + 3 * k : nv + 3 * k + 2] = normal
                pyramid[len(faces) * k + row, nv + 3 * k + 2] = -reach
        # The constraint matrix as a numpy array: its first `_rows` rows set at each step, the rest fixed. OSQP
        # holds only the entries that can be nonzero, the kinematic tree's: a row of M has none between two joints
        # on different branches, a corner's Jacobian none for a joint that does not move its foot. With those rows
        # whole (H1's: twice the entries), the control step took 15% longer (BENCHMARKS.md, twenty-first session).
        self._constraints = np.vstack([np.zeros((self._rows, n)), pyramid, np.eye(n)[nv:]])
        self._lifting = slice(self._rows - self.corners, self._rows)  # the corners' height rows (vdot only)
        self._dynamics_rows = np.r_[self.floating, self.actuated]  # the dynamics' rows, floating then actuated
        mass_pattern, corner_columns = _tree_structure(plant, soles)
        dynamics = np.hstack([mass_pattern, np.repeat(corner_columns, 3, axis=0).T])  # where [M, -J'] can be nonzero
        mask = self._constraints != 0.0
        mask[: self._lifting.start] = dynamics[self._dynamics_rows]
        mask[self._lifting, :nv] = corner_columns
        self._a_pattern = _Pattern(mask)
        # The cost's Hessian: the accelerations' block dense (the CoM's Jacobian spans every joint), the forces'
        # a constant diagonal. Its upper triangle in CSC order: the block's (`_p_pattern`), then that diagonal.
        hessian = np.eye(n)
        hessian[:nv, :nv] = 1.0
        self._p_pattern = _Pattern(np.triu(np.ones((nv, nv), bool)))
        self._regularization, self._force_hessian = REGULARIZATION * np.eye(nv), np.full(forces, FORCE_WEIGHT)
        self._lower = np.r_[np.zeros(self._rows), np.full(len(pyramid), -INFINITY), np.zeros(forces)]
        self._upper = np.r_[np.zeros(self._rows), np.zeros(len(pyramid)), np.zeros(forces)]
        self._lower[self._lifting], self._upper[self._lifting] = -INFINITY, INFINITY  # active only when lifting
        # Polishing sharpens the contact forces' active set; with no soles there is none to sharpen (and OSQP
        # would say so on stdout at every step).
        settings = SETTINGS | ({} if soles else {"polishing": False})
        constraints = self._constraints.copy()  # the rows set at each step at 1 where they can be nonzero
        constraints[: self._rows][mask[: self._rows]] = 1.0
        self._solver = _Workspace(
            _Pattern(np.triu(hessian) != 0.0).matrix(np.eye(n)),
            self._a_pattern.matrix(constraints),
            self._lower,
            self._upper,
            settings,
        )
        self._guess = np.zeros(n)
        # Each sole's corners among all the soles' (C in all): per-sole flags spread over them (`_by_corner`).
        ends = np.cumsum([0] + [len(sole.corners) for sole in soles.values()])
        self._corner_slices = {name: slice(start, stop) for name, start, stop in zip(soles, ends[:-1], ends[1:])}

    def reset(self) -> None:
        """Forget the warm start."""
        self._guess = np.zeros_like(self._guess)
        self._solver.warm_start(x=self._guess, y=np.zeros(len(self._lower)))

    def contact_jacobians(self, context) -> tuple[np.ndarray, np.ndarray]:
        """The soles' corners: their translational Jacobians (3C, nv) and Jdot v (3C,), in the world."""
        plant, world = self.plant, self.plant.world_frame()
        jacobians, biases = [], []
        for sole in self.soles.values():
            frame = sole.body.body_frame()
            points = sole.corners.T
            jacobians.append(
                plant.CalcJacobianTranslationalVelocity(context, JacobianWrtVariable.kV, frame, points, world, world)
            )
            bias = plant.CalcBiasTranslationalAcceleration(context, JacobianWrtVariable.kV, frame, points, world, world)
            biases.append(np.asarray(bias).T.reshape(-1))
        if not jacobians:  # a robot on a base, not on feet
            return np.zeros((0, self.nv)), np.zeros(0)
        return np.vstack(jacobians), np.concatenate(biases)

    def _by_corner(self, flags: dict) -> np.ndarray:
        """Per corner (C,) from per sole flags (by name: a bool, or one per corner)."""
        out = np.zeros(self.corners, bool)
        for name, corners in self._corner_slices.items():
            out[corners] = flags.get(name, False)
        return out

    def _heights(self, context) -> np.ndarray:
        """Each corner's height above the floor (C,)."""
        plant, world = self.plant, self.plant.world_frame()
        heights = [
            plant.CalcPointsPositions(context, sole.body.body_frame(), sole.corners.T, world)[2]
            for sole in self.soles.values()
        ]
        return np.concatenate([np.zeros(0), *heights])

    def solve(
        self,
        context,
        tasks: list[Task],
        planted: dict,
        lifting: dict | None = None,
        dynamics: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> Solution:
        """The accelerations, sole forces and torques that best meet `tasks`
        with the soles `planted` (by name: True, or which corners, (K,) bools)
        held on the floor, and the corners `lifting` (by name, (K,) bools)
        free to lift but not to sink, at the plant state in `context`
        (`dynamics`: its mass matrix and C(q, v) v, if the caller has them)."""
        plant, nv, floating, dynamic_rows = self.plant, self.nv, len(self.floating), self._lifting.start
        if dynamics is None:
            dynamics = plant.CalcMassMatrix(context), plant.CalcBiasTerm(context)
        mass, coriolis = dynamics
        h = coriolis - plant.CalcGravityGeneralizedForces(context)
        jacobian, bias = self.contact_jacobians(context)
        velocity = jacobian @ plant.GetVelocities(context)  # each corner's (3C,)
        # (M vdot + h - J' f): the generalized forces the actuators must supply, the floating rows, then the actuated.
        constraints = self._constraints
        constraints[:dynamic_rows, :nv], constraints[:dynamic_rows, nv:] = (
            mass[self._dynamics_rows],
            -jacobian.T[self._dynamics_rows],
        )
        constraints[self._lifting, :nv] = jacobian[2::3]
        down = self._by_corner(planted)
        limits, bounds = self._limits, len(self._lower) - 3 * self.corners
        lower, upper = self._lower.copy(), self._upper.copy()
        lower[:floating] = upper[:floating] = -h[self.floating]
        lower[floating:dynamic_rows] = -limits - h[self.actuated]
        upper[floating:dynamic_rows] = limits - h[self.actuated]
        if lifting:  # J_z vdot >= -(kp z + kd zdot) - Jdot_z v
            least = -(LIFT_STIFFNESS * self._heights(context) + LIFT_DAMPING * velocity[2::3]) - bias[2::3]
            lower[self._lifting] = np.where(self._by_corner(lifting), least, -INFINITY)
        on = np.repeat(down, 3)  # a planted corner's force is free but for f_z >= 0; one in the air is zero
        lower[bounds:], upper[bounds:] = np.where(on, -INFINITY, 0.0), np.where(on, INFINITY, 0.0)
        lower[bounds + 2 :: 3] = 0.0
        # The tasks' rows stacked, a planted corner's last (its acceleration against its velocity: a sole that
        # slides is braked): sum_i w_i |J_i vdot + b_i - a_i|^2 as one product.
        tasks = [
            *tasks,
            Task(jacobian, bias, -SLIP_DAMPING * velocity, np.repeat(np.where(down, CONTACT_WEIGHT, 0.0), 3)),
        ]
        stacked = np.vstack([task.jacobian for task in tasks])
        weighted = stacked.T * np.concatenate([np.full(task.target.shape, task.weight) for task in tasks])
        hessian = weighted @ stacked + self._regularization
        gradient = np.zeros(self.n)
        gradient[:nv] = weighted @ np.concatenate([task.bias - task.target for task in tasks])
        solver = self._solver
        hessian_values = np.concatenate([self._p_pattern.values(hessian), self._force_hessian])
        solver.update(hessian_values, self._a_pattern.values(constraints), gradient, lower, upper)
        x = solver.solve()
        success = x is not None
        if success:
            self._guess = x
        else:  # the next step starts from the last solution, not from the failed iterate
            x = self._guess
            solver.warm_start(x=self._guess)
        vdot, f = x[:nv], x[nv:]
        torques = constraints[floating:dynamic_rows] @ x + h[self.actuated]
        forces, start = {}, 0
        for name, sole in self.soles.items():
            count = len(sole.corners)
            forces[name] = f[3 * start : 3 * (start + count)].reshape(count, 3)
            start += count
        return Solution(vdot, forces, np.clip(torques, -self._limits, self._limits), success)


class _Workspace:
    """One OSQP workspace, set up once and then only updated and solved.

    Through the solver object inside OSQP's Python interface (osqp 1.x):
    the interface's `update` and `solve` add to every call bookkeeping this
    loop does not use (a cache for its derivatives, a copy of every field of
    its info)."""

    def __init__(self, hessian: sparse.csc_matrix, constraints: sparse.csc_matrix, lower, upper, settings: dict):
        self._osqp = osqp.OSQP()
        self._osqp.setup(hessian, np.zeros(hessian.shape[0]), constraints, lower, upper, **settings)
        self._solver = self._osqp._solver

    def update(self, hessian: np.ndarray, constraints: np.ndarray, gradient, lower, upper) -> None:
        """New values of the upper triangle's and the constraints' nonzeros (CSC order), the gradient and bounds."""
        self._solver.update_data_vec(q=gradient, l=np.maximum(lower, -INFINITY), u=np.minimum(upper, INFINITY))
        self._solver.update_data_mat(P_x=hessian, P_i=None, A_x=constraints, A_i=None)

    def solve(self) -> np.ndarray | None:
        """The primal solution, warm-started from the last; None if OSQP did not solve it."""
        self._solver.solve()
        return self._solver.solution.x if self._solver.info.status_val in SOLVED else None

    def warm_start(self, x: np.ndarray | None = None, y: np.ndarray | None = None) -> None:
        self._osqp.warm_start(x=x, y=y)


class _Pattern:
    """A fixed sparsity pattern: the CSC matrix of a dense array's entries
    there, and those entries in CSC order (OSQP's `update(Px=..., Ax=...)`)."""

    def __init__(self, mask: np.ndarray):
        self.shape = mask.shape
        columns, rows = np.nonzero(mask.T)  # column by column, rows ascending: CSC order
        self.rows, self.columns = rows, columns
        self.pointers = np.r_[0, np.cumsum(np.bincount(columns, minlength=mask.shape[1]))]

    def values(self, dense: np.ndarray) -> np.ndarray:
        return dense[self.rows, self.columns]

    def matrix(self, dense: np.ndarray) -> sparse.csc_matrix:
        return sparse.csc_matrix((self.values(dense), self.rows, self.pointers), shape=self.shape)
