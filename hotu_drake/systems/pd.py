"""SaturatedPdController and the mapping from policy actions to PD targets.

Actions are normalised PD targets: a = -1 and a = 1 are a joint's lower and
upper limits. The controller applies tau = clip(Kp (q* - q) - Kd v, -e, e)
with the embodiment's gains and effort limits e, which is how the method
simulates torque limits. The plant's built-in PD (implicit in SAP, with the
same effort limits) is the alternative for larger time steps.
"""

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, LeafSystem

from hotu_drake.embodiment import Embodiment

# Half-range used for joints without position limits (CURI's base yaw).
UNLIMITED_HALF_RANGE = np.pi


@dataclass(frozen=True)
class ActionScaling:
    """Per-joint affine map between actions in [-1, 1] and PD targets."""

    offset: np.ndarray
    scale: np.ndarray

    @staticmethod
    def for_embodiment(embodiment: Embodiment) -> "ActionScaling":
        lower, upper = embodiment.position_lower, embodiment.position_upper
        limited = np.isfinite(lower) & np.isfinite(upper)
        low, high = np.where(limited, lower, 0.0), np.where(limited, upper, 0.0)
        offset = 0.5 * (high + low)
        scale = np.where(limited, 0.5 * (high - low), UNLIMITED_HALF_RANGE)
        return ActionScaling(offset, scale)

    def to_targets(self, action: np.ndarray) -> np.ndarray:
        """PD targets for actions (clipped to [-1, 1])."""
        return self.offset + self.scale * np.clip(action, -1.0, 1.0)

    def to_action(self, targets: np.ndarray) -> np.ndarray:
        """The action that asks for `targets`."""
        return (np.asarray(targets) - self.offset) / self.scale


def actuated_state_indices(plant: MultibodyPlant, model, joint_names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Indices of each joint's position and velocity in the model's state vector."""
    positions, velocities = [], []
    for index in plant.GetJointIndices(model):
        joint = plant.get_joint(index)
        positions += range(joint.position_start(), joint.position_start() + joint.num_positions())
        velocities += range(joint.velocity_start(), joint.velocity_start() + joint.num_velocities())
    positions, velocities = sorted(positions), sorted(velocities)
    q_index = [positions.index(plant.GetJointByName(n, model).position_start()) for n in joint_names]
    v_index = [velocities.index(plant.GetJointByName(n, model).velocity_start()) for n in joint_names]
    return np.array(q_index), len(positions) + np.array(v_index)


class SaturatedPdController(LeafSystem):
    """Input ports `state` (the model's [q; v]) and `targets` (one per
    actuated joint); output port `torques` (actuation, saturated)."""

    def __init__(self, plant: MultibodyPlant, model, embodiment: Embodiment):
        super().__init__()
        self._q, self._v = actuated_state_indices(plant, model, embodiment.joint_names)
        self._kp, self._kd = embodiment.kp, embodiment.kd
        self._limit = embodiment.effort_limits
        n = len(embodiment.joint_names)
        self.DeclareVectorInputPort("state", plant.num_multibody_states(model))
        self.DeclareVectorInputPort("targets", n)
        self.DeclareVectorOutputPort("torques", n, self._CalcTorques)

    def _CalcTorques(self, context, output: BasicVector) -> None:
        state = self.get_input_port(0).Eval(context)
        targets = self.get_input_port(1).Eval(context)
        torque = self._kp * (targets - state[self._q]) - self._kd * state[self._v]
        output.SetFromVector(np.clip(torque, -self._limit, self._limit))
