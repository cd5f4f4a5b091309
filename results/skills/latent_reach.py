"""How far a UDH behavior controller's latents move its body: from standing,
each of 12 latents (one per part group, drawn from the prior) held for 2 s;
the hands relative to the pelvis and the pelvis position at the end, and
their spread over the latents.

    python results/skills/latent_reach.py runs/udh_dail    (a run folder with its training checkpoint)
"""

import sys

import gymnasium as gym
import numpy as np

import hotu_drake.envs  # noqa: F401
from hotu_drake.learning.latents import sample_sphere
from hotu_drake.learning.low_level import LowLevelController

llc = LowLevelController.load(sys.argv[1])
env = gym.make(
    "hotu_drake/Imitation-v0",
    robot=llc.embodiment,
    hands=llc.hands,
    motions=["walk"],
    amp_history=llc.history,
    reference_init_probability=0.0,
)
u = env.unwrapped
plant = u.sim.plant
bodies = [plant.GetBodyByName(u.embodiment.key_bodies[r], u.sim.model) for r in ("pelvis", "left_hand", "right_hand")]
rng = np.random.default_rng(0)
ends = []
for i in range(12):
    obs, _ = env.reset(seed=i, options={"init": "default"})
    z = {g: sample_sphere(rng, 1, llc.latent_size) for g in llc.latent_groups}
    for _ in range(60):
        obs, _, term, trunc, _ = env.step(llc.act(obs[None], z)[0])
        if term:
            break
    p = [plant.EvalBodyPoseInWorld(u._plant_context, b).translation() for b in bodies]
    ends.append(np.concatenate([p[1] - p[0], p[2] - p[0], p[0]]))
ends = np.array(ends)
np.set_printoptions(precision=3, suppress=True)
print("left hand - pelvis, right hand - pelvis, pelvis (m) after 2 s, one row per latent:\n", ends)
print("spread (std over the latents), m:", ends.std(0))
