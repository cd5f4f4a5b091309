"""How far a behavior controller's latents move its body: from standing,
each of `latents` latents (one per part group, drawn from the prior) held
for `seconds`; the hands relative to the pelvis and the pelvis position at
the end, and their spread over the latents.

A controller whose latents all end in one pose has nothing for a high
level to choose between: this is the measure of that (RESULTS.md, the
skills section), `python -m hotu_drake.train reach RUN`.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from hotu_drake.learning import sample_sphere
from hotu_drake.learning.low_level import LowLevelController

BODIES = ("pelvis", "left_hand", "right_hand")


def latent_reach(
    llc: LowLevelController,
    latents: int = 12,
    seconds: float = 2.0,
    seed: int = 0,
    motions: tuple[str, ...] = ("walk",),
) -> dict:
    """`ends` (one row per latent: left hand - pelvis, right hand - pelvis,
    pelvis, metres, in the world frame) and `spread` (their standard
    deviation over the latents), and how many of the episodes `fell`."""
    env = gym.make(
        "hotu_drake/Imitation-v0",
        robot=llc.embodiment,
        hands=llc.hands,
        motions=list(motions),
        amp_history=llc.history,
        reference_init_probability=0.0,
    )
    inner = env.unwrapped
    rng = np.random.default_rng(seed)
    steps = max(1, round(seconds / inner.control_period))
    ends, fell = [], 0
    try:
        for i in range(latents):
            observation, _ = env.reset(seed=seed + i, options={"init": "default"})
            z = {g: sample_sphere(rng, 1, llc.latent_size) for g in llc.latent_groups}
            for _ in range(steps):
                observation, _, terminated, _, _ = env.step(llc.act(observation[None], z)[0])
                if terminated:
                    fell += 1
                    break
            pelvis, left, right = (inner.body_position(b) for b in BODIES)
            ends.append(np.concatenate([left - pelvis, right - pelvis, pelvis]))
    finally:
        env.close()
    ends = np.array(ends)
    return {"ends": ends.round(4).tolist(), "spread": ends.std(0).round(4).tolist(), "fell": fell, "latents": latents}
