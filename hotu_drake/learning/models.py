"""The networks a run trains besides the deployed policy: the Gaussian
actor and critic around it, and one style network (discriminator and
encoder) per part group."""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from hotu_drake.learning.normalizer import Normalizer
from hotu_drake.learning.policy import PolicyConfig, PolicyNetwork, mlp


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
