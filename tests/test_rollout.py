"""Parallel rollouts: the worker-process path (N = 1 here) gives what the env gives in process."""

import pickle

import numpy as np

import hotu_drake.envs  # noqa: F401
from hotu_drake.envs import EnvSpec, RolloutCollector, make_vector_env

SPEC = EnvSpec("hotu_drake/Imitation-v0", {"robot": "bruce", "hands": "none", "motions": ["walk"], "amp_history": 3})


def limp_after(steps: int):
    """Stand for `steps` control steps, then drop every joint to its lower limit."""
    count = {"n": 0}

    def policy(observations: np.ndarray) -> np.ndarray:
        count["n"] += 1
        env_actions = np.zeros((observations.shape[0], 16), dtype=np.float32)
        return env_actions if count["n"] <= steps else env_actions - 1.0

    return policy


def test_env_spec_is_a_plain_picklable_worker_unit():
    again = pickle.loads(pickle.dumps(SPEC))
    assert again == SPEC
    env = again.make()
    assert env.spec.id == "hotu_drake/Imitation-v0"
    env.close()


def test_vector_rollout_in_a_worker_process_matches_the_env_in_process():
    steps = 40
    envs = make_vector_env(SPEC, 1)
    try:
        batch = RolloutCollector(envs, seed=5).collect(limp_after(5), steps)
    finally:
        envs.close()
    assert batch.observations.shape[:2] == (steps, 1) and batch.actions.shape == (steps, 1, 16)
    assert batch.amp["hip"].shape[:3] == (steps, 1, 3) and batch.num_steps == steps
    ended = np.flatnonzero(batch.terminated[:, 0] | batch.truncated[:, 0])
    assert batch.terminated.any(), "a limp robot falls within 40 steps"

    # The same seed and actions in this process give the same first episode.
    env = SPEC.make()
    observation, _ = env.reset(seed=5)
    first_end = ended[0]
    for t in range(first_end + 1):
        np.testing.assert_allclose(batch.observations[t, 0], observation, atol=1e-6)
        observation, _, terminated, _, info = env.step(batch.actions[t, 0])
        np.testing.assert_allclose(batch.next_observations[t, 0], observation, atol=1e-6)
        for part, frames in info["amp"].items():
            np.testing.assert_allclose(batch.amp[part][t, 0], frames, atol=1e-6)
    assert terminated
    env.close()
    # After the end, the batch continues from a fresh episode (same-step reset).
    assert not np.allclose(batch.observations[first_end + 1, 0], batch.next_observations[first_end, 0])
