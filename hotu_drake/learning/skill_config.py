"""Configuration of a skill run (`python -m hotu_drake.train skill`).

Four methods on the same task environment and samples (`SKILL_ALGORITHMS`):

- `ours`: a high-level policy over the frozen DAIL controller's part
  latents, rewarded by the task, the interaction discriminator D_I and the
  controller's own part judges (eq. 3);
- `ase`: the same high level over a whole-body ASE controller, without D_I;
- `amp`, `pmp`: one level, a policy of PD targets trained on the task
  reward plus a whole-body (AMP) or per-part averaged (PMP) style reward
  from discriminators it trains itself (`one_level`, a `TrainConfig`).

Every number here is a field of the YAML a run writes (`config.yaml`) and
reads back with `--config`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from hotu_drake.errors import InputError, check_choice, check_number
from hotu_drake.learning.config import PPOConfig, TrainConfig, _merge, preset, read_config_file

SKILL_ALGORITHMS = ("ours", "amp", "ase", "pmp")
TWO_LEVEL = ("ours", "ase")
# The method's tasks and their registered environments.
TASKS = {"box_carry": "hotu_drake/BoxCarry-v0", "drill_grasp": "hotu_drake/DrillGrasp-v0"}
# Their transfer twins: the task on a robot, tracking retargeted UDH episodes (`train finetune`).
TRANSFER_TASKS = {"box_carry": "hotu_drake/BoxCarryTransfer-v0", "drill_grasp": "hotu_drake/DrillGraspTransfer-v0"}


@dataclass
class SkillRewardConfig:
    """r = w_g r_g + w_s r_s + w_b r_b (eq. 3), each term in [0, 1]. The
    ASE task template weighs task and style 0.9 and 0.1; here the style
    share is split between the interaction and the behaviour judges (not
    measured against other splits)."""

    task: float = 0.8  # w_g: the environment's task reward
    interaction: float = 0.1  # w_s: max(0, 1 - 0.25 (D_I - 1)^2)
    style: float = 0.1  # w_b: the controller's combined part style rewards


@dataclass
class HighLevelConfig:
    """eta(z_1..P | s, G, g): an MLP over the task observation and s_I to one
    vector per part group, clipped to [-1, 1] and normalised onto the group's
    sphere (as ASE's high level does), held for `hold_steps` control steps."""

    # k: control steps each high-level action is held (ASE's task template: 5). Rewards are the
    # mean over the k steps; an episode that ends inside them ends the high-level step.
    hold_steps: int = 5
    hidden: tuple[int, ...] = (256, 128)
    critic_hidden: tuple[int, ...] = (256, 128)
    # Exploration noise of the pre-normalisation vector (each component in [-1, 1]); not measured.
    std: float = 0.2


@dataclass
class InteractionConfig:
    """D_I: eq. (2) on (s_I, s_I') transitions, regularised as the style
    discriminators are (gradient penalty on demonstrations, logit L2, weight
    decay; policy samples half fresh, half from a replay)."""

    hidden: tuple[int, ...] = (256, 128)
    learning_rate: float = 3e-5
    batch_size: int = 256
    updates: int = 2
    grad_penalty: float = 10.0
    logit_regularization: float = 0.01
    weight_decay: float = 1e-4
    replay_size: int = 50_000
    replay_keep: float = 0.1


@dataclass
class SkillEnvironmentConfig:
    """What the task environment is asked for. `task` holds the task's own
    keywords (`BoxCarryEnv`, `DrillGraspEnv`): the curriculum (start and
    target ranges, table distance), reported with the results."""

    termination_height: float = 0.5
    reference_init_probability: float = 0.0  # the method starts each episode standing (dropped)
    task: dict = field(default_factory=dict)


@dataclass
class SkillConfig:
    algo: str = "ours"
    ppo: PPOConfig = field(default_factory=lambda: PPOConfig(horizon=128))
    reward: SkillRewardConfig = field(default_factory=SkillRewardConfig)
    high_level: HighLevelConfig = field(default_factory=HighLevelConfig)
    interaction: InteractionConfig = field(default_factory=InteractionConfig)
    environment: SkillEnvironmentConfig = field(default_factory=SkillEnvironmentConfig)
    # The one-level methods' own policy and discriminators (amp, pmp); unused by ours and ase.
    one_level: TrainConfig = field(default_factory=lambda: preset("amp"))
    torch_threads: int = 2

    @property
    def two_level(self) -> bool:
        return self.algo in TWO_LEVEL

    @property
    def uses_interaction(self) -> bool:
        """D_I is trained and rewarded (ours only)."""
        return self.algo == "ours" and self.reward.interaction > 0

    def validate(self, where: str = "config") -> SkillConfig:
        check_choice(self.algo, "algo", SKILL_ALGORITHMS, where)
        p, r, h, i = self.ppo, self.reward, self.high_level, self.interaction
        check_number(p.horizon, "ppo.horizon", where, low=1, high=100_000, integer=True)
        check_number(p.epochs, "ppo.epochs", where, low=1, high=1000, integer=True)
        check_number(p.minibatch_size, "ppo.minibatch_size", where, low=1, high=1_000_000, integer=True)
        for name in ("gamma", "lam", "clip", "learning_rate", "critic_learning_rate"):
            check_number(getattr(p, name), f"ppo.{name}", where, low=0.0, high=1.0)
        for name in ("task", "interaction", "style"):
            check_number(getattr(r, name), f"reward.{name}", where, low=0.0, high=100.0)
        check_number(h.hold_steps, "high_level.hold_steps", where, low=1, high=1000, integer=True)
        check_number(h.std, "high_level.std", where, low=1e-4, high=10.0)
        check_number(i.learning_rate, "interaction.learning_rate", where, low=0.0, high=1.0)
        check_number(i.batch_size, "interaction.batch_size", where, low=1, high=1_000_000, integer=True)
        check_number(i.updates, "interaction.updates", where, low=0, high=1000, integer=True)
        check_number(i.replay_size, "interaction.replay_size", where, low=1, high=10**8, integer=True)
        check_number(i.replay_keep, "interaction.replay_keep", where, low=0.0, high=1.0)
        e = self.environment
        check_number(e.termination_height, "environment.termination_height", where, low=0.0, high=1.0)
        check_number(e.reference_init_probability, "environment.reference_init_probability", where, low=0.0, high=1.0)
        if not isinstance(e.task, dict) or not all(isinstance(k, str) for k in e.task):
            raise InputError("must be a mapping of the task's keywords", where, "environment.task")
        check_number(self.torch_threads, "torch_threads", where, low=1, high=256, integer=True)
        if not self.two_level:
            self.one_level.validate(where)
        return self

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def skill_preset(algo: str) -> SkillConfig:
    """The configuration of `algo` with every shared default."""
    check_choice(algo, "algo", SKILL_ALGORITHMS, "--algo")
    config = SkillConfig(algo=algo)
    if algo in ("amp", "pmp"):
        config.one_level = preset(algo)
        config.one_level.environment.reference_init_probability = 0.0
    if algo == "ase":
        config.reward.interaction = 0.0
    return config


def finetune_preset() -> SkillConfig:
    """The fine-tuning layer of a transfer (`train finetune`): `ours`'s high
    level, small, choosing every part's latent at every control step (a
    latent curve), rewarded by tracking of the retargeted UDH episode
    (the environment's reward, w_g) and the robot's own part judges (w_b);
    no D_I. The sizes are this project's choice, not measured against others."""
    config = skill_preset("ours")
    config.reward = SkillRewardConfig(task=0.9, interaction=0.0, style=0.1)
    config.high_level = HighLevelConfig(hold_steps=1, hidden=(64, 64), critic_hidden=(128, 64), std=0.2)
    config.ppo.horizon = 64
    return config


def skill_config_from_dict(data: dict, where: str = "config") -> SkillConfig:
    """The preset of `data['algo']` with `data`'s fields over it."""
    if not isinstance(data, dict):
        raise InputError("a skill configuration must be a mapping of sections", where)
    config = skill_preset(data.get("algo", "ours"))
    _merge(config, data, where, "")
    return config.validate(where)


def load_skill_config(path: str | Path, algo: str | None = None, base: SkillConfig | None = None) -> SkillConfig:
    """The preset of `algo` (or of the file's `algo`), or `base`, overridden by the YAML file at `path`."""
    data = read_config_file(path, algo, "ours")
    if base is None:
        return skill_config_from_dict(data, str(path))
    _merge(base, data, str(path), "")
    return base.validate(str(path))
