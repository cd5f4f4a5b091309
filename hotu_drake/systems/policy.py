"""PolicySystem: runs a policy checkpoint at the control rate.

Input ports `observation` and one `latent_<part>` per functional part the
policy was trained with; output port `action`, updated every control
period (30 Hz by default) and held in between (zero-order hold).
"""

from pathlib import Path

import numpy as np
import torch
from pydrake.systems.framework import BasicVector, LeafSystem

from hotu_drake.learning.checkpoint import load_checkpoint
from hotu_drake.learning.policy import PolicyNetwork

CONTROL_RATE = 30.0  # Hz


class PolicySystem(LeafSystem):
    def __init__(self, network: PolicyNetwork, control_rate: float = CONTROL_RATE):
        super().__init__()
        self._network = network.eval()
        config = network.config
        self.DeclareVectorInputPort("observation", config.observation_size)
        self._latent_ports = {
            part: self.DeclareVectorInputPort(f"latent_{part}", size) for part, size in config.latent_sizes.items()
        }
        self._action = self.DeclareDiscreteState(config.action_size)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / control_rate, 0.0, self._Act)
        self.DeclareVectorOutputPort("action", config.action_size, self._CalcAction)

    @staticmethod
    def from_checkpoint(path: str | Path, control_rate: float = CONTROL_RATE) -> "PolicySystem":
        network, _ = load_checkpoint(path)
        return PolicySystem(network, control_rate)

    def _Act(self, context, discrete_state) -> None:
        observation = torch.as_tensor(self.get_input_port(0).Eval(context), dtype=torch.float32)
        latents = {
            part: torch.as_tensor(port.Eval(context), dtype=torch.float32) for part, port in self._latent_ports.items()
        }
        with torch.no_grad():
            action = self._network(observation, latents).numpy().astype(np.float64)
        discrete_state.set_value(self._action, action)

    def _CalcAction(self, context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._action).get_value())
