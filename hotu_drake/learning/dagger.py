"""Learning from a teacher's actions: DAgger, with DART's noise.

The environments label every state with the whole-body controller's
action (`info["teacher_action"]`, computed on the Drake side), so the
policy can be regressed on the teacher's actions at the states it visits
itself, not only at the teacher's (Ross et al., DAgger; Laskey et al.,
DART for the noise). One iteration (`DAggerAgent.iteration`):

1. collect `ppo.horizon` steps of every environment. At each step the
   teacher acts with probability `beta` (1 for the first
   `teacher.teacher_iterations` iterations, then falling by
   `teacher.beta_decay` each iteration), the policy's mean otherwise
   (DAgger's mixture: the teacher's steps keep the robot near what the
   policy would do, but upright, so later parts of the clips are
   visited too); `teacher.noise` is added to what is executed either way;
2. measure the policy's label loss on the states just visited, before it
   learns from them (`label_loss_visited`: the DAgger figure, falling as
   the policy's own states stop surprising it);
3. keep every (state, label) pair (`ReplayBuffer`, the oldest dropped)
   and regress the policy's mean on `teacher.updates` minibatches drawn
   from all of them (a fixed cost per iteration, however much is kept).
   The loss weighs each joint by the inverse of its kept labels'
   variance (`teacher.joint_weights`), so joints that barely move count
   as much as those that swing.

With `teacher.ppo_after` the clone goes on with PPO once that many
samples are in (lever 1's last stage): the environment's reward (its
tracking of the clip), the policy's Gaussian exploration, and the label
loss on each rollout's own states kept in the actor's loss, fading to 0
over `teacher.label_fade_samples` (`label_weight` in the metrics). The
critic learns the reward's values from the first iteration, so the
handover starts with one.

The policy is the same `ActorCritic` the style learners train. A clone
that observes its clip's phase or reference is deployed by asking for
its motion by name (`!PolicyCheckpoint {latents: walk}`): the scenario
gives it those numbers without the teacher (`systems.motion_reference`).
"""

from __future__ import annotations

import time

import numpy as np
import torch

from hotu_drake.learning.base_agent import BaseAgent
from hotu_drake.learning.buffers import ReplayBuffer, to_arrays, to_tensors
from hotu_drake.learning.config import TrainConfig
from hotu_drake.learning.demonstrations import Demonstrations
from hotu_drake.learning.latents import LatentSchedule
from hotu_drake.learning.logger import count_iteration
from hotu_drake.learning.networks import ActorCritic
from hotu_drake.learning.ppo import PPO, PPOBatch, gae, make_batch
from hotu_drake.learning.rollout import Decision, Rollout, Step

LABEL = "teacher_action"  # the info key that carries the teacher's action for the state observed


class DAggerAgent(BaseAgent):
    """Regresses a policy on the teacher's actions (`info["teacher_action"]`
    of `envs`, a vector environment made with `teacher=True`);
    `demonstrations` only for what a checkpoint records (their layout and
    control rate)."""

    def __init__(
        self,
        config: TrainConfig,
        envs,
        demonstrations: Demonstrations,
        action_offset: np.ndarray | None = None,
        seed: int = 0,
    ):
        super().__init__(config, envs, seed)
        config = self.config
        self.demos = demonstrations
        policy_config = self.policy_config(action_offset, {})
        observation_size, action_size = policy_config.observation_size, policy_config.action_size
        self.model = ActorCritic(policy_config, config.networks.critic_hidden, config.action.std, False)
        self.ppo = PPO(self.model, config.ppo)  # the critic from the start; the actor after `teacher.ppo_after`
        teacher = config.teacher
        self.optimizer = torch.optim.Adam(self.model.policy.parameters(), lr=teacher.learning_rate)
        self.labelled = ReplayBuffer(teacher.buffer_size, (observation_size + action_size,))
        self._observation_size = observation_size
        self._visited: list[tuple[np.ndarray, np.ndarray]] = []
        self._loss_weights = torch.ones(action_size)  # the label loss's joint weights in PPO's updates (`update`)
        self.latents = LatentSchedule([], 0, self.num_envs, 1, 2, self.rng)  # none (as `Agent.latents` for `trace`)
        self._reset_envs()

    @property
    def beta(self) -> float:
        """The share of steps the teacher acts at, this iteration."""
        t, done = self.config.teacher, self.counters["iteration"]
        return 1.0 if done < t.teacher_iterations else t.beta_decay ** (done - t.teacher_iterations + 1)

    @property
    def handed_over(self) -> bool:
        """Whether the clone learns by PPO now (`teacher.ppo_after`)."""
        after = self.config.teacher.ppo_after
        return after > 0 and self.counters["samples"] >= after

    @property
    def label_weight(self) -> float:
        """The label loss's weight in PPO's actor loss now (0 before the handover)."""
        t = self.config.teacher
        if not self.handed_over:
            return 0.0
        return t.label_weight * max(0.0, 1.0 - (self.counters["samples"] - t.ppo_after) / t.label_fade_samples)

    # -- the rollout loop's hooks ----------------------------------------------------

    def decide(self, observations: np.ndarray) -> Decision:
        """The teacher's action or the policy's mean, drawn per environment
        and step, with the exploration noise (after the handover: the
        policy's sample); the state and its label kept."""
        info = self.collector.info
        if LABEL not in info:
            raise RuntimeError(f"the environments give no info[{LABEL!r}]: make them with teacher=True")
        labels = np.asarray(info[LABEL], dtype=np.float32)
        self._visited.append((observations.astype(np.float32), labels))
        if self.handed_over:
            return super().decide(observations)
        mean, _ = self.act(observations, deterministic=True)
        teacher_acts = self.rng.random(len(observations)) < self.beta
        action = np.where(teacher_acts[:, None], labels, mean)
        noise = self.config.teacher.noise
        if noise > 0.0:
            action = action + noise * self.rng.standard_normal(action.shape)
        return Decision(np.clip(action, -1.0, 1.0).astype(np.float32))

    def observe(self, step: Step) -> None:
        """Episode bookkeeping."""
        self._bookkeeping(step.ended, step.terminated, step.info)
        return None

    # -- one iteration -------------------------------------------------------------

    def iteration(self) -> dict[str, float]:
        """Collect, measure the label loss on what was visited, keep it,
        regress (and fit the critic); after the handover, a PPO iteration."""
        self._visited = []
        if self.handed_over:
            weight = self.label_weight  # this iteration's (the samples counted at its end)
            return super().iteration() | {"label_weight": weight}
        start = time.perf_counter()
        beta = self.beta
        self.model.eval()
        torch.set_num_threads(1)
        rollout = (
            self.collect() if self.config.teacher.ppo_after else self.collector.collect(self, self.config.ppo.horizon)
        )
        observations, labels = self._visited_pairs()
        collected = time.perf_counter()
        torch.set_num_threads(self.config.torch_threads)
        self.labelled.add(np.concatenate([observations, labels], axis=1))
        weights = self._weights(self._kept()[1])  # of everything kept, for the measure and the regression alike
        stats = {"beta": beta, "label_loss_visited": self.label_loss(observations, labels, weights)}
        self.model.policy.normalizer.update(torch.as_tensor(observations))
        stats |= self.fit(weights)
        if self.config.teacher.ppo_after:
            stats |= self._fit_critic(rollout)
        end = time.perf_counter()
        stats |= count_iteration(self.counters, rollout.num_steps, start, collected, end)
        stats |= {"reward": float(rollout.rewards.mean()), "falls": int(rollout.terminated.sum())}
        stats |= self.episodes.stats()
        return stats

    def _visited_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """The states this iteration visited and their labels, (T N, ...) in the rollout's order."""
        return np.concatenate([o for o, _ in self._visited]), np.concatenate([a for _, a in self._visited])

    def _fit_critic(self, rollout: Rollout) -> dict[str, float]:
        c = self.config.ppo
        advantages = gae(
            rollout.rewards, rollout.values, rollout.next_values, rollout.terminated, rollout.ended, c.gamma, c.lam
        )
        batch = make_batch(
            self.model,
            rollout.observations,
            rollout.latents,
            rollout.actions,
            np.zeros(rollout.rewards.shape),
            rollout.values,
            advantages,
            c.normalize_value,
        )
        return self.ppo.fit_critic(batch, self.generator)

    # -- PPO after the handover ------------------------------------------------------

    def rewards(self, rollout: Rollout) -> dict[str, np.ndarray]:
        """The environment's reward (its tracking of the clip)."""
        return {"total": rollout.rewards}

    def batch_extras(self, rollout: Rollout) -> dict[str, np.ndarray]:
        """Each step's label, for the label loss in the actor's (`extra_losses`)."""
        _, labels = self._visited_pairs()
        return {LABEL: labels.reshape(*rollout.rewards.shape, -1)}

    def extra_losses(self, minibatch: PPOBatch, mean: torch.Tensor) -> dict[str, torch.Tensor]:
        """The label loss (joints weighed as in the regression, `update` sets them) at its weight now."""
        error = (mean - minibatch.extras[LABEL]).square() * self._loss_weights
        return {"label_term": self.label_weight * error.mean()}

    def update(self, rollout: Rollout, rewards: dict[str, np.ndarray]) -> dict[str, float]:
        """PPO with the label loss; the label loss on the rollout's states (before) as in DAgger."""
        observations, labels = self._visited_pairs()
        self._loss_weights = self._weights(self._kept()[1])
        stats = {"label_loss_visited": self.label_loss(observations, labels, self._loss_weights)}
        return stats | super().update(rollout, rewards)

    def _kept(self) -> tuple[torch.Tensor, torch.Tensor]:
        data = torch.as_tensor(self.labelled.data[: self.labelled.size])
        return data[:, : self._observation_size], data[:, self._observation_size :]

    def _weights(self, labels: torch.Tensor) -> torch.Tensor:
        """Each joint's weight in the loss: the inverse variance of its labels kept (floored), or 1."""
        if self.config.teacher.joint_weights == "equal":
            return torch.ones(labels.shape[1])
        return 1.0 / labels.var(0, unbiased=False).clamp_min(1e-4)

    def label_loss(self, observations: np.ndarray, labels: np.ndarray, weights: torch.Tensor | None = None) -> float:
        """The policy's mean squared error against `labels` at `observations`,
        each joint weighed as in the regression (`weights`, by default those
        of everything kept; with the variance weights, 1 is no better than
        the labels' mean)."""
        weights = self._weights(self._kept()[1]) if weights is None else weights
        with torch.no_grad():
            error = (self.model.policy.mean(torch.as_tensor(observations)) - torch.as_tensor(labels)).square()
            return float((error * weights).mean())

    def fit(self, weights: torch.Tensor) -> dict[str, float]:
        """`teacher.updates` minibatches of the regression weighted by `weights`, drawn from every kept pair."""
        t = self.config.teacher
        observations, labels = self._kept()
        policy = self.model.policy
        self.model.train()
        total = 0.0
        for _ in range(t.updates):
            index = torch.randint(len(observations), (t.batch_size,), generator=self.generator)
            loss = ((policy.mean(observations[index]) - labels[index]).square() * weights).mean()
            self.optimizer.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), self.config.ppo.max_grad_norm)
            self.optimizer.step()
            total += float(loss.detach())
        self.model.eval()
        return {"label_loss": total / t.updates, "labelled": self.labelled.size}

    # -- what checkpoints record -------------------------------------------------------

    def checkpoint_meta(self) -> dict:
        return {
            "groups": [],
            "layout": self.demos.layout.to_dict(),
            "samples": self.counters["samples"],
            "iteration": self.counters["iteration"],
            "config": self.config.to_dict(),
        }

    def policy_info(self) -> dict:
        """What a deployed policy needs besides its weights: no latents, and its control rate."""
        latent = self.config.latent
        prior = {"size": 0, "resample_min": latent.resample_min, "resample_max": latent.resample_max}
        return {"latent": prior, "control_rate": self.demos.control_rate}

    def state_dict(self) -> dict:
        return super().state_dict() | {
            "teacher_optimizer": self.optimizer.state_dict(),
            "labelled": to_tensors(self.labelled.state_dict()),
        }

    def load_state_dict(self, state: dict) -> None:
        self.optimizer.load_state_dict(state["teacher_optimizer"])
        self.labelled.load_state_dict(to_arrays(state["labelled"]))
        super().load_state_dict(state)
