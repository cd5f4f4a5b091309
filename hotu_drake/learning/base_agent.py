"""What every learner shares: a Gaussian actor-critic trained by PPO on
rollouts of a vector environment.

`BaseAgent` holds the model and PPO, the seeded random streams, the
counters and episode log, and the iteration:

1. `collect`: `ppo.horizon` steps of every environment through the one
   rollout loop (`rollout.RolloutCollector`), the agent `decide`-ing each
   action and `observe`-ing each step, and the critic's values;
2. `rewards`: the learner's reward of every step (`total`) and its terms
   (with 1 and 2, the iteration's `rollout_seconds`);
3. `update`: PPO on the rollout, then whatever else the learner trains
   (`update_seconds`).

Subclasses (`agent.Agent` for behavior primitives and one-level skills,
`skill_agent.SkillAgent` for two-level skills and fine-tunes) give the
model, the rewards and their own updates; `state_dict` holds everything a
resumed run needs.
"""

from __future__ import annotations

import math
import time

import numpy as np
import torch

from hotu_drake.errors import InputError
from hotu_drake.learning.buffers import EpisodeLog
from hotu_drake.learning.logger import count_iteration
from hotu_drake.learning.networks import ActorCritic, PolicyConfig
from hotu_drake.learning.ppo import PPO, PPOBatch, gae, make_batch
from hotu_drake.learning.rollout import Decision, Rollout, RolloutCollector, Step

HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)


class BaseAgent:
    """PPO over `envs` (a gymnasium vector environment); `config` has
    `ppo`, `torch_threads` and what the subclass reads."""

    record: tuple[str, ...] = ()  # `info` keys the rollouts keep
    model: ActorCritic
    ppo: PPO

    def __init__(self, config, envs, seed: int):
        self.config = config.validate()
        torch.manual_seed(seed)
        self.envs = envs
        self.num_envs = envs.num_envs
        self.rng = np.random.default_rng(seed)
        self.generator = torch.Generator().manual_seed(seed)
        self.episodes = EpisodeLog(self.num_envs)
        self.counters: dict = {"iteration": 0, "samples": 0, "episodes": 0, "falls": 0, "seconds": 0.0}
        self.collector: RolloutCollector | None = None

    def policy_config(self, action_offset: np.ndarray | None, latent_sizes: dict[str, int]) -> PolicyConfig:
        """The policy network's sizes for these environments and `config.networks`,
        its actions around `action_offset` (the standing pose's; None: zeros)."""
        networks = self.config.networks
        return PolicyConfig(
            self.envs.single_observation_space.shape[0],
            self.envs.single_action_space.shape[0],
            latent_sizes,
            networks.policy_hidden,
            () if action_offset is None else tuple(float(a) for a in action_offset),
            self.config.action.residual_scale,
            networks.policy_activation,
        )

    def _reset_envs(self) -> None:
        """Start every environment afresh (also after a resume)."""
        seed = int(self.rng.integers(2**31))
        if self.collector is None:
            self.collector = RolloutCollector(self.envs, seed, self.record)
        else:
            self.collector.reset(seed)
        self.episodes.restart()

    # -- policy ------------------------------------------------------------------

    def act(self, observations: np.ndarray, latents: dict[str, np.ndarray] | None = None, deterministic: bool = False):
        """Actions (and their log-probabilities) for a batch; the mean, clipped to [-1, 1], if `deterministic`."""
        latents = latents or {}
        with torch.inference_mode():
            obs = torch.as_tensor(observations, dtype=torch.float32)
            mean = self.model.policy.mean(obs, {g: torch.as_tensor(z) for g, z in latents.items()})
            if deterministic:
                return mean.clamp(-1.0, 1.0).numpy(), None
            log_std = self.model.log_std
            noise = torch.randn(mean.shape, generator=self.generator)
            action = mean + log_std.exp() * noise
            # The Gaussian's log-density, written out (torch.distributions costs more than the policy here).
            log_prob = -(0.5 * noise.square() + log_std + HALF_LOG_2PI).sum(-1)
        return action.numpy(), log_prob.numpy()

    def values(self, observations: np.ndarray, latents: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """The critic's values in reward units, for (..., obs) observations."""
        with torch.no_grad():
            obs = torch.as_tensor(observations, dtype=torch.float32)
            flat = obs.reshape(-1, obs.shape[-1])
            lat = {g: torch.as_tensor(z).reshape(flat.shape[0], -1) for g, z in (latents or {}).items()}
            value = self.model.value_normalizer.denormalize(self.model.value(flat, lat)[:, None])[:, 0]
        return value.numpy().reshape(obs.shape[:-1])

    # -- the rollout loop's hooks ----------------------------------------------------

    def decide(self, observations: np.ndarray) -> Decision:
        """A sampled action for every environment."""
        action, log_prob = self.act(observations)
        return Decision(action, log_prob)

    def observe(self, step: Step) -> np.ndarray | None:
        """Bookkeeping after a step; the environments whose episodes the learner ends (None: none)."""
        self._bookkeeping(step.ended, step.terminated, step.info)
        return None

    def _bookkeeping(self, ended: np.ndarray, terminated: np.ndarray, info: dict) -> None:
        """Episode lengths, falls and successes of the environments whose episode ended."""
        succeeded = self.episodes.step(ended, info)
        if "successes" in self.counters:
            self.counters["successes"] += succeeded
        self.counters["episodes"] += int(ended.sum())
        self.counters["falls"] += int(terminated.sum())

    # -- one iteration -------------------------------------------------------------

    def collect(self) -> Rollout:
        """`ppo.horizon` steps of every environment, with the critic's values."""
        rollout = self.collector.collect(self, self.config.ppo.horizon)
        rollout.values = self.values(rollout.observations, rollout.latents)
        rollout.next_values = self.values(rollout.next_observations, rollout.latents)
        return rollout

    def num_samples(self, rollout: Rollout) -> int:
        """The samples (control steps) a rollout counts for."""
        return rollout.num_steps

    def rewards(self, rollout: Rollout) -> dict[str, np.ndarray]:
        """`total` (T, N) and its terms."""
        raise NotImplementedError

    def update(self, rollout: Rollout, rewards: dict[str, np.ndarray]) -> dict[str, float]:
        """GAE and the PPO epochs on the rollout rewarded by `rewards["total"]`
        (the actor's loss with the learner's `extra_losses`), then its judges
        (`update_judges`), then the policy's observation normaliser."""
        c, r = self.config.ppo, rollout
        advantages = gae(rewards["total"], r.values, r.next_values, r.terminated, r.ended, c.gamma, c.lam)
        batch = make_batch(
            self.model,
            r.observations,
            r.latents,
            r.actions,
            r.log_probs,
            r.values,
            advantages,
            c.normalize_value,
            self.batch_extras(rollout),
        )
        stats = self.ppo.update(batch, self.generator, self.extra_losses)
        stats |= self.update_judges(rollout)
        self.model.policy.normalizer.update(batch.observations)
        return stats

    def batch_extras(self, rollout: Rollout) -> dict[str, np.ndarray]:
        """(T, N, ...) arrays of the rollout the learner's `extra_losses` read per sample (`PPOBatch.extras`)."""
        return {}

    def extra_losses(self, minibatch: PPOBatch, mean: torch.Tensor) -> dict[str, torch.Tensor]:
        """The actor's losses besides PPO's, on a minibatch and its mean actions."""
        return {}

    def update_judges(self, rollout: Rollout) -> dict[str, float]:
        """What the learner trains besides the actor-critic (its discriminators); their statistics."""
        return {}

    def iteration(self) -> dict[str, float]:
        """Collect, reward, update; the iteration's statistics."""
        start = time.perf_counter()
        self.model.eval()
        # One thread while the workers step (the batch is a handful of rows and
        # the cores are theirs); all of them for the update, while they wait.
        torch.set_num_threads(1)
        rollout = self.collect()
        rewards = self.rewards(rollout)  # the judges do not change during a collection: its part
        collected = time.perf_counter()
        torch.set_num_threads(self.config.torch_threads)
        self.model.train()
        stats = self.update(rollout, rewards)
        end = time.perf_counter()
        stats |= count_iteration(self.counters, self.num_samples(rollout), start, collected, end)
        stats |= {"reward": float(rewards["total"].mean())}
        stats |= self.iteration_stats(rollout, rewards)
        return stats

    def iteration_stats(self, rollout: Rollout, rewards: dict[str, np.ndarray]) -> dict[str, float]:
        """What the metrics log records of an iteration besides its pace and losses."""
        return {"falls": int(rollout.terminated.sum()), **self.episodes.stats()}

    # -- state -----------------------------------------------------------------------

    def state_dict(self) -> dict:
        return {
            "model": self.model.state_dict(),
            "actor_optimizer": self.ppo.actor_optimizer.state_dict(),
            "critic_optimizer": self.ppo.critic_optimizer.state_dict(),
            "numpy_rng": self.rng.bit_generator.state,
            "torch_generator": self.generator.get_state(),
            "torch_rng": torch.get_rng_state(),
            "counters": dict(self.counters),
            **self.episodes.state_dict(),
        }

    def start_from(self, state: dict, source: str) -> None:
        """Begin with another run's networks (`state`: the agent state of
        its checkpoint, named `source` in errors): the model's weights and
        observation normalisers, nothing of its training (optimisers,
        counters, random streams); `InputError` if they do not fit."""
        try:
            self.model.load_state_dict(state["model"])
        except (KeyError, RuntimeError):
            raise InputError(
                f"{source}: its networks do not fit this run's (another robot, hands or observation?)"
            ) from None

    def load_state_dict(self, state: dict) -> None:
        self.model.load_state_dict(state["model"])
        self.ppo.actor_optimizer.load_state_dict(state["actor_optimizer"])
        self.ppo.critic_optimizer.load_state_dict(state["critic_optimizer"])
        self.rng.bit_generator.state = state["numpy_rng"]
        self.generator.set_state(state["torch_generator"])
        torch.set_rng_state(state["torch_rng"])
        self.counters = dict(state["counters"])
        self.episodes.load_state_dict(state)
        self._reset_envs()
