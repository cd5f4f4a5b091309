"""The networks of a run: the deployed policy pi(a | s, z_1..P), the Gaussian
actor and critic around it, and one style network (discriminator and
encoder) per part group.

The policy is an MLP over the normalised observation and one latent per
part group. Its mean action is the standing pose's action plus
`residual_scale` times the network's output (`mean`): an untrained network
already holds the robot up, and exploration is measured from there.
`forward` is the action a deployed policy sends (the mean, clipped to
[-1, 1]); training adds Gaussian noise to `mean` (`ActorCritic`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch
from torch import nn
from torch.nn import functional as F

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
    activation: str = "relu"  # between the hidden layers: relu or elu (`ACTIVATIONS`)


ACTIVATIONS: dict[str, type[nn.Module]] = {"relu": nn.ReLU, "elu": nn.ELU}


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
        self.body = mlp([inputs, *config.hidden, config.action_size], ACTIVATIONS[config.activation])
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


class ActorCritic(nn.Module):
    """pi(a | s, z) as a Gaussian around `PolicyNetwork.mean`, and V(s, z).

    The critic reads the policy's normalised observation and the latents,
    and predicts the value in units of a running normaliser of the returns
    (`value_normalizer`), so its scale does not depend on the reward's.
    """

    def __init__(self, config: PolicyConfig, critic_hidden: tuple[int, ...], std: float | list[float], learn_std: bool):
        super().__init__()
        self.policy = PolicyNetwork(config)
        inputs = config.observation_size + sum(config.latent_sizes.values())
        self.critic = mlp([inputs, *critic_hidden, 1])
        log_std = torch.log(torch.as_tensor(std, dtype=torch.float32).expand(config.action_size).clone())
        if learn_std:
            self.log_std = nn.Parameter(log_std)
        else:
            self.register_buffer("log_std", log_std)
        self.value_normalizer = Normalizer(1, clip=1e6)

    def distribution(self, observation: torch.Tensor, latents: dict) -> torch.distributions.Normal:
        return torch.distributions.Normal(self.policy.mean(observation, latents), self.log_std.exp())

    def value(self, observation: torch.Tensor, latents: dict) -> torch.Tensor:
        """The critic's value in normalised units."""
        return self.critic(self.policy.features(observation, latents).detach()).squeeze(-1)

    def actor_parameters(self) -> list[nn.Parameter]:
        extra = [self.log_std] if isinstance(self.log_std, nn.Parameter) else []
        return [*self.policy.parameters(), *extra]


class StyleNetwork(nn.Module):
    """D_g and q_g of one part group over K frames of its AMP features.

    `logit` is the discriminator's output before the sigmoid; `encode` the
    encoder's estimate of the latent, on the unit sphere (the encoder
    shares the discriminator's hidden layers, as in ASE).
    """

    def __init__(self, input_size: int, hidden: tuple[int, ...], latent_size: int = 0):
        super().__init__()
        self.normalizer = Normalizer(input_size)
        self.trunk = nn.Sequential(mlp([input_size, *hidden]), nn.ReLU())
        self.logit_head = nn.Linear(hidden[-1], 1)
        self.encoder_head = nn.Linear(hidden[-1], latent_size) if latent_size else None

    def normalize(self, windows: torch.Tensor) -> torch.Tensor:
        """(..., K, d) windows as the flat, normalised input of the network."""
        return self.normalizer(windows.flatten(-2))

    def logit(self, inputs: torch.Tensor) -> torch.Tensor:
        """D's logit of normalised inputs."""
        return self.logit_head(self.trunk(inputs)).squeeze(-1)

    def encode(self, inputs: torch.Tensor) -> torch.Tensor:
        """q's latent estimate (unit length) of normalised inputs."""
        return F.normalize(self.encoder_head(self.trunk(inputs)), dim=-1)

    def logit_weights(self) -> torch.Tensor:
        return self.logit_head.weight

    def trunk_weights(self) -> list[torch.Tensor]:
        return [m.weight for m in self.trunk.modules() if isinstance(m, nn.Linear)]
