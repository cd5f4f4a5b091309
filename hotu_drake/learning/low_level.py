"""The frozen low-level controller of a skill: a behavior run's policy and its judges.

A skill drives a trained behavior controller pi(a | s, z_1..P) through its
latents. From the run's training checkpoint it keeps what the skill
trainer needs and nothing it may change: the policy (the mean action,
from the robot's own observation and one latent per part group), and the
part groups' discriminators, whose combined style reward is the skill's
r_b (eq. 3).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from hotu_drake.learning.checkpoint import CheckpointError, load_checkpoint, read_checkpoint
from hotu_drake.learning.config import TrainConfig, config_from_dict
from hotu_drake.learning.networks import PolicyNetwork, StyleNetwork
from hotu_drake.learning.parts import PartGroup
from hotu_drake.learning.style import combine_rewards, style_reward


@dataclass
class LowLevelController:
    """A behavior run's policy and style networks, frozen."""

    policy: PolicyNetwork
    style: nn.ModuleDict  # part group -> StyleNetwork
    groups: list[PartGroup]
    config: TrainConfig
    embodiment: str
    hands: str
    source: str = ""

    def __post_init__(self) -> None:
        self.policy.eval().requires_grad_(False)
        self.style.eval().requires_grad_(False)

    @property
    def latent_groups(self) -> list[str]:
        """The groups with a latent input, in the policy's order."""
        return list(self.policy.config.latent_sizes)

    @property
    def latent_size(self) -> int:
        return max(self.policy.config.latent_sizes.values(), default=0)

    @property
    def observation_size(self) -> int:
        """The robot's own observation: the first columns of a task's observation."""
        return self.policy.config.observation_size

    @property
    def history(self) -> int:
        return self.config.environment.amp_history

    def act(self, observations: np.ndarray, latents: dict[str, np.ndarray]) -> np.ndarray:
        """The deterministic action (the mean, clipped) for a batch; extra
        observation columns (a task's goal) are left out."""
        with torch.no_grad():
            obs = torch.as_tensor(observations[..., : self.observation_size], dtype=torch.float32)
            z = {g: torch.as_tensor(latents[g], dtype=torch.float32) for g in self.latent_groups}
            return self.policy(obs, z).numpy()

    def style_reward(self, amp: dict[str, np.ndarray]) -> np.ndarray:
        """r_b of AMP windows (`info["amp"]`, (N, K, d) per key): each group's
        bounded style reward, combined as the run combined them."""
        with torch.no_grad():
            rewards = []
            for g in self.groups:
                network = self.style[g.name]
                windows = torch.as_tensor(g.gather(amp).astype(np.float32))
                rewards.append(style_reward(network.logit(network.normalize(windows)), self.config.style.reward))
            return combine_rewards(torch.stack(rewards), self.config.style.combine).numpy()

    @staticmethod
    def from_parts(
        policy: PolicyNetwork,
        style: nn.ModuleDict,
        groups: list[PartGroup],
        config: TrainConfig,
        embodiment: str,
        hands: str,
    ) -> LowLevelController:
        """A copy of live networks (an `Agent`'s), frozen."""
        policy_copy = PolicyNetwork(policy.config)
        policy_copy.load_state_dict(policy.state_dict())
        style_copy = _style_networks(groups, config)
        style_copy.load_state_dict(style.state_dict())
        return LowLevelController(policy_copy, style_copy, groups, config, embodiment, hands)

    @staticmethod
    def load(path: str | Path) -> LowLevelController:
        """From a behavior run folder (its `checkpoint.pt`) or a training
        checkpoint file; `CheckpointError` naming the file otherwise."""
        path = Path(path)
        file = path / "checkpoint.pt" if path.is_dir() else path
        data = read_checkpoint(file, kind="training")
        policy, meta = load_checkpoint(file)
        info = meta.get("meta", {})
        if "groups" not in info or "config" not in info or "style" not in data.get("state", {}):
            raise CheckpointError("not a behavior run's checkpoint (no part groups or style networks)", file)
        if info.get("kind", "behavior") != "behavior":
            raise CheckpointError(f"a {info['kind']} checkpoint, not a behavior controller's", file)
        groups = [PartGroup.from_dict(g) for g in info["groups"]]
        config = config_from_dict(info["config"], where=str(file))
        style = _style_networks(groups, config)
        try:
            style.load_state_dict(data["state"]["style"])
        except (RuntimeError, KeyError) as error:
            reason = str(error).strip().splitlines()[0][:100]
            raise CheckpointError(f"style networks that do not fit its configuration ({reason})", file) from None
        return LowLevelController(policy, style, groups, config, meta["embodiment"], meta["hands"], str(file))


def _style_networks(groups: list[PartGroup], config: TrainConfig) -> nn.ModuleDict:
    history, hidden, size = config.environment.amp_history, config.networks.discriminator_hidden, config.latent.size
    return nn.ModuleDict({g.name: StyleNetwork(history * g.frame_size, hidden, size) for g in groups})
