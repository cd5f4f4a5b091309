"""PlanarBaseCommand: turns a body-frame velocity command into desired states.

For a robot on a holonomic planar base (CURI), the plant's built-in PD
tracks a desired state. This system integrates the commanded base twist
(vx, vy in the base frame, yaw rate) into a desired base pose and outputs
the full desired state: base pose and velocity, and the other actuated
joints held at fixed targets.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem

from hotu_drake.embodiment import Embodiment


class PlanarBaseCommand(LeafSystem):
    """A base twist integrated into the built-in PD's desired state.

    .. pydrake_system::

        name: PlanarBaseCommand
        input_ports:
        - twist
        output_ports:
        - desired_state

    `twist` is (vx, vy, yaw_rate), the linear part in the base frame;
    `desired_state` is [q*; v*] for every actuated joint.

    Args:
        joint_targets: desired positions of all actuated joints, with the
            base's x, y, yaw at `base_indices` (their initial values).
        base_indices: indices of the x, y and yaw joints in `joint_targets`.
        period: integration step of the desired base pose (s).
    """

    def __init__(self, joint_targets: np.ndarray, base_indices: tuple[int, int, int], period: float = 0.005):
        super().__init__()
        self._targets = np.asarray(joint_targets, dtype=float).copy()
        self._base = list(base_indices)
        self._period = period
        n = len(self._targets)
        self._twist = self.DeclareVectorInputPort("twist", 3)
        self._pose = self.DeclareDiscreteState(self._targets[self._base])
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._Integrate)
        self.DeclareVectorOutputPort("desired_state", 2 * n, self._CalcDesiredState)

    def _world_velocity(self, context: Context, pose: np.ndarray) -> np.ndarray:
        vx, vy, wz = self._twist.Eval(context)
        c, s = np.cos(pose[2]), np.sin(pose[2])
        return np.array([c * vx - s * vy, s * vx + c * vy, wz])

    def _Integrate(self, context: Context, discrete_state) -> None:
        pose = context.get_discrete_state(self._pose).get_value()
        discrete_state.set_value(self._pose, pose + self._period * self._world_velocity(context, pose))

    def _CalcDesiredState(self, context: Context, output: BasicVector) -> None:
        pose = context.get_discrete_state(self._pose).get_value()
        q = self._targets.copy()
        v = np.zeros_like(q)
        q[self._base] = pose
        v[self._base] = self._world_velocity(context, pose)
        output.SetFromVector(np.concatenate([q, v]))


def AddPlanarBaseCommand(builder: DiagramBuilder, embodiment: Embodiment, period: float) -> PlanarBaseCommand:
    """Add a `PlanarBaseCommand` named `base_command` for a planar-base
    embodiment, its other joints held at the standing pose."""
    base = tuple(embodiment.joint_names.index(j) for j in embodiment.base_joints)
    if len(base) != 3:
        raise ValueError(f"{embodiment.name} has no planar base to command")
    command = PlanarBaseCommand(embodiment.standing_pose, base, period)
    return builder.AddNamedSystem("base_command", command)
