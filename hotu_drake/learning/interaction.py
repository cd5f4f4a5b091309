"""The interaction discriminator D_I: does the hand-object interaction look human?

D_I judges transitions (s_I, s_I') of the interaction graph's features
s_I = {d_ho, d_og, e_ho}: from the human-object demonstrations retargeted
to the robot (computed by the environment's own InteractionGraphSystem at
the clips' frames) against the policy's. It is a `StyleNetwork` over a
window of two frames, trained with eq. (2) as the style discriminators are
(`style.discriminator_loss`), and its reward is the bounded
max(0, 1 - 0.25 (D_I - 1)^2) (`style.style_reward`).
"""

from __future__ import annotations

import numpy as np
import torch

from hotu_drake.learning.buffers import ReplayBuffer, to_arrays, to_tensors
from hotu_drake.learning.networks import StyleNetwork
from hotu_drake.learning.skill_config import InteractionConfig
from hotu_drake.learning.style import discriminator_loss, style_reward


def transitions(sequences: list[np.ndarray]) -> np.ndarray:
    """Every (s_I, s_I') pair of consecutive frames of each sequence (T, d), as (N, 2, d)."""
    pairs = [np.stack([s[:-1], s[1:]], axis=1) for s in sequences if len(s) > 1]
    if not pairs:
        raise ValueError("no demonstration with two or more interaction frames")
    return np.concatenate(pairs).astype(np.float32)


class InteractionJudge:
    """D_I with its optimiser, replay of policy transitions and demonstrations."""

    def __init__(self, demonstrations: np.ndarray, config: InteractionConfig, rng: np.random.Generator):
        self.demos = np.asarray(demonstrations, dtype=np.float32)  # (N, 2, d)
        self.config, self.rng = config, rng
        size = self.demos.shape[-1]
        self.network = StyleNetwork(2 * size, config.hidden, 0)
        self.optimizer = torch.optim.Adam(self.network.parameters(), lr=config.learning_rate)
        self.replay = ReplayBuffer(config.replay_size, (2, size))

    def reward(self, pairs: np.ndarray) -> np.ndarray:
        """r_s in [0, 1] of transitions (..., 2, d)."""
        with torch.no_grad():
            x = self.network.normalize(torch.as_tensor(pairs, dtype=torch.float32))
            return style_reward(self.network.logit(x), "amp").numpy()

    def update(self, pairs: np.ndarray) -> dict[str, float]:
        """Eq. (2) on this iteration's policy transitions (N, 2, d) against demonstrations."""
        c = self.config
        demo_all = self.demos[self.rng.integers(0, len(self.demos), len(pairs))]
        both = np.concatenate([demo_all, pairs]).reshape(len(demo_all) + len(pairs), -1)
        self.network.normalizer.update(torch.as_tensor(both))
        stats: dict[str, float] = {}
        for _ in range(c.updates):
            demo = self.demos[self.rng.integers(0, len(self.demos), c.batch_size)]
            policy = self.replay.mix(pairs[self.rng.integers(0, len(pairs), c.batch_size)], self.rng)
            loss, batch_stats = discriminator_loss(
                self.network,
                self.network.normalize(torch.as_tensor(demo)),
                self.network.normalize(torch.as_tensor(policy)),
                c.grad_penalty,
                c.logit_regularization,
                c.weight_decay,
            )
            self.optimizer.zero_grad()
            loss.backward()
            self.optimizer.step()
            for k, v in batch_stats.items():
                key = f"interaction_discriminator/{k}"
                stats[key] = stats.get(key, 0.0) + v / c.updates
        self.replay.keep(pairs, c.replay_keep, self.rng)
        return stats

    def state_dict(self) -> dict:
        replay = to_tensors(self.replay.state_dict())
        return {"network": self.network.state_dict(), "optimizer": self.optimizer.state_dict(), "replay": replay}

    def load_state_dict(self, state: dict) -> None:
        self.network.load_state_dict(state["network"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.replay.load_state_dict(to_arrays(state["replay"]))
