"""The whole-body controller's quadratic program: one per control step.

Variables: the generalized accelerations vdot (nv) and a force f_k (3) at
each corner k of each sole (its contact points). The program

    min  sum_i w_i |J_i vdot + Jdot_i v - a_i|^2 + w_c sum_planted |J_k vdot + Jdot_k v|^2
         + w_r |vdot|^2 + w_f |f|^2
    s.t. (M vdot + h - sum_k J_k' f_k)_floating = 0                 (the unactuated rows)
         -u_max <= (M vdot + h - sum_k J_k' f_k)_actuated <= u_max   (the torques, within limits)
         f_k in its friction pyramid, f_k = 0 on a foot in the air

with h = C(q, v) v - tau_g, is the operational-space / task-space
inverse-dynamics QP of DAIR Lab's OSC and of TSID (accelerations, forces
and torques, the torques eliminated through the actuated rows). It is one
Drake `MathematicalProgram` built once, its coefficients and bounds set at
each step and solved by OSQP warm-started from the last solution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.solvers import MathematicalProgram, OsqpSolver, SolverOptions

from hotu_drake.embodiment import Embodiment

CONTACT_WEIGHT = 1e3  # a planted corner's acceleration, against the tasks' (order 1-100): soft, as the
# torque limits are hard (with both hard, a clip that needs more torque than the robot has leaves no solution)
FRICTION = 0.8  # a little under the floor's (1.0): the pyramid is inside the cone
REGULARIZATION = 1e-4
FORCE_WEIGHT = 1e-6
SETTINGS = {"verbose": 0, "polishing": 1, "eps_abs": 1e-5, "eps_rel": 1e-5, "max_iter": 4000}


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


@dataclass
class Solution:
    accelerations: np.ndarray  # (nv,)
    forces: dict[str, np.ndarray]  # per sole, (K, 3) in the world
    torques: np.ndarray  # (na,) in actuator order
    success: bool


class WholeBodyQp:
    """The QP over one model of a (finalized, continuous or discrete) plant,
    for the soles given by name (`soles`), with the actuators' effort limits."""

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
        n = nv + 3 * self.corners
        program = self.program = MathematicalProgram()
        self.vdot = program.NewContinuousVariables(nv, "vdot")
        self.f = program.NewContinuousVariables(3 * self.corners, "f")
        x = np.r_[self.vdot, self.f]
        self._dynamics = program.AddLinearEqualityConstraint(
            np.zeros((len(self.floating), n)), np.zeros(len(self.floating)), x
        )
        limits = np.asarray(effort_limits, float)
        self._limits = limits
        self._torques = program.AddLinearConstraint(np.zeros((len(limits), n)), -limits, limits, x)
        pyramid = np.zeros((4 * self.corners, 3 * self.corners))
        for k in range(self.corners):  # |f_x|, |f_y| <= mu f_z
            for row, (axis, sign) in enumerate(((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0))):
                pyramid[4 * k + row, 3 * k + axis] = sign
                pyramid[4 * k + row, 3 * k + 2] = -friction
        program.AddLinearConstraint(pyramid, np.full(len(pyramid), -np.inf), np.zeros(len(pyramid)), self.f)
        self._bounds = program.AddBoundingBoxConstraint(np.zeros(len(self.f)), np.zeros(len(self.f)), self.f)
        self._cost = program.AddQuadraticCost(np.eye(n), np.zeros(n), x, True)
        self._solver = OsqpSolver()
        self._options = SolverOptions()
        # Polishing sharpens the contact forces' active set; with no soles there is none to sharpen (and OSQP
        # would say so on stdout at every step).
        for option, value in (SETTINGS | ({} if soles else {"polishing": 0})).items():
            self._options.SetOption(self._solver.solver_id(), option, value)
        self._guess = np.zeros(n)

    def reset(self) -> None:
        """Forget the warm start."""
        self._guess = np.zeros_like(self._guess)

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

    def solve(self, context, tasks: list[Task], planted: dict[str, bool]) -> Solution:
        """The accelerations, sole forces and torques that best meet `tasks`
        with the soles `planted` (by name) on the floor, at the plant state in `context`."""
        plant, nv = self.plant, self.nv
        mass = plant.CalcMassMatrix(context)
        h = plant.CalcBiasTerm(context) - plant.CalcGravityGeneralizedForces(context)
        jacobian, bias = self.contact_jacobians(context)
        # (M vdot + h - J' f): the generalized forces the actuators must supply, row by row.
        rows = np.hstack([mass, -jacobian.T])
        self._dynamics.evaluator().UpdateCoefficients(rows[self.floating], -h[self.floating])
        actuated = rows[self.actuated]
        self._torques.evaluator().UpdateCoefficients(
            actuated, -self._limits - h[self.actuated], self._limits - h[self.actuated]
        )
        down = np.array(
            [bool(planted.get(name)) for name, sole in self.soles.items() for _ in sole.corners], dtype=bool
        )
        upper = np.where(np.repeat(down, 3), np.inf, 0.0)
        lower = np.where(np.repeat(down, 3), -np.inf, 0.0)
        lower[2::3] = 0.0
        self._bounds.evaluator().set_bounds(lower, upper)
        n = nv + len(self.f)
        hessian, gradient = np.zeros((n, n)), np.zeros(n)
        hessian[:nv, :nv] += REGULARIZATION * np.eye(nv)
        hessian[nv:, nv:] += FORCE_WEIGHT * np.eye(len(self.f))
        contact_weight = np.repeat(np.where(down, CONTACT_WEIGHT, 0.0), 3)
        for task in [*tasks, Task(jacobian, bias, np.zeros(len(bias)), contact_weight)]:
            weight = np.broadcast_to(np.asarray(task.weight, float), (len(task.target),))
            weighted = task.jacobian * weight[:, None]
            hessian[:nv, :nv] += weighted.T @ task.jacobian
            gradient[:nv] += weighted.T @ (task.bias - task.target)
        self._cost.evaluator().UpdateCoefficients(2.0 * hessian, 2.0 * gradient, 0.0, True)
        result = self._solver.Solve(self.program, self._guess, self._options)
        x = result.get_x_val() if result.is_success() else self._guess
        if result.is_success():
            self._guess = x
        vdot, f = x[:nv], x[nv:]
        torques = actuated @ x + h[self.actuated]
        forces, start = {}, 0
        for name, sole in self.soles.items():
            count = len(sole.corners)
            forces[name] = f[3 * start : 3 * (start + count)].reshape(count, 3)
            start += count
        return Solution(vdot, forces, np.clip(torques, -self._limits, self._limits), result.is_success())
