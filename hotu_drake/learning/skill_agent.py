"""The two-level skill trainer (section II-C): PPO on the high-level action,
the frozen behavior controller inside the rollout.

One high-level step: the policy eta(z_1..P | s, s_I, g) gives one vector
per part group; each is clipped to [-1, 1] and normalised onto its sphere
(`to_latents`) and held for `high_level.hold_steps` (k) control steps,
during which the frozen controller (`low_level.LowLevelController`) turns
the robot's observation and those latents into PD targets. Each control
step is rewarded by eq. (3),

    r = w_g r_g + w_s r_s + w_b r_b,

r_g the environment's task reward, r_s from the interaction discriminator
on the step's (s_I, s_I') (`interaction.InteractionJudge`, `ours` only),
r_b the controller's own part judges on the step's AMP windows; the
high-level step's reward is their mean over its control steps. An episode
that ends inside the k steps ends the high-level step there (the
environment has already started the next episode; its first steps, up to
k - 1, run on the old latents and count toward no high-level step).

The high-level policy sees the task observation (the robot's, then the
goal) followed by s_I; the environments must give `info["interaction"]`
and `info["amp"]` laid out as the controller's run saw them.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import torch

from hotu_drake.learning.buffers import EpisodeLog
from hotu_drake.learning.interaction import InteractionJudge
from hotu_drake.learning.logger import count_iteration
from hotu_drake.learning.low_level import LowLevelController
from hotu_drake.learning.models import ActorCritic
from hotu_drake.learning.policy import PolicyConfig
from hotu_drake.learning.ppo import PPO, gae, make_batch
from hotu_drake.learning.skill_config import SkillConfig

HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)
REWARD_TERMS = ("task", "interaction", "style")


def to_latents(raw: np.ndarray, groups: list[str], size: int) -> dict[str, np.ndarray]:
    """The high-level action (N, G x size) as one unit latent per group:
    each group's slice clipped to [-1, 1] and normalised."""
    clipped = np.clip(raw, -1.0, 1.0).reshape(*raw.shape[:-1], len(groups), size)
    norms = np.linalg.norm(clipped, axis=-1, keepdims=True)
    unit = (clipped / np.maximum(norms, 1e-6)).astype(np.float32)
    return {g: unit[..., i, :] for i, g in enumerate(groups)}


def high_level_input(observations: np.ndarray, interaction: np.ndarray) -> np.ndarray:
    """What the high-level policy sees: the task observation, then s_I."""
    return np.concatenate([observations, interaction], axis=-1).astype(np.float32)


@dataclass
class SkillRollout:
    """One iteration's high-level samples, shaped (T, N, ...)."""

    inputs: np.ndarray
    actions: np.ndarray
    log_probs: np.ndarray
    values: np.ndarray
    next_values: np.ndarray
    rewards: np.ndarray
    terms: dict[str, np.ndarray]  # reward term -> (T, N) mean over the high-level step
    terminated: np.ndarray
    ended: np.ndarray
    transitions: np.ndarray  # (M, 2, d_I): every control step's (s_I, s_I')
    control_steps: int


class SkillAgent:
    """Trains a high-level policy over `llc` on `envs` (a gymnasium vector
    environment of a task); `interaction_demos` (N, 2, d_I) are the
    demonstrations' transitions (needed when the config uses D_I)."""

    def __init__(
        self,
        config: SkillConfig,
        envs,
        llc: LowLevelController,
        interaction_demos: np.ndarray | None = None,
        seed: int = 0,
    ):
        self.config = config.validate()
        if not config.two_level:
            raise ValueError(f"{config.algo!r} is a one-level method (learning.agent.Agent trains it)")
        if not llc.latent_groups:
            raise ValueError(f"{llc.source}: the controller takes no latents, a high level cannot drive it")
        torch.manual_seed(seed)
        self.envs, self.llc = envs, llc
        self.num_envs = envs.num_envs
        self.rng = np.random.default_rng(seed)
        self.generator = torch.Generator().manual_seed(seed)
        self.groups, self.latent_size = llc.latent_groups, llc.latent_size
        self.episodes = EpisodeLog(self.num_envs)
        self._reset_envs()
        interaction_size = self._interaction.shape[1]
        h = config.high_level
        inputs = envs.single_observation_space.shape[0] + interaction_size
        policy_config = PolicyConfig(inputs, len(self.groups) * self.latent_size, {}, h.hidden, (), 1.0)
        self.model = ActorCritic(policy_config, h.critic_hidden, h.std, learn_std=False)
        self.ppo = PPO(self.model, config.ppo)
        self.judge = None
        if config.uses_interaction:
            if interaction_demos is None or len(interaction_demos) == 0:
                raise ValueError("D_I needs demonstration transitions of the task's interaction")
            if interaction_demos.shape[-1] != interaction_size:
                size = interaction_demos.shape[-1]
                raise ValueError(f"demonstrations of s_I size {size}, the task's is {interaction_size}")
            self.judge = InteractionJudge(interaction_demos, config.interaction, self.rng)
        self.counters = {"iteration": 0, "samples": 0, "episodes": 0, "falls": 0, "successes": 0, "seconds": 0.0}

    # -- environments ------------------------------------------------------------

    def _reset_envs(self) -> None:
        observations, info = self.envs.reset(seed=int(self.rng.integers(2**31)))
        self._observations = observations
        self._interaction = _interaction(info, self.num_envs)
        self.episodes.restart()

    # -- policy ------------------------------------------------------------------

    def act(self, inputs: np.ndarray, deterministic: bool = False):
        """High-level actions (pre-normalisation) and their log-probabilities."""
        with torch.inference_mode():
            mean = self.model.policy.mean(torch.as_tensor(inputs))
            if deterministic:
                return mean.numpy(), None
            log_std = self.model.log_std
            noise = torch.randn(mean.shape, generator=self.generator)
            action = mean + log_std.exp() * noise
            log_prob = -(0.5 * noise.square() + log_std + HALF_LOG_2PI).sum(-1)
        return action.numpy(), log_prob.numpy()

    def latents(self, inputs: np.ndarray, deterministic: bool = True) -> dict[str, np.ndarray]:
        """The part latents the high level gives for `inputs` (its mean by default)."""
        raw, _ = self.act(inputs, deterministic)
        return to_latents(raw, self.groups, self.latent_size)

    def values(self, inputs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            flat = torch.as_tensor(inputs.reshape(-1, inputs.shape[-1]))
            value = self.model.value_normalizer.denormalize(self.model.value(flat, {})[:, None])[:, 0]
        return value.numpy().reshape(inputs.shape[:-1])

    # -- one iteration ---------------------------------------------------------------

    def control_step_rewards(self, amp: dict, pairs: np.ndarray, task: np.ndarray) -> dict[str, np.ndarray]:
        """Eq. (3)'s terms of control steps (any leading shape): the task
        reward, D_I's on the (s_I, s_I') `pairs`, the controller's judges'
        on the `amp` windows."""
        zeros = np.zeros(task.shape, np.float32)
        style = self.llc.style_reward(amp) if self.config.reward.style > 0 else zeros
        interaction = self.judge.reward(pairs) if self.judge is not None else zeros
        return {"task": task.astype(np.float32), "interaction": interaction, "style": style}

    def combine(self, terms: dict[str, np.ndarray]) -> np.ndarray:
        """w_g r_g + w_s r_s + w_b r_b."""
        w = self.config.reward
        return (w.task * terms["task"] + w.interaction * terms["interaction"] + w.style * terms["style"]).astype(
            np.float32
        )

    def collect(self) -> SkillRollout:
        """`ppo.horizon` high-level steps of every environment. The control
        steps' rewards are computed once at the end, in one batch (the
        judges do not change during a collection)."""
        T, N, k = self.config.ppo.horizon, self.num_envs, self.config.high_level.hold_steps
        size = len(self.groups) * self.latent_size
        first = high_level_input(self._observations, self._interaction)
        inputs = np.zeros((T, N, first.shape[1]), np.float32)
        next_inputs = np.zeros_like(inputs)
        actions = np.zeros((T, N, size), np.float32)
        log_probs = np.zeros((T, N), np.float32)
        terminated = np.zeros((T, N), bool)
        ended = np.zeros((T, N), bool)
        # Per control step: alive (in its high-level step's episode), task reward, s_I pair, AMP windows.
        alive_steps = np.zeros((T, k, N), bool)
        task_steps = np.zeros((T, k, N), np.float32)
        pair_steps = np.zeros((T, k, N, 2, first.shape[1] - self._observations.shape[1]), np.float32)
        amp_steps: dict[str, np.ndarray] = {}
        for t in range(T):
            inputs[t] = high_level_input(self._observations, self._interaction)
            raw, log_prob = self.act(inputs[t])
            actions[t], log_probs[t] = raw, log_prob
            latents = to_latents(raw, self.groups, self.latent_size)
            alive = np.ones(N, bool)
            last = inputs[t].copy()
            for j in range(k):
                action = self.llc.act(self._observations, latents)
                observation, task, term, trunc, info = self.envs.step(action)
                done = term | trunc
                after, interaction, amp = observation.copy(), _interaction(info, N), _amp(info)
                for i in np.flatnonzero(done):  # same-step reset: the ended episode's last frames
                    after[i] = info["final_obs"][i]
                    interaction[i] = info["final_info"]["interaction"][i]
                    for key in amp:
                        amp[key][i] = info["final_info"]["amp"][key][i]
                alive_steps[t, j], task_steps[t, j] = alive, task
                pair_steps[t, j, :, 0], pair_steps[t, j, :, 1] = self._interaction, interaction
                for key, windows in amp.items():
                    amp_steps.setdefault(key, np.zeros((T, k, *windows.shape), np.float32))[t, j] = windows
                last[alive] = high_level_input(after, interaction)[alive]
                terminated[t] |= term & alive
                ended[t] |= done & alive
                self._bookkeeping(done, term, info)
                alive &= ~done
                self._observations = observation
                self._interaction = _interaction(info, N)
            next_inputs[t] = last
        step_terms = self.control_step_rewards(amp_steps, pair_steps, task_steps)
        lived = np.maximum(alive_steps.sum(1), 1)
        terms = {
            name: (np.where(alive_steps, r, 0.0).sum(1) / lived).astype(np.float32) for name, r in step_terms.items()
        }
        rewards = self.combine(terms)
        values, next_values = self.values(inputs), self.values(next_inputs)
        return SkillRollout(
            inputs,
            actions,
            log_probs,
            values,
            next_values,
            rewards,
            terms,
            terminated,
            ended,
            pair_steps[alive_steps],
            T * k * N,
        )

    def _bookkeeping(self, done: np.ndarray, terminated: np.ndarray, info: dict) -> None:
        """Episode lengths, falls and successes of the environments whose episode ended."""
        self.counters["successes"] += self.episodes.step(done, info)
        self.counters["episodes"] += int(done.sum())
        self.counters["falls"] += int(terminated.sum())

    def update(self, rollout: SkillRollout) -> dict[str, float]:
        c = self.config
        r = rollout
        advantages = gae(r.rewards, r.values, r.next_values, r.terminated, r.ended, c.ppo.gamma, c.ppo.lam)
        batch = make_batch(
            self.model, r.inputs, {}, r.actions, r.log_probs, r.values, advantages, c.ppo.normalize_value
        )
        stats = self.ppo.update(batch, self.generator)
        if self.judge is not None and len(rollout.transitions):
            stats |= self.judge.update(rollout.transitions)
        self.model.policy.normalizer.update(batch.observations)
        return stats

    def iteration(self) -> dict[str, float]:
        """Collect, update; the iteration's statistics."""
        start = time.perf_counter()
        self.model.eval()
        torch.set_num_threads(1)
        rollout = self.collect()
        collected = time.perf_counter()
        torch.set_num_threads(self.config.torch_threads)
        self.model.train()
        stats = self.update(rollout)
        end = time.perf_counter()
        stats |= count_iteration(self.counters, rollout.control_steps, start, collected, end)
        stats |= {
            "reward": float(rollout.rewards.mean()),
            "falls": int(rollout.terminated.sum()),
            **self.episodes.stats(),
        }
        stats |= {f"reward/{name}": float(values.mean()) for name, values in rollout.terms.items()}
        if self.judge is None:  # no D_I (ase): no interaction term to log
            stats.pop("reward/interaction")
        return stats

    # -- state -----------------------------------------------------------------------

    def state_dict(self) -> dict:
        return {
            "model": self.model.state_dict(),
            "actor_optimizer": self.ppo.actor_optimizer.state_dict(),
            "critic_optimizer": self.ppo.critic_optimizer.state_dict(),
            "judge": self.judge.state_dict() if self.judge is not None else {},
            "numpy_rng": self.rng.bit_generator.state,
            "torch_generator": self.generator.get_state(),
            "torch_rng": torch.get_rng_state(),
            "counters": dict(self.counters),
            **self.episodes.state_dict(),
        }

    def load_state_dict(self, state: dict) -> None:
        self.model.load_state_dict(state["model"])
        self.ppo.actor_optimizer.load_state_dict(state["actor_optimizer"])
        self.ppo.critic_optimizer.load_state_dict(state["critic_optimizer"])
        if self.judge is not None:
            self.judge.load_state_dict(state["judge"])
        self.rng.bit_generator.state = state["numpy_rng"]
        self.generator.set_state(state["torch_generator"])
        torch.set_rng_state(state["torch_rng"])
        self.counters = dict(state["counters"])
        self.episodes.load_state_dict(state)
        self._reset_envs()


def _interaction(info: dict, num_envs: int) -> np.ndarray:
    """`info["interaction"]` as a (N, d) float array."""
    if "interaction" not in info:
        raise ValueError("the environment gives no info['interaction'] (s_I): not a task environment")
    return np.asarray(info["interaction"], dtype=np.float32).reshape(num_envs, -1).copy()


def _amp(info: dict) -> dict[str, np.ndarray]:
    return {key: np.array(v) for key, v in info.get("amp", {}).items() if not key.startswith("_")}


class SkillController:
    """The deterministic two-level controller for evaluation: the high
    level's mean action, held for `hold_steps` control steps per environment
    (and chosen afresh when an episode starts), driving the frozen controller."""

    def __init__(self, agent: SkillAgent):
        self.agent = agent
        self.hold = agent.config.high_level.hold_steps
        self._latents: dict[str, np.ndarray] | None = None
        self._countdown = np.zeros(agent.num_envs, dtype=np.int64)

    def __call__(self, observations: np.ndarray, interaction: np.ndarray, started: np.ndarray) -> np.ndarray:
        agent = self.agent
        due = (self._countdown <= 0) | started
        if self._latents is None or due.any():
            fresh = agent.latents(high_level_input(observations, interaction))
            if self._latents is None:
                self._latents = fresh
            for g in self._latents:
                self._latents[g][due] = fresh[g][due]
            self._countdown[due] = self.hold
        self._countdown -= 1
        return agent.llc.act(observations, self._latents)
