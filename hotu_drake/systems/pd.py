"""PD control with torque saturation, and the map from policy actions to PD targets.

The controller applies tau = clip(Kp (q* - q) - Kd v, -e, e) with the
embodiment's gains and effort limits e, which is how the method simulates
torque limits. The plant's built-in PD (implicit in SAP, with the same
effort limits) is the alternative for larger time steps; `AddPdControl`
wires whichever a scenario asks for. Actions are normalised PD targets
(`embodiment.actions.ActionScaling`); `AddActionToTargets` applies that
map inside the diagram as a static gain (a C++ system: no Python per step).
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.primitives import AffineSystem

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.actions import ActionScaling
from hotu_drake.plant import actuated_state_indices


class SaturatedPdController(LeafSystem):
    """tau = clip(Kp (q* - q) - Kd v, -effort, effort) per actuated joint.

    .. pydrake_system::

        name: SaturatedPdController
        input_ports:
        - state
        - targets
        output_ports:
        - torques

    `state` is the model's [q; v]; `targets` one position per actuated
    joint; `torques` goes to the plant's actuation input.
    """

    def __init__(self, plant: MultibodyPlant, model: ModelInstanceIndex, embodiment: Embodiment):
        super().__init__()
        self._q, self._v = actuated_state_indices(plant, model, embodiment.joint_names)
        self._kp, self._kd = embodiment.kp, embodiment.kd
        self._limit = embodiment.effort_limits
        n = len(embodiment.joint_names)
        self._state = self.DeclareVectorInputPort("state", plant.num_multibody_states(model))
        self._targets = self.DeclareVectorInputPort("targets", n)
        self.DeclareVectorOutputPort("torques", n, self._CalcTorques)

    def _CalcTorques(self, context: Context, output: BasicVector) -> None:
        state = self._state.Eval(context)
        targets = self._targets.Eval(context)
        torque = self._kp * (targets - state[self._q]) - self._kd * state[self._v]
        output.SetFromVector(np.clip(torque, -self._limit, self._limit))


def AddPdControl(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    model: ModelInstanceIndex,
    embodiment: Embodiment,
    targets: OutputPort,
    explicit: bool = False,
) -> SaturatedPdController | None:
    """Send PD `targets` to the robot: into the plant's built-in PD (its
    desired-state input, `targets` = [q*; v*]), or with `explicit=True`
    through a `SaturatedPdController` named `pd` (`targets` = q*), which is
    returned."""
    if not explicit:
        builder.Connect(targets, plant.get_desired_state_input_port(model))
        return None
    controller = builder.AddNamedSystem("pd", SaturatedPdController(plant, model, embodiment))
    builder.Connect(plant.get_state_output_port(model), controller.GetInputPort("state"))
    builder.Connect(targets, controller.GetInputPort("targets"))
    builder.Connect(controller.GetOutputPort("torques"), plant.get_actuation_input_port(model))
    return controller


def AddActionToTargets(builder: DiagramBuilder, embodiment: Embodiment, explicit: bool = False) -> AffineSystem:
    """Add `action_to_targets`: normalised actions in, PD targets out
    (q* = offset + scale a, and v* = 0 for the built-in PD's desired state)."""
    scaling = ActionScaling.for_embodiment(embodiment)
    n = scaling.scale.size
    rows = n if explicit else 2 * n
    gain, offset = np.zeros((rows, n)), np.zeros(rows)
    gain[:n], offset[:n] = np.diag(scaling.scale), scaling.offset
    system = AffineSystem(
        A=np.zeros((0, 0)), B=np.zeros((0, n)), f0=np.zeros(0), C=np.zeros((rows, 0)), D=gain, y0=offset
    )
    return builder.AddNamedSystem("action_to_targets", system)
