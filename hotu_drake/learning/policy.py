"""The low-level controller pi(a | s, z_1..P): an MLP over the normalised
observation and one latent per part group.

Its mean action is the standing pose's action plus `residual_scale` times
the network's output (`mean`): an untrained network already holds the
robot up, and exploration is measured from there. `forward` is the action
a deployed policy sends (the mean, clipped to [-1, 1]); training adds
Gaussian noise to `mean` (`models.ActorCritic`).
"""

from dataclasses import dataclass, field

import torch
from torch import nn

from hotu_drake.learning.normalizer import Normalizer


@dataclass
class PolicyConfig:
    """Sizes of the policy network and its action offset and scale."""

    observation_size: int
    action_size: int
    latent_sizes: dict[str, int] = field(default_factory=dict)  # part group -> latent dim
    hidden: tuple[int, ...] = (256, 128)
    action_offset: tuple[float, ...] = ()  # the standing pose's action; () for zeros
    residual_scale: float = 1.0


def mlp(sizes: list[int], activation: type[nn.Module] = nn.ReLU) -> nn.Sequential:
    """Linear layers of `sizes` with `activation` between them (none after the last)."""
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            layers.append(activation())
    return nn.Sequential(*layers)


class PolicyNetwork(nn.Module):
    """Mean action from observation and latents (see the module docstring)."""

    def __init__(self, config: PolicyConfig):
        super().__init__()
        self.config = config
        self.normalizer = Normalizer(config.observation_size)
        inputs = config.observation_size + sum(config.latent_sizes.values())
        self.body = mlp([inputs, *config.hidden, config.action_size])
        offset = torch.as_tensor(config.action_offset or [0.0] * config.action_size, dtype=torch.float32)
        if offset.numel() != config.action_size:
            raise ValueError(f"action_offset has {offset.numel()} values for {config.action_size} actions")
        self.register_buffer("action_offset", offset)
        with torch.no_grad():  # start at the offset: small last-layer weights, no bias
            self.body[-1].weight.mul_(0.01)
            self.body[-1].bias.zero_()

    def features(self, observation: torch.Tensor, latents: dict[str, torch.Tensor] | None = None) -> torch.Tensor:
        pieces = [self.normalizer(observation)]
        for part in self.config.latent_sizes:
            pieces.append(latents[part])
        return torch.cat(pieces, dim=-1)

    def mean(self, observation: torch.Tensor, latents: dict[str, torch.Tensor] | None = None) -> torch.Tensor:
        """The Gaussian policy's mean (not clipped)."""
        residual = self.body(self.features(observation, latents))
        return self.action_offset + self.config.residual_scale * residual

    def forward(self, observation: torch.Tensor, latents: dict[str, torch.Tensor] | None = None) -> torch.Tensor:
        return self.mean(observation, latents).clamp(-1.0, 1.0)
