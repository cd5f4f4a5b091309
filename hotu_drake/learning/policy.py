"""The low-level controller pi(a | s, z_1..P): an MLP over the observation
and one latent vector per functional part, with an observation normaliser."""

from dataclasses import dataclass, field

import torch
from torch import nn


@dataclass
class PolicyConfig:
    """Sizes of the policy network."""

    observation_size: int
    action_size: int
    latent_sizes: dict[str, int] = field(default_factory=dict)  # functional part -> latent dim
    hidden: tuple[int, ...] = (256, 128)


class Normalizer(nn.Module):
    """(x - mean) / std, with statistics kept as buffers (saved with the weights)."""

    def __init__(self, size: int):
        super().__init__()
        self.register_buffer("mean", torch.zeros(size))
        self.register_buffer("std", torch.ones(size))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.mean) / self.std.clamp_min(1e-6)


class PolicyNetwork(nn.Module):
    """Mean action (tanh-squashed into [-1, 1]) from observation and latents."""

    def __init__(self, config: PolicyConfig):
        super().__init__()
        self.config = config
        self.normalizer = Normalizer(config.observation_size)
        sizes = [config.observation_size + sum(config.latent_sizes.values()), *config.hidden]
        layers: list[nn.Module] = []
        for a, b in zip(sizes[:-1], sizes[1:]):
            layers += [nn.Linear(a, b), nn.ReLU()]
        layers.append(nn.Linear(sizes[-1], config.action_size))
        self.body = nn.Sequential(*layers)

    def forward(self, observation: torch.Tensor, latents: dict[str, torch.Tensor] | None = None) -> torch.Tensor:
        pieces = [self.normalizer(observation)]
        for part in self.config.latent_sizes:
            pieces.append(latents[part])
        return torch.tanh(self.body(torch.cat(pieces, dim=-1)))
