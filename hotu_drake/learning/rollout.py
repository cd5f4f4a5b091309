"""Parallel rollouts: environments in worker processes, and the one loop that
steps them for every learner.

Gymnasium only (no pydrake): trainers import this, and it reaches the
robots through registered environment ids.

- `EnvSpec` is the rollout worker's unit: a plain, picklable description
  (environment id, keywords, and the module whose import registers the
  id) that makes one environment in whichever process calls it: a local
  worker process (`workers`) or a Ray actor (`ray_workers`) on this
  machine or another.
- `make_vector_env(spec, N)` runs N environments in N processes, one core
  each, batches through shared memory (also for N = 1, so tests take the
  same path as training), or with `backend="ray"` in N Ray actors
  (`address` names an existing cluster).
  Episodes reset in the same step they end; the last observation and info
  of an ended episode are in `info["final_obs"]` and `info["final_info"]`.
- `RolloutCollector` steps a vector environment with a policy and returns
  a `Rollout` of arrays shaped (steps, N, ...). The policy is any function
  from a batch of observations to a batch of actions, or a learner that
  `decide`s (actions, their log-probabilities, the latents they were taken
  with) and `observe`s each step (its own bookkeeping, and the episodes it
  ends early). Primitives, one-level skills, two-level skills (over
  `high_level.HighLevelEnv`) and fine-tunes all collect through it.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from hotu_drake.errors import check_choice, check_number


@dataclass(frozen=True)
class EnvSpec:
    """What makes one environment: a registered id, its keywords, and the
    module that registers the id (imported first, in a fresh worker too)."""

    env_id: str = "hotu_drake/Imitation-v0"
    kwargs: dict = field(default_factory=dict)
    module: str = "hotu_drake.envs"

    def make(self) -> gym.Env:
        if self.module:
            importlib.import_module(self.module)
        return gym.make(self.env_id, **self.kwargs)

    def __call__(self) -> gym.Env:
        return self.make()


BACKENDS = ("local", "ray")


def make_vector_env(
    spec: EnvSpec, num_envs: int, start_method: str = "spawn", backend: str = "local", address: str | None = None
) -> gym.vector.VectorEnv:
    """`num_envs` environments, each in its own worker process (`local`) or
    Ray actor (`ray`, on a cluster given by `address`, e.g. "auto")."""
    num_envs = check_number(num_envs, "num_envs", low=1, high=4096, integer=True)
    check_choice(backend, "backend", BACKENDS)
    if backend == "ray":
        from hotu_drake.learning.ray_workers import RayVectorEnv

        return RayVectorEnv(spec, num_envs, address)
    from hotu_drake.learning.workers import SharedMemoryVectorEnv

    return SharedMemoryVectorEnv(spec, num_envs, context=start_method)


@dataclass
class Decision:
    """A policy's choice for a batch of observations."""

    action: np.ndarray
    log_prob: np.ndarray | None = None  # of the action, for PPO
    latents: dict[str, np.ndarray] = field(default_factory=dict)  # group -> (N, z) it was taken with


@dataclass
class Step:
    """One step of every environment of a vector environment, an ended
    episode's last frames in place of the next episode's first."""

    observations: np.ndarray  # what the next decision sees (a new episode's first where one ended)
    after: np.ndarray  # the state the step reached (an ended episode's last)
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    amp: dict[str, np.ndarray]  # info["amp"] after the step, key -> (N, K, d)
    interaction: np.ndarray | None  # info["interaction"] (s_I) after the step
    info: dict

    @property
    def ended(self) -> np.ndarray:
        return self.terminated | self.truncated


@dataclass
class Rollout:
    """One collection from a vector environment, arrays shaped (T, N, ...)."""

    observations: np.ndarray  # what each action was chosen on
    actions: np.ndarray
    rewards: np.ndarray  # the environment's reward (a task's r_g)
    terminated: np.ndarray  # a fall, or an episode the learner ended (`cut`)
    truncated: np.ndarray
    next_observations: np.ndarray  # the state after each step (an ended episode's last)
    amp: dict[str, np.ndarray]  # key -> (T, N, K, d): the AMP window after each step
    interaction: np.ndarray | None = None  # (T, N, d_I): s_I after each step, tasks only
    log_probs: np.ndarray | None = None
    latents: dict[str, np.ndarray] = field(default_factory=dict)  # group -> (T, N, z)
    cut: np.ndarray | None = None  # (T, N): episodes the learner ended early
    info: dict[str, Any] = field(default_factory=dict)  # the recorded `info` keys, stacked
    values: np.ndarray | None = None  # (T, N): a learner's critic on `observations`, at collection
    next_values: np.ndarray | None = None  # (T, N): and on `next_observations`

    @property
    def ended(self) -> np.ndarray:
        return self.terminated | self.truncated

    @property
    def num_steps(self) -> int:
        return self.rewards.size


class RolloutCollector:
    """Collects fixed-length rollouts from a vector environment; `record`
    names `info` keys (arrays, or dicts of arrays) to keep in `Rollout.info`."""

    def __init__(self, envs: gym.vector.VectorEnv, seed: int | None = None, record: tuple[str, ...] = ()):
        self.envs, self.record = envs, tuple(record)
        self.reset(seed)

    def reset(self, seed: int | None = None) -> None:
        """Start every environment afresh. `info` is the vector environment's
        info that goes with `observations` (the reset's, then each step's;
        not refreshed where a learner ended episodes early)."""
        self.observations, self.info = self.envs.reset(seed=seed)

    def step(self, action: np.ndarray) -> Step:
        """One step of every environment, the ended episodes' last frames in `after`, `amp` and `interaction`."""
        observation, reward, terminated, truncated, info = self.envs.step(action)
        after, amp, interaction = last_frames(observation, terminated | truncated, info)
        return Step(observation, after, np.asarray(reward), terminated, truncated, amp, interaction, info)

    def end_episodes(self, mask: np.ndarray, step: Step) -> None:
        """Reset the environments in `mask` (a learner ended their episodes):
        the step ends as a termination there, and the next decision sees the
        fresh episodes."""
        fresh, _ = self.envs.reset(options={"reset_mask": mask})
        step.observations = step.observations.copy()
        step.observations[mask] = fresh[mask]
        step.terminated = step.terminated | mask

    def collect(self, policy, steps: int) -> Rollout:
        """`steps` steps of every environment with `policy`: a function of
        observations to actions, or an object with `decide(observations) ->
        Decision` and, optionally, `observe(step) -> mask | None` (called
        after each step; the environments in the mask it returns are ended
        early and reset)."""
        decide: Callable[[np.ndarray], Decision] = getattr(policy, "decide", None) or _plain(policy)
        observe = getattr(policy, "observe", None)
        rows: dict[str, list] = {}
        for _ in range(steps):
            decision = decide(self.observations)
            step = self.step(decision.action)
            cut = observe(step) if observe is not None else None
            if cut is not None and cut.any():
                self.end_episodes(cut, step)
            row = {
                "observations": self.observations,
                "actions": decision.action,
                "rewards": step.rewards,
                "terminated": step.terminated,
                "truncated": step.truncated,
                "next_observations": step.after,
                "amp": step.amp,
                "interaction": step.interaction,
                "log_probs": decision.log_prob,
                "latents": decision.latents,
                "cut": cut if cut is not None else np.zeros(len(step.rewards), bool),
                "info": {key: step.info[key] for key in self.record},
            }
            for key, value in row.items():
                rows.setdefault(key, []).append(value)
            self.observations, self.info = step.observations, step.info
        stacked = {key: _stack(values) for key, values in rows.items()}
        stacked["rewards"] = stacked["rewards"].astype(np.float32)
        if observe is None:
            stacked["cut"] = None
        return Rollout(**stacked)


def last_frames(
    observation: np.ndarray, ended: np.ndarray, info: dict
) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray | None]:
    """What a vector step reached: its observations, `info["amp"]` and
    `info["interaction"]` (copies), with an ended episode's own last frames
    (`final_obs`, `final_info`) where the environment already reset it."""
    after = observation.copy()
    amp = {key: np.array(v) for key, v in info.get("amp", {}).items() if not key.startswith("_")}
    interaction = np.array(info["interaction"], dtype=np.float32) if "interaction" in info else None
    for i in np.flatnonzero(ended):
        after[i] = info["final_obs"][i]
        for key in amp:
            amp[key][i] = info["final_info"]["amp"][key][i]
        if interaction is not None:
            interaction[i] = info["final_info"]["interaction"][i]
    return after, amp, interaction


def _plain(policy: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], Decision]:
    return lambda observations: Decision(np.asarray(policy(observations), dtype=np.float32))


def _stack(values: list):
    """Per-step values stacked along a new first axis: arrays, dicts of them (recursively), or None."""
    first = values[0]
    if first is None:
        return None
    if isinstance(first, dict):
        return {key: _stack([v[key] for v in values]) for key in first}
    return np.stack([np.asarray(v) for v in values])
