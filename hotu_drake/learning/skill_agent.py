"""The two-level skill trainer (section II-C): PPO on the high-level action,
the frozen behavior controller inside the rollout.

The agent trains over `high_level.HighLevelEnv`: one high-level step is
the policy eta(z_1..P | s, s_I, g)'s output, one vector per part group,
clipped to [-1, 1] and normalised onto its sphere (`to_latents`) and held
for `high_level.hold_steps` (k) control steps, during which the frozen
controller (`low_level.LowLevelController`) turns the robot's observation
and those latents into PD targets. Each control step is rewarded by eq. (3),

    r = w_g r_g + w_s r_s + w_b r_b,

r_g the environment's task reward, r_s from the interaction discriminator
on the step's (s_I, s_I') (`interaction.InteractionJudge`, `ours` only),
r_b the controller's own part judges on the step's AMP windows; the
high-level step's reward is their mean over its control steps in its
episode, computed once per collection (the judges do not change during
one).

The high-level policy sees the task observation (the robot's, then the
goal) followed by s_I; the environments must give `info["interaction"]`
and `info["amp"]` laid out as the controller's run saw them.
"""

from __future__ import annotations

import numpy as np

from hotu_drake.learning.base_agent import BaseAgent
from hotu_drake.learning.high_level import HighLevelEnv, SkillController, alive_mean
from hotu_drake.learning.interaction import InteractionJudge
from hotu_drake.learning.low_level import LowLevelController
from hotu_drake.learning.networks import ActorCritic, PolicyConfig
from hotu_drake.learning.ppo import PPO
from hotu_drake.learning.rollout import Rollout, Step
from hotu_drake.learning.skill_config import SkillConfig

REWARD_TERMS = ("task", "interaction", "style")


class SkillAgent(BaseAgent):
    """Trains a high-level policy over `llc` on `envs` (a gymnasium vector
    environment of a task); `interaction_demos` (N, 2, d_I) are the
    demonstrations' transitions (needed when the config uses D_I)."""

    record = ("control",)

    def __init__(
        self,
        config: SkillConfig,
        envs,
        llc: LowLevelController,
        interaction_demos: np.ndarray | None = None,
        seed: int = 0,
    ):
        if not config.two_level:
            raise ValueError(f"{config.algo!r} is a one-level method (learning.agent.Agent trains it)")
        self.task_envs, self.llc = envs, llc
        super().__init__(config, HighLevelEnv(envs, llc, config.high_level.hold_steps), seed)
        config = self.config
        self.groups, self.latent_size = llc.latent_groups, llc.latent_size
        self.counters["successes"] = 0
        self._reset_envs()
        h = config.high_level
        inputs = self.envs.single_observation_space.shape[0]
        policy_config = PolicyConfig(inputs, len(self.groups) * self.latent_size, {}, h.hidden, (), 1.0)
        self.model = ActorCritic(policy_config, h.critic_hidden, h.std, learn_std=False)
        self.ppo = PPO(self.model, config.ppo)
        self.judge = None
        if config.uses_interaction:
            if interaction_demos is None or len(interaction_demos) == 0:
                raise ValueError("D_I needs demonstration transitions of the task's interaction")
            if interaction_demos.shape[-1] != self.interaction_size:
                size = interaction_demos.shape[-1]
                raise ValueError(f"demonstrations of s_I size {size}, the task's is {self.interaction_size}")
            self.judge = InteractionJudge(interaction_demos, config.interaction, self.rng)

    @property
    def interaction_size(self) -> int:
        """s_I's size: what follows the task observation in the high level's input."""
        return self.envs.single_observation_space.shape[0] - self.envs.task_observation_size

    def controller(self) -> SkillController:
        """The deterministic two-level controller of the high level's mean, on the task's own environment."""
        choose = lambda inputs: self.act(inputs, deterministic=True)[0]  # noqa: E731
        return SkillController(choose, self.llc, self.config.high_level.hold_steps, self.task_envs.num_envs)

    # -- the rollout loop's hooks ----------------------------------------------------

    def observe(self, step: Step) -> None:
        """Episode bookkeeping of every control step of the high-level step."""
        control = step.info["control"]
        for j in range(len(control["ended"])):
            info = {"final_info": {"success": control["success"][j]}} if control["reports_success"][j].any() else {}
            self._bookkeeping(control["ended"][j], control["terminated"][j], info)
        return None

    # -- one iteration ---------------------------------------------------------------

    def num_samples(self, rollout: Rollout) -> int:
        return rollout.info["control"]["alive"].size  # T x k x N control steps

    def control_step_rewards(self, amp: dict, pairs: np.ndarray, task: np.ndarray) -> dict[str, np.ndarray]:
        """Eq. (3)'s terms of control steps (any leading shape): the task
        reward, D_I's on the (s_I, s_I') `pairs`, the controller's judges'
        on the `amp` windows."""
        zeros = np.zeros(task.shape, np.float32)
        style = self.llc.style_reward(amp) if self.config.reward.style > 0 else zeros
        interaction = self.judge.reward(pairs) if self.judge is not None else zeros
        return {"task": task.astype(np.float32), "interaction": interaction, "style": style}

    def combine(self, terms: dict[str, np.ndarray]) -> np.ndarray:
        """w_g r_g + w_s r_s + w_b r_b."""
        w = self.config.reward
        return (w.task * terms["task"] + w.interaction * terms["interaction"] + w.style * terms["style"]).astype(
            np.float32
        )

    def rewards(self, rollout: Rollout) -> dict[str, np.ndarray]:
        """`total` (T, N) and eq. (3)'s terms, each the mean over the high-level step's control steps in its episode."""
        control = rollout.info["control"]  # (T, k, N, ...)
        alive = control["alive"]
        step_terms = self.control_step_rewards(control["amp"], control["pairs"], control["task"])
        terms = {name: alive_mean(r, alive, axis=1) for name, r in step_terms.items()}
        return {**terms, "total": self.combine(terms)}

    def update_judges(self, rollout: Rollout) -> dict[str, float]:
        """D_I on every control step's (s_I, s_I') in its episode."""
        control = rollout.info["control"]
        transitions = control["pairs"][control["alive"]]  # every control step's (s_I, s_I') in its episode
        if self.judge is not None and len(transitions):
            return self.judge.update(transitions)
        return {}

    def iteration_stats(self, rollout: Rollout, rewards: dict[str, np.ndarray]) -> dict[str, float]:
        stats = {"falls": int(rollout.terminated.sum()), **self.episodes.stats()}
        stats |= {f"reward/{name}": float(rewards[name].mean()) for name in REWARD_TERMS}
        if self.judge is None:  # no D_I (ase): no interaction term to log
            stats.pop("reward/interaction")
        return stats

    # -- state -----------------------------------------------------------------------

    def checkpoint_meta(self) -> dict:
        """What its checkpoints record of the run besides the command's settings."""
        return {
            "kind": "skill",
            "llc_groups": list(self.groups),
            "latent_size": self.latent_size,
            "hold_steps": self.config.high_level.hold_steps,
            "interaction_size": self.interaction_size,
            "samples": self.counters["samples"],
            "iteration": self.counters["iteration"],
            "config": self.config.to_dict(),
        }

    def policy_info(self) -> dict:
        return {"latent": {}}

    def state_dict(self) -> dict:
        return super().state_dict() | {"judge": self.judge.state_dict() if self.judge is not None else {}}

    def load_state_dict(self, state: dict) -> None:
        if self.judge is not None:
            self.judge.load_state_dict(state["judge"])
        super().load_state_dict(state)
