"""PolicySystem: runs a policy checkpoint at the control rate.

Input ports `observation` and one `latent_<part>` per functional part the
policy was trained with; output port `action`, updated every control
period (30 Hz by default) and held in between (zero-order hold).
"""

from pathlib import Path

import numpy as np
import torch
from pydrake.systems.framework import LeafSystem

from hotu_drake.embodiment import Embodiment
from hotu_drake.learning.checkpoint import load_checkpoint
from hotu_drake.learning.policy import PolicyConfig, PolicyNetwork
from hotu_drake.systems.observation import observation_size

CONTROL_RATE = 30.0  # Hz


LATENT_SIZE = 16  # per functional part


def policy_for(embodiment: Embodiment, latent_size: int = LATENT_SIZE, seed: int = 0) -> PolicyNetwork:
    """A freshly initialised policy shaped for `embodiment`: its observation,
    one action per joint, one latent per functional part. Its output layer
    starts small around the standing pose's action, so an untrained policy
    holds the robot roughly upright (training starts here)."""
    from hotu_drake.systems.pd import ActionScaling

    torch.manual_seed(seed)
    parts = {part: latent_size for part, joints in embodiment.parts.items() if joints}
    config = PolicyConfig(observation_size(embodiment), len(embodiment.joint_names), parts)
    network = PolicyNetwork(config)
    standing = ActionScaling.for_embodiment(embodiment).to_action(embodiment.standing_pose)
    output = network.body[-1]
    with torch.no_grad():
        output.weight.mul_(0.01)
        output.bias.copy_(torch.atanh(torch.as_tensor(np.clip(standing, -0.99, 0.99), dtype=torch.float32)))
    return network


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
        # Served from the discrete state by Drake itself: no Python call per plant step.
        self.DeclareStateOutputPort("action", self._action)

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
