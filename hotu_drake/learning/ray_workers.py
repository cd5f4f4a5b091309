"""Rollout workers on Ray: each environment in a Ray actor, on this machine or a cluster.

`RayVectorEnv` is a gymnasium `VectorEnv` with the same contract as the
local backend of `rollout.make_vector_env` (episodes reset in the step
they end, with `final_obs` and `final_info`; `reset(seed=s)` seeds
environment i with s + i), so the same seeds give the same batches on
either backend. Ray is an optional extra (`pip install ".[ray]"`); this
module imports it only when a `RayVectorEnv` is made.

On a cluster: `ray start --head` on one machine, `ray start
--address=<head>:6379` on the others (each with hotu_drake installed),
then `make_vector_env(spec, N, backend="ray", address="auto")` from a
process on any of them; the actors spread over the cluster's CPUs.
"""

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from hotu_drake.errors import InputError
from hotu_drake.learning.workers import reset_request


class _EnvWorker:
    """One environment in a Ray actor; autoresets in the step an episode ends."""

    def __init__(self, spec):
        self.env = spec.make()

    def spaces(self):
        return self.env.observation_space, self.env.action_space

    def reset(self, seed: int | None, options: dict | None):
        return self.env.reset(seed=seed, options=options)

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        if terminated or truncated:
            final = {"final_obs": observation, "final_info": info}
            observation, info = self.env.reset()
            return observation, reward, terminated, truncated, info, final
        return observation, reward, terminated, truncated, info, None

    def close(self):
        self.env.close()


class RayVectorEnv(VectorEnv):
    """`num_envs` copies of `spec`'s environment, each a Ray actor of one CPU."""

    def __init__(self, spec, num_envs: int, address: str | None = None):
        try:
            import ray
        except ImportError:
            raise InputError('Ray is not installed (pip install ".[ray]")', field="backend") from None
        if not ray.is_initialized():
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
        self._ray = ray
        worker = ray.remote(num_cpus=1)(_EnvWorker)
        self.workers = [worker.remote(spec) for _ in range(num_envs)]
        self.num_envs = num_envs
        self.metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}
        self.single_observation_space, self.single_action_space = ray.get(self.workers[0].spaces.remote())
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._observations = create_empty_array(self.single_observation_space, num_envs, fn=np.zeros)

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every environment, or with `options={"reset_mask": mask}` those where `mask` is true."""
        chosen, seeds, options = reset_request(self.num_envs, seed, options)
        results = self._ray.get([self.workers[i].reset.remote(seeds[i], options) for i in chosen])
        infos: dict[str, Any] = {}
        observations = list(self._observations)
        for i, (observation, info) in zip(chosen, results):
            observations[i] = observation
            infos = self._add_info(infos, info, i)
        return self._batch(observations), infos

    def step(self, actions):
        futures = [w.step.remote(a) for w, a in zip(self.workers, actions)]
        results = self._ray.get(futures)
        infos: dict[str, Any] = {}
        for i, (*_, info, final) in enumerate(results):
            if final is not None:
                infos = self._add_info(infos, final, i)
            infos = self._add_info(infos, info, i)
        observations = self._batch([r[0] for r in results])
        rewards = np.array([r[1] for r in results], dtype=np.float64)
        terminated = np.array([r[2] for r in results], dtype=np.bool_)
        truncated = np.array([r[3] for r in results], dtype=np.bool_)
        return observations, rewards, terminated, truncated, infos

    def _batch(self, observations: list) -> np.ndarray:
        self._observations = concatenate(self.single_observation_space, observations, self._observations)
        return np.copy(self._observations)

    def close_extras(self, **kwargs) -> None:
        self._ray.get([w.close.remote() for w in self.workers])
        for w in self.workers:
            self._ray.kill(w)
        self.workers = []
