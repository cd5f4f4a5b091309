"""Rollout workers on Ray: a local Ray instance with two workers gives the same
batches (shapes and contents) as the local worker processes, for the same
seeds. Skips where Ray is not installed (the `ray` extra)."""

import os

import numpy as np
import pytest

from hotu_drake.learning.rollout import EnvSpec, RolloutCollector, make_vector_env

ray = pytest.importorskip("ray")

SPEC = EnvSpec("hotu_drake/Imitation-v0", {"robot": "bruce", "motions": ["squat"], "reference_init_probability": 0.5})
PASSED_ON = ("HOTU_DRAKE_CACHE", "OMP_NUM_THREADS")  # the test run's cache and threads, in the workers
STEPS = 40  # long enough for episodes to end and reset (the policy lets BRUCE fall)


def _policy(observations: np.ndarray) -> np.ndarray:
    """Deterministic and crude: BRUCE falls within a second, so episodes end inside the batch."""
    return np.tanh(3.0 * observations[:, 13:29]).astype(np.float32)


def _collect(backend: str):
    envs = make_vector_env(SPEC, 2, backend=backend)
    try:
        return RolloutCollector(envs, seed=7).collect(_policy, STEPS)
    finally:
        envs.close()


@pytest.fixture(scope="module")
def local_ray():
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        log_to_driver=False,
        runtime_env={
            "env_vars": {k: os.environ[k] for k in ("HOTU_DRAKE_CACHE", "OMP_NUM_THREADS") if k in os.environ}
        },
    )
    yield
    ray.shutdown()


def test_ray_workers_collect_the_batches_the_local_workers_do(local_ray):
    local, remote = _collect("local"), _collect("ray")
    assert (remote.terminated | remote.truncated).any()  # resets happened inside the batch
    for name in ("observations", "actions", "rewards", "terminated", "truncated", "next_observations"):
        a, b = getattr(local, name), getattr(remote, name)
        assert a.shape == b.shape and a.shape[:2] == (STEPS, 2), name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert set(local.amp) == set(remote.amp)
    for part in local.amp:
        np.testing.assert_array_equal(local.amp[part], remote.amp[part], err_msg=part)
