"""Partial inverse kinematics of one functional part, as a small QP.

Each part (a shoulder, a knee, a finger, ...) is a short open chain. Its
targets (directions between landmarks, body-frame orientations, points) are
linearised around the current configuration; the step dq minimises

    sum_k w_k |J_k dq - e_k|^2 + reg |dq|^2 + smooth |q + dq - q_prev|^2

within the joint limits and a trust region. The Drake `MathematicalProgram`
is built once per part; every frame only its cost coefficients and bounds
are updated before OSQP solves it.
"""

import numpy as np
from pydrake.solvers import MathematicalProgram, OsqpSolver, SolverOptions

TRUST_REGION = 0.6  # rad (or m) per iteration
# Parts are solved proximal first, by level: the torso; shoulders and hips;
# elbows, knees and the neck; wrists and ankles; the fingers. A part's
# targets depend on the levels before it, which the one linearisation of a
# level holds fixed: so the torso gets a level of its own.
FINGER_LEVEL = 4
# A hand whose finger directions (in its frame) change less keeps its shape: its finger part needs no new solve.
SHAPE_TOLERANCE = 1e-4


class PartProblem:
    """The QP of one part over its joints (indices into the embodiment's q)."""

    def __init__(
        self,
        name: str,
        joints: list[int],
        lower: np.ndarray,
        upper: np.ndarray,
        regularization: float = 1e-3,
        smoothness: float = 1e-2,
    ):
        self.name = name
        self.joints = list(joints)
        self.lower, self.upper = np.asarray(lower, float), np.asarray(upper, float)
        self.regularization, self.smoothness = regularization, smoothness
        k = len(self.joints)
        self.program = MathematicalProgram()
        self.dq = self.program.NewContinuousVariables(k, f"d{name}")
        self._cost = self.program.AddQuadraticCost(np.eye(k), np.zeros(k), self.dq, is_convex=True)
        self._bounds = self.program.AddBoundingBoxConstraint(-np.ones(k), np.ones(k), self.dq)
        self._solver = OsqpSolver()
        self._options = SolverOptions()
        for option, value in (("verbose", 0), ("polishing", 0), ("eps_abs", 1e-6), ("eps_rel", 1e-6)):
            self._options.SetOption(self._solver.solver_id(), option, value)

    def step(
        self, rows: list[tuple[np.ndarray, np.ndarray, float]], q: np.ndarray, q_previous: np.ndarray
    ) -> np.ndarray:
        """The joint step of this part; `rows` are (J (m x k), e (m,), weight)."""
        k = len(self.joints)
        hessian = np.eye(k) * (self.regularization + self.smoothness)
        gradient = -self.smoothness * (q_previous - q)
        for jacobian, error, weight in rows:
            hessian += weight * jacobian.T @ jacobian
            gradient -= weight * jacobian.T @ error
        self._cost.evaluator().UpdateCoefficients(2.0 * hessian, 2.0 * gradient)
        low = np.maximum(self.lower - q, -TRUST_REGION)
        high = np.minimum(self.upper - q, TRUST_REGION)
        self._bounds.evaluator().set_bounds(np.minimum(low, 0.0), np.maximum(high, 0.0))
        result = self._solver.Solve(self.program, None, self._options)
        if not result.is_success():
            return np.zeros(k)
        return result.GetSolution(self.dq)
