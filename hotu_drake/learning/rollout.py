"""Parallel rollouts: environments in worker processes, batches for a trainer.

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
- `RolloutCollector` steps a vector environment with a policy (any
  function from a batch of observations to a batch of actions) and returns
  a `RolloutBatch` of arrays shaped (steps, N, ...).
"""

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field

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
class RolloutBatch:
    """Arrays of one collection, shaped (steps, num_envs, ...)."""

    observations: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    next_observations: np.ndarray  # the episode's last observation where it ended
    amp: dict[str, np.ndarray]  # part -> (steps, num_envs, K, d_part)
    interaction: np.ndarray | None = None  # s_I, tasks only

    @property
    def num_steps(self) -> int:
        return self.rewards.size


class RolloutCollector:
    """Collects fixed-length batches from a vector environment."""

    def __init__(self, envs: gym.vector.VectorEnv, seed: int | None = None):
        self.envs = envs
        self._observations, info = envs.reset(seed=seed)
        self._parts = [part for part in info["amp"] if not part.startswith("_")]  # not gymnasium's masks

    def collect(self, policy: Callable[[np.ndarray], np.ndarray], steps: int) -> RolloutBatch:
        obs, actions, rewards, terminated, truncated, next_obs, interaction = [], [], [], [], [], [], []
        amp: dict[str, list] = {part: [] for part in self._parts}
        for _ in range(steps):
            action = np.asarray(policy(self._observations), dtype=np.float32)
            observation, reward, term, trunc, info = self.envs.step(action)
            ended = term | trunc
            after = observation.copy()
            if ended.any():  # same-step reset: the ended episodes' last frames are in final_*
                for i in np.flatnonzero(ended):
                    after[i] = info["final_obs"][i]
                    for part in self._parts:
                        info["amp"][part][i] = info["final_info"]["amp"][part][i]
                    if "interaction" in info:
                        info["interaction"][i] = info["final_info"]["interaction"][i]
            obs.append(self._observations)
            actions.append(action)
            rewards.append(reward)
            terminated.append(term)
            truncated.append(trunc)
            next_obs.append(after)
            for part in self._parts:
                amp[part].append(np.array(info["amp"][part]))
            if "interaction" in info:
                interaction.append(np.array(info["interaction"]))
            self._observations = observation
        return RolloutBatch(
            observations=np.array(obs),
            actions=np.array(actions),
            rewards=np.array(rewards, dtype=np.float32),
            terminated=np.array(terminated),
            truncated=np.array(truncated),
            next_observations=np.array(next_obs),
            amp={part: np.array(frames) for part, frames in amp.items()},
            interaction=np.array(interaction) if interaction else None,
        )
