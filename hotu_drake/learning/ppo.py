"""PPO: advantages by GAE and the clipped-surrogate update of an `ActorCritic`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch
from torch import nn

from hotu_drake.learning.config import PPOConfig
from hotu_drake.learning.networks import ActorCritic


def gae(
    rewards: np.ndarray,
    values: np.ndarray,
    next_values: np.ndarray,
    terminated: np.ndarray,
    ended: np.ndarray,
    gamma: float,
    lam: float,
) -> np.ndarray:
    """Generalised advantage estimates of a (T, N) rollout.

    `next_values[t]` is the value of the state after step t (the ended
    episode's last state where it ended); it is not bootstrapped where the
    episode `terminated` (a fall), and the sum does not run on past an
    episode's end (`ended`: terminated or truncated).
    """
    advantages = np.zeros_like(rewards, dtype=np.float64)
    running = np.zeros(rewards.shape[1])
    for t in range(rewards.shape[0] - 1, -1, -1):
        delta = rewards[t] + gamma * (1.0 - terminated[t]) * next_values[t] - values[t]
        running = delta + gamma * lam * (1.0 - ended[t]) * running
        advantages[t] = running
    return advantages.astype(np.float32)


@dataclass
class PPOBatch:
    """Flat tensors of one rollout for the update."""

    observations: torch.Tensor
    latents: dict[str, torch.Tensor]
    actions: torch.Tensor
    log_probs: torch.Tensor
    values: torch.Tensor  # normalised units, as the critic predicted them
    returns: torch.Tensor  # normalised units
    advantages: torch.Tensor
    extras: dict[str, torch.Tensor] = field(default_factory=dict)  # per-sample tensors a learner's losses read

    def __len__(self) -> int:
        return self.actions.shape[0]

    def take(self, index: torch.Tensor) -> PPOBatch:
        return PPOBatch(
            self.observations[index],
            {g: z[index] for g, z in self.latents.items()},
            self.actions[index],
            self.log_probs[index],
            self.values[index],
            self.returns[index],
            self.advantages[index],
            {name: x[index] for name, x in self.extras.items()},
        )


def make_batch(
    model: ActorCritic,
    observations: np.ndarray,
    latents: dict[str, np.ndarray],
    actions: np.ndarray,
    log_probs: np.ndarray,
    values: np.ndarray,
    advantages: np.ndarray,
    normalize_value: bool,
    extras: dict[str, np.ndarray] | None = None,
) -> PPOBatch:
    """A rollout's (T, N, ...) arrays as the update's flat batch. The
    returns (advantages + values) first update the critic's value
    normaliser (with `normalize_value`); values and returns are given in
    its units, as the critic predicts them. `extras` are (T, N, ...) arrays
    carried along per sample."""
    returns = advantages + values
    flat = observations.reshape(-1, observations.shape[-1])
    if normalize_value:
        model.value_normalizer.update(torch.as_tensor(returns.reshape(-1, 1)))
    to_normal = model.value_normalizer
    return PPOBatch(
        observations=torch.as_tensor(flat),
        latents={g: torch.as_tensor(z.reshape(len(flat), -1)) for g, z in latents.items()},
        actions=torch.as_tensor(actions.reshape(len(flat), -1)),
        log_probs=torch.as_tensor(log_probs.reshape(-1)),
        values=to_normal(torch.as_tensor(values.reshape(-1, 1)))[:, 0],
        returns=to_normal(torch.as_tensor(returns.reshape(-1, 1)))[:, 0],
        advantages=torch.as_tensor(advantages.reshape(-1)),
        extras={name: torch.as_tensor(x.reshape(len(flat), *x.shape[2:])) for name, x in (extras or {}).items()},
    )


def bound_loss(mean: torch.Tensor, bound: float = 1.0) -> torch.Tensor:
    """How far mean actions leave [-bound, bound] (squared, summed over joints)."""
    return ((mean - bound).clamp_min(0.0).square() + (mean + bound).clamp_max(0.0).square()).sum(-1).mean()


class PPO:
    """The update; `extra_loss(minibatch, mean)` adds terms of the actor (ASE's diversity)."""

    def __init__(self, model: ActorCritic, config: PPOConfig):
        self.model, self.config = model, config
        self.actor_optimizer = torch.optim.Adam(model.actor_parameters(), lr=config.learning_rate)
        self.critic_optimizer = torch.optim.Adam(model.critic.parameters(), lr=config.critic_learning_rate)

    def update(self, batch: PPOBatch, generator: torch.Generator, extra_loss=None) -> dict[str, float]:
        c = self.config
        sums: dict[str, float] = {}
        count = 0
        for _ in range(c.epochs):
            order = torch.randperm(len(batch), generator=generator)
            for start in range(0, len(batch), c.minibatch_size):
                mb = batch.take(order[start : start + c.minibatch_size])
                stats = self._step(mb, extra_loss)
                for k, v in stats.items():
                    sums[k] = sums.get(k, 0.0) + v
                count += 1
        return {k: v / max(count, 1) for k, v in sums.items()}

    def _step(self, mb: PPOBatch, extra_loss) -> dict[str, float]:
        c, model = self.config, self.model
        mean = model.policy.mean(mb.observations, mb.latents)
        distribution = torch.distributions.Normal(mean, model.log_std.exp())
        log_probs = distribution.log_prob(mb.actions).sum(-1)
        ratio = (log_probs - mb.log_probs).exp()
        advantages = mb.advantages
        if len(advantages) > 1:
            advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
        surrogate = torch.min(ratio * advantages, ratio.clamp(1 - c.clip, 1 + c.clip) * advantages)
        actor_loss = -surrogate.mean()
        bounds = bound_loss(mean)
        entropy = distribution.entropy().sum(-1).mean()
        critic_loss = self._critic_loss(mb)
        loss = actor_loss + c.bound_coefficient * bounds - c.entropy_coefficient * entropy
        loss = loss + c.value_coefficient * critic_loss
        extra: dict[str, torch.Tensor] = extra_loss(mb, mean) if extra_loss else {}
        for term in extra.values():
            loss = loss + term
        self.actor_optimizer.zero_grad()
        self.critic_optimizer.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(self.model.actor_parameters(), c.max_grad_norm)
        nn.utils.clip_grad_norm_(self.model.critic.parameters(), c.max_grad_norm)
        self.actor_optimizer.step()
        self.critic_optimizer.step()
        with torch.no_grad():
            log_ratio = log_probs - mb.log_probs
            kl = ((ratio - 1.0) - log_ratio).mean()
            clip_fraction = ((ratio - 1.0).abs() > c.clip).float().mean()
        stats = {
            "actor_loss": float(actor_loss.detach()),
            "critic_loss": float(critic_loss.detach()),
            "bound_loss": float(bounds.detach()),
            "entropy": float(entropy.detach()),
            "approx_kl": float(kl),
            "clip_fraction": float(clip_fraction),
        }
        stats |= {name: float(term.detach()) for name, term in extra.items()}
        return stats

    def _critic_loss(self, mb: PPOBatch) -> torch.Tensor:
        c = self.config
        values = self.model.value(mb.observations, mb.latents)
        loss = (values - mb.returns).square()
        if c.clip_value:
            clipped = mb.values + (values - mb.values).clamp(-c.clip, c.clip)
            loss = torch.max(loss, (clipped - mb.returns).square())
        return loss.mean()

    def fit_critic(self, batch: PPOBatch, generator: torch.Generator) -> dict[str, float]:
        """The critic's part of `update` alone (its epochs and minibatches):
        for a learner whose actor learns otherwise (a clone before its PPO)."""
        c = self.config
        total, count = 0.0, 0
        for _ in range(c.epochs):
            order = torch.randperm(len(batch), generator=generator)
            for start in range(0, len(batch), c.minibatch_size):
                loss = self._critic_loss(batch.take(order[start : start + c.minibatch_size]))
                self.critic_optimizer.zero_grad()
                (c.value_coefficient * loss).backward()
                nn.utils.clip_grad_norm_(self.model.critic.parameters(), c.max_grad_norm)
                self.critic_optimizer.step()
                total, count = total + float(loss.detach()), count + 1
        return {"critic_loss": total / max(count, 1)}
