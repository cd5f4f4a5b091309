"""The behavior-primitive trainer: PPO against per-part-group style
discriminators and latent encoders (DAIL), with AMP, ASE and PMP as
configurations of the same code (`config.preset`); with a task reward, the
one-level skill methods (AMP, PMP) too.

One iteration (`base_agent.BaseAgent`):

1. `collect`: `ppo.horizon` control steps of every environment of the
   vector environment with the Gaussian policy, each part group's latent
   resampled on its own timer; the AMP window of every step is kept (an
   ended episode's last window where it ended); an episode whose style
   reward stays low is ended (`environment.style_termination`).
2. `rewards`: per group, the style reward of the window (`style.style_reward`)
   and, with latents, the encoder's reward; each combined over the groups
   (`style.combine_rewards`: a product for DAIL) and weighted.
3. `update`: GAE and PPO epochs (with ASE's diversity loss when there are
   latents); then the discriminators and encoders (eq. 1 with gradient
   penalty on demonstration windows, logit regularisation, weight decay;
   policy windows half from this iteration, half from a replay buffer);
   then the running normalisers.

The agent sees the robot only through the vector environment (gymnasium)
and the `Demonstrations` arrays; `state_dict` holds everything a resumed
run needs.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from hotu_drake.learning.base_agent import BaseAgent
from hotu_drake.learning.buffers import ReplayBuffer, to_arrays, to_tensors
from hotu_drake.learning.config import TrainConfig
from hotu_drake.learning.demonstrations import Demonstrations
from hotu_drake.learning.latents import LatentSchedule, sample_sphere
from hotu_drake.learning.networks import ActorCritic, StyleNetwork
from hotu_drake.learning.parts import PartGroup, resolve_groups
from hotu_drake.learning.ppo import PPO, PPOBatch
from hotu_drake.learning.rollout import Decision, Rollout, Step
from hotu_drake.learning.style import (
    combine_rewards,
    discriminator_loss,
    diversity_loss,
    encoder_loss,
    encoder_reward,
    style_reward,
)


class Agent(BaseAgent):
    """Trains a policy on `envs` (a gymnasium vector environment whose
    `info["amp"]` is laid out as `demonstrations.layout`)."""

    def __init__(
        self,
        config: TrainConfig,
        envs,
        demonstrations: Demonstrations,
        action_offset: np.ndarray | None = None,
        seed: int = 0,
    ):
        super().__init__(config, envs, seed)
        config = self.config
        self.demos = demonstrations
        style = config.style
        self.groups: list[PartGroup] = resolve_groups(demonstrations.layout, style.grouping, style.groups or None)
        if style.combine == "single" and len(self.groups) != 1:
            raise ValueError(f"combine 'single' needs one part group, the grouping gives {len(self.groups)}")
        self.group_motions = {
            g.name: style.group_motions.get(g.name) or list(demonstrations.motions) for g in self.groups
        }
        for name, motions in self.group_motions.items():
            demonstrations.check_motions(motions, f"style.group_motions[{name}]")
        action_size = envs.single_action_space.shape[0]
        latent = config.latent
        latent_sizes = {g.name: latent.size for g in self.groups} if latent.size else {}
        policy_config = self.policy_config(action_offset, latent_sizes)
        self.model = ActorCritic(
            policy_config, config.networks.critic_hidden, self._action_std(action_size), config.action.learn_std
        )
        history = demonstrations.history
        self.style = nn.ModuleDict(
            {
                g.name: StyleNetwork(history * g.frame_size, config.networks.discriminator_hidden, latent.size)
                for g in self.groups
            }
        )
        self.ppo = PPO(self.model, config.ppo)
        self.style_optimizer = torch.optim.Adam(self.style.parameters(), lr=style.learning_rate)
        self.replay = {g.name: ReplayBuffer(style.replay_size, (history, g.frame_size)) for g in self.groups}
        self.latents = LatentSchedule(
            list(latent_sizes), latent.size, self.num_envs, latent.resample_min, latent.resample_max, self.rng
        )
        self.counters["warm_started"] = False
        self._reset_envs()

    def _action_std(self, action_size: int) -> list[float]:
        """Each action's exploration noise: `action.std`, or its part's `action.part_std`."""
        std = [self.config.action.std] * action_size
        for part, value in self.config.action.part_std.items():
            for joint in self.demos.part_joints.get(part, []):
                std[joint] = value
        return std

    def _reset_envs(self) -> None:
        self._low_style = np.zeros(self.num_envs, dtype=np.int64)
        super()._reset_envs()

    def group_windows(self, amp: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each group's windows from AMP windows (..., K, d_key) per key (`info["amp"]`)."""
        return {g.name: g.gather(amp).astype(np.float32) for g in self.groups}

    # -- the rollout loop's hooks ----------------------------------------------------

    def decide(self, observations: np.ndarray) -> Decision:
        """A sampled action for every environment, with its part latents."""
        latents = self.latents.current()
        action, log_prob = self.act(observations, latents)
        return Decision(action, log_prob, latents)

    def observe(self, step: Step) -> np.ndarray | None:
        """Bookkeeping and the latents' timers; ends the episodes whose style
        reward stayed below `environment.style_termination` for
        `environment.style_patience` steps."""
        env_config = self.config.environment
        cut = None
        if env_config.style_termination > 0:
            low = self.combine(self.group_style_rewards(self.group_windows(step.amp))) < env_config.style_termination
            self._low_style = np.where(low & ~step.ended, self._low_style + 1, 0)
            cut = self._low_style >= env_config.style_patience
            self._low_style[cut] = 0
        terminated = step.terminated if cut is None else step.terminated | cut
        ended = step.ended if cut is None else step.ended | cut
        self._bookkeeping(ended, terminated, step.info)
        self.latents.step(ended)
        return cut

    # -- rewards -----------------------------------------------------------------

    def group_style_rewards(self, windows: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each group's style reward in [0, 1] of windows (..., K, d)."""
        out = {}
        with torch.no_grad():
            for g in self.groups:
                x = torch.as_tensor(windows[g.name])
                network = self.style[g.name]
                out[g.name] = style_reward(network.logit(network.normalize(x)), self.config.style.reward).numpy()
        return out

    def group_encoder_rewards(
        self, windows: dict[str, np.ndarray], latents: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        out = {}
        with torch.no_grad():
            for g in latents:
                network = self.style[g]
                estimate = network.encode(network.normalize(torch.as_tensor(windows[g])))
                out[g] = encoder_reward(
                    estimate, torch.as_tensor(latents[g]), self.config.latent.encoder_reward
                ).numpy()
        return out

    def combine(self, per_group: dict[str, np.ndarray]) -> np.ndarray:
        stacked = torch.as_tensor(np.stack([per_group[g] for g in per_group]))
        return combine_rewards(stacked, self.config.style.combine).numpy()

    def rewards(self, rollout: Rollout) -> dict[str, np.ndarray]:
        """`total` (T, N) and its pieces: `style`, `encoder`, and per group."""
        windows = self.group_windows(rollout.amp)
        style = self.group_style_rewards(windows)
        out = {"style": self.combine(style), **{f"style/{g}": r for g, r in style.items()}}
        total = self.config.style.weight * out["style"]
        if self.config.task_weight > 0:
            out["task"] = rollout.rewards
            total = total + self.config.task_weight * rollout.rewards
        if rollout.latents:
            encoder = self.group_encoder_rewards(windows, rollout.latents)
            out["encoder"] = self.combine(encoder)
            out |= {f"encoder/{g}": r for g, r in encoder.items()}
            total = total + self.config.latent.encoder_weight * out["encoder"]
        out["total"] = total.astype(np.float32)
        return out

    # -- one iteration -------------------------------------------------------------

    def extra_losses(self, mb: PPOBatch, mean: torch.Tensor) -> dict[str, torch.Tensor]:
        """The actor's losses besides PPO's: ASE's diversity, and the cloning term."""
        return self._diversity(mb, mean) | self._cloning()

    def _cloning(self) -> dict[str, torch.Tensor]:
        """The warm start's regression, kept on at `warm_start.keep_weight`
        falling linearly to 0 over `warm_start.keep_samples` samples, so the
        first PPO updates (made while the policy still falls) do not undo
        what the cloning gave before the style rewards can hold it."""
        w = self.config.warm_start
        if w.keep_weight <= 0 or self.counters["samples"] >= w.keep_samples:
            return {}
        obs, _, _ = self._cloning_data()
        weight = w.keep_weight * (1.0 - self.counters["samples"] / w.keep_samples)
        index = torch.randint(0, len(obs), (min(w.batch_size, len(obs)),), generator=self.generator)
        return {"cloning_loss": weight * self._cloning_loss(index)}

    def _cloning_data(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """The clips' (observation, action) pairs and the jitter's scale per
        observation column, read once from the demonstrations."""
        if not hasattr(self, "_cloning_pairs"):
            observations, actions = self.demos.behavior_cloning_pairs()
            obs = torch.as_tensor(observations)
            self._cloning_pairs = (obs, torch.as_tensor(actions), _jitter_scale(obs) if len(obs) else obs)
        return self._cloning_pairs

    def _cloning_loss(self, index: torch.Tensor) -> torch.Tensor:
        """The mean squared error of the policy's mean against the clips'
        actions at the pairs `index`, on jittered states, latents drawn from
        the prior."""
        obs, target, scale = self._cloning_data()
        policy = self.model.policy
        latents = {
            g: torch.as_tensor(sample_sphere(self.rng, len(index), size))
            for g, size in policy.config.latent_sizes.items()
        }
        inputs = self._jittered(obs[index], scale, self.config.warm_start.observation_noise)
        return (policy.mean(inputs, latents) - target[index]).square().mean()

    def _diversity(self, mb: PPOBatch, mean: torch.Tensor) -> dict[str, torch.Tensor]:
        weight = self.config.latent.diversity_weight
        if weight <= 0 or not mb.latents:
            return {}
        n, size = mean.shape[0], self.config.latent.size
        other = {g: torch.as_tensor(sample_sphere(self.rng, n, size)) for g in mb.latents}
        other_mean = self.model.policy.mean(mb.observations, other)
        return {"diversity_loss": weight * diversity_loss(mean, other_mean, mb.latents, other)}

    def _demo_windows(self, group: PartGroup, count: int) -> np.ndarray:
        """`count` demonstration windows of `group` from its own motions."""
        motions = self.group_motions[group.name]
        return self.demos.sample_windows(group, count, self.rng, motions, self.config.style.still_speed)

    def update_judges(self, rollout: Rollout) -> dict[str, float]:
        """The style networks: discriminators (and encoders) on this
        iteration's windows, half of them from the replay buffer."""
        s = self.config.style
        batch = s.batch_size
        stats: dict[str, float] = {}
        windows = self.group_windows(rollout.amp)
        current = {g.name: windows[g.name].reshape(-1, *windows[g.name].shape[2:]) for g in self.groups}
        latents = {g: z.reshape(-1, z.shape[-1]) for g, z in rollout.latents.items()}
        for g in self.groups:  # the input statistics: this iteration's policy windows and as many demonstrations
            demo = self._demo_windows(g, len(current[g.name]))
            network = self.style[g.name]
            network.normalizer.update(
                torch.as_tensor(np.concatenate([demo, current[g.name]]).reshape(-1, network.normalizer.mean.numel()))
            )
        for _ in range(s.updates):
            loss = torch.zeros(())
            for g in self.groups:
                network, name = self.style[g.name], g.name
                demo = self._demo_windows(g, batch)
                index = self.rng.integers(0, len(current[name]), batch)
                fresh = current[name][index]
                policy = self.replay[name].mix(fresh, self.rng)
                demo_in = network.normalize(torch.as_tensor(demo))
                policy_in = network.normalize(torch.as_tensor(policy))
                group_loss, group_stats = discriminator_loss(
                    network, demo_in, policy_in, s.grad_penalty, s.logit_regularization, s.weight_decay
                )
                if latents:
                    encoder = encoder_loss(
                        network, network.normalize(torch.as_tensor(fresh)), torch.as_tensor(latents[name][index])
                    )
                    group_loss = group_loss + encoder
                    group_stats["encoder_loss"] = float(encoder.detach())
                loss = loss + group_loss
                for k, v in group_stats.items():
                    key = f"discriminator/{name}/{k}"
                    stats[key] = stats.get(key, 0.0) + v / s.updates
            if s.updates:
                self.style_optimizer.zero_grad()
                loss.backward()
                self.style_optimizer.step()
        for g in self.groups:
            self.replay[g.name].keep(current[g.name], s.replay_keep, self.rng)
        return stats

    def iteration_stats(self, rollout: Rollout, rewards: dict[str, np.ndarray]) -> dict[str, float]:
        cut = int(rollout.cut.sum())
        stats = {"falls": int(rollout.terminated.sum()) - cut, "style_terminations": cut, **self.episodes.stats()}
        stats |= {key: float(value.mean()) for key, value in rewards.items() if key != "total"}
        if "task" in rewards:  # a skill's one-level run: eq. (3)'s terms under the names the two-level runs use
            stats |= {"reward/task": stats["task"], "reward/style": stats["style"]}
        return stats

    # -- warm start ----------------------------------------------------------------

    def warm_start(self) -> dict[str, float]:
        """Behavior cloning: the policy's mean regressed on the reference clips'
        actions at their own states (latents drawn from the prior), the states
        jittered by `warm_start.observation_noise` (see `_jittered`)."""
        w = self.config.warm_start
        obs, _, scale = self._cloning_data()
        policy = self.model.policy
        if len(obs) == 0:
            self.counters["warm_started"] = True
            return {}
        policy.normalizer.update(
            torch.cat([obs, self._jittered(obs, scale, w.observation_noise)]) if w.observation_noise > 0 else obs
        )
        if w.epochs == 0:
            self.counters["warm_started"] = True
            return {}
        optimizer = torch.optim.Adam(policy.parameters(), lr=w.learning_rate)
        losses = []
        for _ in range(w.epochs):
            order = torch.randperm(len(obs), generator=self.generator)
            for start in range(0, len(obs), w.batch_size):
                loss = self._cloning_loss(order[start : start + w.batch_size])
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
                losses.append(loss.item())
        self.counters["warm_started"] = True
        return {"warm_start/first_loss": losses[0], "warm_start/last_loss": losses[-1]}

    def _jittered(self, obs: torch.Tensor, scale: torch.Tensor, noise: float) -> torch.Tensor:
        """`obs` plus Gaussian noise of `noise` x `scale` per column: states
        near the clips' own, which the cloned policy should also answer by
        heading for the reference's next pose."""
        if noise <= 0:
            return obs
        return obs + noise * scale * torch.randn(obs.shape, generator=self.generator)

    # -- state -----------------------------------------------------------------------

    def checkpoint_meta(self) -> dict:
        """What its checkpoints record of the run besides the command's settings."""
        return {
            "groups": [g.to_dict() for g in self.groups],
            "layout": self.demos.layout.to_dict(),
            "samples": self.counters["samples"],
            "iteration": self.counters["iteration"],
            "config": self.config.to_dict(),
        }

    def policy_info(self) -> dict:
        """What a deployed policy needs besides its weights: its latents' prior and its control rate."""
        latent = self.config.latent
        prior = {"size": latent.size, "resample_min": latent.resample_min, "resample_max": latent.resample_max}
        return {"latent": prior, "control_rate": self.demos.control_rate}

    def state_dict(self) -> dict:
        return super().state_dict() | {
            "style": self.style.state_dict(),
            "style_optimizer": self.style_optimizer.state_dict(),
            "replay": {g: to_tensors(b.state_dict()) for g, b in self.replay.items()},
            "latents": to_tensors(self.latents.state_dict()),
        }

    def load_state_dict(self, state: dict) -> None:
        self.style.load_state_dict(state["style"])
        self.style_optimizer.load_state_dict(state["style_optimizer"])
        for g, b in self.replay.items():
            b.load_state_dict(to_arrays(state["replay"][g]))
        self.latents.load_state_dict(to_arrays(state["latents"]))
        super().load_state_dict(state)


def _jitter_scale(obs: torch.Tensor) -> torch.Tensor:
    """Each observation column's spread over the clips, at least the median
    column's: a joint a clip holds still still gets jitter of a usual size."""
    spread = obs.std(0)
    return spread.clamp_min(float(spread.median()))
