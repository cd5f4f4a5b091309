"""The high level of a two-level controller (section II-C): part latents,
chosen every k control steps, driving a frozen behavior controller.

- `to_latents`, `high_level_input`: what a deployed high level needs (the
  Drake system of a skill uses them too): the action as one unit latent
  per part group, and the observation as the task observation then s_I.
- `HighLevelEnv`: a task's vector environment as the high level sees it;
  one of its steps is `hold_steps` control steps of the frozen controller
  on one set of latents, each control step's arrays in `info["control"]`
  so a trainer can reward them (eq. 3) after its collection.
- `SkillController`: the deterministic two-level controller on the task's
  own environment, for evaluation.
"""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np

from hotu_drake.learning.low_level import LowLevelController
from hotu_drake.learning.rollout import last_frames


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


def interaction_of(info: dict, num_envs: int) -> np.ndarray:
    """`info["interaction"]` as a (N, d) float array."""
    if "interaction" not in info:
        raise ValueError("the environment gives no info['interaction'] (s_I): not a task environment")
    return np.asarray(info["interaction"], dtype=np.float32).reshape(num_envs, -1).copy()


def alive_mean(values: np.ndarray, alive: np.ndarray, axis: int = 0) -> np.ndarray:
    """The mean over a high-level step's control steps (`axis`) of `values`,
    over those in its episode (`alive`): what a high-level step earns."""
    lived = np.maximum(alive.sum(axis), 1)
    return (np.where(alive, values, 0.0).sum(axis) / lived).astype(np.float32)


class HighLevelEnv(gym.vector.VectorEnv):
    """A task's vector environment `envs` under the frozen controller `llc`:
    an action is the high level's raw output (one latent per part group,
    `to_latents`), held for `hold_steps` control steps; an observation is
    `high_level_input`. A step's reward is the mean task reward of the
    control steps in its episode.

    An episode that ends inside the k control steps ends the high-level
    step there (`final_obs` is its last input); the environment has already
    started the next episode, whose first steps (up to k - 1) run on the old
    latents and count toward no high-level step. `info["control"]` holds,
    per control step (k, N, ...): `alive` (in the high-level step's
    episode), `task`, `pairs` ((s_I, s_I') of the step), `amp` (the AMP
    windows after it), and the raw `ended`, `terminated` and `success` of
    every environment (for episode bookkeeping)."""

    def __init__(self, envs: gym.vector.VectorEnv, llc: LowLevelController, hold_steps: int):
        if not llc.latent_groups:
            raise ValueError(f"{llc.source}: the controller takes no latents, a high level cannot drive it")
        self.envs, self.llc, self.hold_steps = envs, llc, hold_steps
        self.groups, self.latent_size = llc.latent_groups, llc.latent_size
        self.num_envs = envs.num_envs
        self._observations: np.ndarray | None = None
        self._interaction: np.ndarray | None = None
        size = len(self.groups) * self.latent_size
        self.single_action_space = gym.spaces.Box(-np.inf, np.inf, (size,), np.float32)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.single_observation_space = None  # known after the first reset (s_I's size)
        self.observation_space = None

    @property
    def task_observation_size(self) -> int:
        """The task environment's own observation (robot, goal, references): what precedes s_I."""
        return self.envs.single_observation_space.shape[0]

    def reset(self, *, seed=None, options=None):
        observations, info = self.envs.reset(seed=seed, options=options)
        interaction = interaction_of(info, self.num_envs)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], bool)
            self._observations[mask], self._interaction[mask] = observations[mask], interaction[mask]
        else:
            self._observations, self._interaction = observations, interaction
        inputs = high_level_input(self._observations, self._interaction)
        if self.single_observation_space is None:
            self.single_observation_space = gym.spaces.Box(-np.inf, np.inf, inputs.shape[1:], np.float32)
            self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        return inputs, info

    def step(self, actions: np.ndarray):
        k, n = self.hold_steps, self.num_envs
        latents = to_latents(actions, self.groups, self.latent_size)
        alive = np.ones(n, bool)
        last = high_level_input(self._observations, self._interaction)
        terminated, ended = np.zeros(n, bool), np.zeros(n, bool)
        rows: dict[str, list] = {}
        for _ in range(k):
            action = self.llc.act(self._observations, latents)
            observation, task, term, trunc, info = self.envs.step(action)
            done = term | trunc
            interaction_of(info, n)  # raises unless the environment is a task's (it gives s_I)
            after, amp, interaction = last_frames(observation, done, info)
            success = info.get("final_info", {}).get("success")
            row = {
                "alive": alive.copy(),
                "task": np.asarray(task, np.float32),
                "pairs": np.stack([self._interaction, interaction], axis=1),
                "amp": amp,
                "ended": done,
                "terminated": term,
                "success": np.asarray(success, bool) if success is not None else np.zeros(n, bool),
                "reports_success": np.full(n, success is not None),
            }
            for key, value in row.items():
                rows.setdefault(key, []).append(value)
            last[alive] = high_level_input(after, interaction)[alive]
            terminated |= term & alive
            ended |= done & alive
            alive &= ~done
            self._observations, self._interaction = observation, interaction_of(info, n)
        control = {
            key: ({a: np.stack([v[a] for v in values]) for a in values[0]} if key == "amp" else np.stack(values))
            for key, values in rows.items()
        }
        reward = alive_mean(control["task"], control["alive"])
        inputs = high_level_input(self._observations, self._interaction)
        info = {"final_obs": last, "control": control}
        return inputs, reward.astype(np.float32), terminated, ended & ~terminated, info

    def close_extras(self, **kwargs) -> None:
        self.envs.close()


class SkillController:
    """The deterministic two-level controller for evaluation on the task's
    own environment: the high level's mean (`choose`) held for `hold_steps`
    control steps per environment (and chosen afresh when an episode
    starts), driving the frozen controller."""

    def __init__(
        self, choose: Callable[[np.ndarray], np.ndarray], llc: LowLevelController, hold_steps: int, num_envs: int
    ):
        self.choose, self.llc, self.hold = choose, llc, hold_steps
        self._latents: dict[str, np.ndarray] | None = None
        self._countdown = np.zeros(num_envs, dtype=np.int64)

    def __call__(self, observations: np.ndarray, interaction: np.ndarray, started: np.ndarray) -> np.ndarray:
        due = (self._countdown <= 0) | started
        if self._latents is None or due.any():
            raw = self.choose(high_level_input(observations, interaction))
            fresh = to_latents(raw, self.llc.latent_groups, self.llc.latent_size)
            if self._latents is None:
                self._latents = fresh
            for g in self._latents:
                self._latents[g][due] = fresh[g][due]
            self._countdown[due] = self.hold
        self._countdown -= 1
        return self.llc.act(observations, self._latents)
