"""The trainer's own costs: samples per second of whole training iterations
(collect, rewards, update) with 1 and N rollout workers, and the share of
an iteration the learner's update takes, at the default configuration.

The robot starts standing (no reference starts) so that every measurement
sees the same episodes; the policy is the untrained one with its default
exploration noise. The first iterations warm the caches and are dropped.
"""

from __future__ import annotations

import statistics

from hotu_drake.learning.config import preset


def train_throughput(
    robot: str, motions: list[str], workers: int, iterations: int, warmup: int = 2, algo: str = "dail"
) -> dict:
    """Median samples/s, learner share and seconds of `iterations` iterations with `workers` workers."""
    import torch

    from hotu_drake.envs.runs import imitation_run
    from hotu_drake.learning.agent import Agent

    config = preset(algo)
    config.warm_start.epochs = 0
    config.environment.reference_init_probability = 0.0
    torch.set_num_threads(config.torch_threads)
    settings = {"robot": robot, "hands": "none", "motions": motions, "algo": algo, "seed": 0}
    run = imitation_run(settings, config)
    envs = run.vector_env(workers)
    try:
        agent = Agent(config, envs, run.demonstrations, action_offset=run.standing_action, seed=0)
        rows = [agent.iteration() for _ in range(warmup + iterations)][warmup:]
    finally:
        envs.close()
    return {
        "robot": robot,
        "algo": algo,
        "workers": workers,
        "iterations": iterations,
        "samples_per_iteration": config.ppo.horizon * workers,
        "samples_per_second": round(statistics.median(r["samples_per_second"] for r in rows), 1),
        "learner_share": round(statistics.median(r["learner_share"] for r in rows), 3),
        "rollout_seconds": round(statistics.median(r["rollout_seconds"] for r in rows), 3),
        "update_seconds": round(statistics.median(r["update_seconds"] for r in rows), 3),
        "episode_length": round(rows[-1]["episode_length"], 1),
    }
