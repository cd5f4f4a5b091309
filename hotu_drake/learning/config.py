"""Training configuration: one dataclass per concern, presets per algorithm, YAML.

`TrainConfig` holds everything a run needs besides the robot and the
motions. `preset(algo)` gives the default for `dail`, `amp`, `ase` or `pmp`:
the four share every network size, sample count and PPO setting, and
differ only in how the style is judged (`StyleConfig.grouping`,
`StyleConfig.combine`) and whether there are latents (`LatentConfig.size`).
A YAML file overrides any field (`load_config`); unknown or mistyped fields
are an `InputError` naming the file and the field.

The defaults are for a CPU with two cores. Where a value was chosen by a
measurement, the comment says which (RESULTS.md has the runs).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from hotu_drake.errors import InputError, check_choice, check_number
from hotu_drake.learning.parts import TABLE_PARTS

ALGORITHMS = ("dail", "amp", "ase", "pmp", "dagger")
GROUPINGS = ("default", "table", "whole")
COMBINATIONS = ("product", "mean", "single")
STYLE_REWARDS = ("amp", "log")
ENCODER_REWARDS = ("clipped", "shifted")


@dataclass
class PPOConfig:
    """Proximal policy optimisation (clipped surrogate, GAE)."""

    # Control steps per environment per iteration. 512 with two workers keeps the
    # update at 12% of an H1 iteration (256: 23%, the style update's cost being per iteration).
    horizon: int = 512
    # Falls come 1-3 s (30-90 control steps) after their cause; 0.95 looks 0.7 s ahead. Not yet
    # separated by a measurement: at 80k samples 0.95 and 0.99 gave the same episode lengths, both
    # then limited by too much action noise.
    gamma: float = 0.99
    lam: float = 0.95
    clip: float = 0.2
    epochs: int = 4
    minibatch_size: int = 512
    learning_rate: float = 3e-4
    critic_learning_rate: float = 1e-3
    value_coefficient: float = 1.0
    clip_value: bool = True
    normalize_value: bool = True
    bound_coefficient: float = 10.0  # pushes the mean action back inside [-1, 1]
    max_grad_norm: float = 1.0
    entropy_coefficient: float = 0.0


@dataclass
class ActionConfig:
    """Actions: the standing pose's action plus `residual_scale` x the
    network's output, with Gaussian exploration noise of `std` (action
    units: [-1, 1] spans each joint's range), or of `part_std[part]` for the
    joints of a Table I part named there."""

    # The residual's reach: 0.5 of each joint's half range around the standing pose (not measured
    # against other values; the references of the library stay within it).
    residual_scale: float = 0.5
    # Exploration noise in action units. Measured on H1 standing from a drop: noise 0.05 on every
    # joint made it fall after 85 steps on average (34 episodes), 0.02 kept it up for the whole 10 s
    # in 8 episodes of 11.
    std: float = 0.04
    # The arms do not topple a standing robot: more noise there. On H1's wave (one seed each, 300k
    # samples, RESULTS.md) arm noise 0.1 left the policy 8.1 degrees from covering the reference
    # (0.04: 16.8, 0.2: 18.0).
    part_std: dict[str, float] = field(default_factory=lambda: {"shoulder": 0.1, "elbow": 0.1, "wrist": 0.1})
    learn_std: bool = False


@dataclass
class NetworkConfig:
    policy_hidden: tuple[int, ...] = (256, 128)
    policy_activation: str = "relu"  # relu | elu
    critic_hidden: tuple[int, ...] = (256, 128)
    discriminator_hidden: tuple[int, ...] = (256, 128)  # [1024, 512] in the GPU references


@dataclass
class StyleConfig:
    """The style discriminators: one per part group, their losses and rewards."""

    grouping: str = "default"  # default | table | whole, or `groups` below
    groups: dict[str, list[str]] = field(default_factory=dict)  # name -> selectors ("hip", "shoulder:left")
    group_motions: dict[str, list[str]] = field(default_factory=dict)  # a group's own clips (partial datasets)
    # Leave out of the demonstrations the windows wholly inside the still pose a clip holds before
    # it starts and after it ends (every joint slower than this, rad/s; 0: keep them). The library's
    # clips hold their first and last pose for 5-20 frames: a robot that just stands matches those.
    still_speed: float = 0.5
    combine: str = "product"  # product (DAIL) | mean (PMP) | single (one group: AMP, ASE)
    reward: str = "amp"  # amp: max(0, 1 - 0.25 (D - 1)^2); log: -log(1 - sigmoid(logit)), bounded
    weight: float = 1.0
    # A slow judge. H1 upper body (dail): at 1e-4 with penalty 5 the discriminators separated policy
    # from demonstrations by 100k samples (accuracy 0.98), the style product fell to 0.01 and after
    # 1.5M samples the motion was further from the references than standing (16.1 against 15.0
    # degrees); at 3e-5 with penalty 10, after 450k samples, 6.1 against 15.0 (RESULTS.md).
    # The published AMP settings are 1e-5 and 10.
    learning_rate: float = 3e-5
    batch_size: int = 256
    updates: int = 2  # discriminator steps per iteration (4 cost 0.15 s of a 0.8 s H1 iteration)
    grad_penalty: float = 10.0
    logit_regularization: float = 0.01
    weight_decay: float = 1e-4
    replay_size: int = 50_000
    replay_keep: float = 0.1  # the share of each iteration's policy windows kept in the replay buffer


@dataclass
class LatentConfig:
    """One latent per part group on the unit sphere, and its encoder."""

    size: int = 8  # 64 in the method; 0: no latents (AMP, PMP)
    resample_min: int = 1  # control steps, resampled every U[min, max)
    resample_max: int = 150
    encoder_weight: float = 0.5
    encoder_reward: str = "shifted"  # clipped: max(0, <z_hat, z>); shifted: (1 + <z_hat, z>) / 2
    diversity_weight: float = 0.01


@dataclass
class WarmStartConfig:
    """Behavior cloning of the reference clips' PD targets before PPO (seconds
    on a CPU). Measured on H1's wave at 300k samples (RESULTS.md): without it
    the policy stayed at its standing pose (coverage 21.2 against
    standing's 22.6 degrees), with it 8.1; with the states jittered too, the
    policy raised its arm from a drop (it did not without)."""

    epochs: int = 200
    learning_rate: float = 1e-3
    batch_size: int = 256
    # Jitter of the clips' states, in units of each column's spread (at least the median column's).
    # Without it the cloned policy extrapolates wildly off the clips: a joint a clip holds still has
    # a near-zero spread, so any deviation is a huge normalised input.
    observation_noise: float = 0.3
    # The cloning loss kept in the actor's loss during PPO at this weight, falling linearly to 0 over
    # `keep_samples`. On H1's wave at 300k samples: the policy covered the reference to 2.9 degrees
    # (7.8 without; standing 22.6) and waved.
    keep_weight: float = 20.0
    keep_samples: int = 300_000


@dataclass
class TeacherConfig:
    """Learning from the whole-body controller's actions (`dagger`): each
    iteration collects with the teacher acting at a share `beta` of the
    steps (1 for the first `teacher_iterations`, then `beta_decay` times
    less each iteration) and the policy's mean at the rest, `noise` added
    to what is executed (DART: states a little off the teacher's path);
    every state is labelled with the teacher's action, kept, and the
    policy regressed on `updates` minibatches drawn from everything kept."""

    teacher_iterations: int = 2
    # Per-episode mixing with 0.5 (the teacher gone after ten iterations) left H1's clone of the walk
    # falling 2.2 s into its episodes from 20k to 170k samples (label loss on its states 0.23).
    beta_decay: float = 0.97
    # The teacher's own 10 s of H1's looped walk with this noise on every action: no fall in 6 without
    # noise, 2 of 26 at 0.02, 6 of 26 at 0.04, 10 of 20 at 0.06. 0.03, between, is not measured alone.
    noise: float = 0.03
    updates: int = 60  # minibatches per iteration
    # Each joint's weight in the regression: the inverse of its kept labels' variance ("variance"), or 1
    # ("equal": the squared action error). In the teacher's own walk (H1) the legs' and torso's labels
    # spread 0.01-0.07 and the arms' 0.12-0.35: with equal weights the arms would rule the loss.
    joint_weights: str = "variance"
    learning_rate: float = 1e-3
    batch_size: int = 512
    buffer_size: int = 300_000  # labelled states kept (the oldest dropped); 120 MB for H1
    # After this many samples the clone goes on with PPO on the environment's reward (its tracking
    # reward, `environment.tracking_reward`), its label loss on the states of each rollout kept in the
    # actor's loss at `label_weight`, falling linearly to 0 over `label_fade_samples`. 0: DAgger only.
    # Until then the critic learns the reward's values of the rollouts, so PPO starts with a critic.
    ppo_after: int = 0
    label_weight: float = 1.0
    label_fade_samples: int = 300_000


CLIP_SAMPLINGS = ("uniform", "falls")  # how an environment draws an episode's clip (`envs.base.clip_weights`)


@dataclass
class EnvironmentConfig:
    """What the trainer asks of each environment (`Imitation-v0` keywords)."""

    reference_init_probability: float = 0.8  # reference state initialisation (AMP's share; not measured here)
    control_rate: float = 30.0  # Hz; the teacher needs 60 (BENCHMARKS.md: at 30, H1 walks 10 s from 2 of 6 starts)
    teacher: bool = False  # `info["teacher_action"]`: the whole-body controller's action (dagger)
    phase_observation: bool = False  # the observation ends with the clip's phase
    # The clips repeat (a walk goes on for the whole episode): every one (true), none, or a list of the
    # motions that do (a clone of a whole library: its walk goes on, its squat is done once).
    loop: bool | list[str] = field(default=False, metadata={"or_names": True})
    tracking_reward: bool = False  # the environment's reward: DeepMimic's tracking of the clip (`envs.tracking`)
    reference_observation: bool = False  # the observation ends with the teacher's reference against the robot
    pose_observation: bool = False  # ... and with the clip's joint positions and velocities less the robot's
    # A standing start (the share 1 - reference_init_probability) follows one of the clips from its start,
    # placed under the robot: a deployed clip-following policy's start. The run's evaluation then starts there.
    standing_follow: bool = False
    # How a training episode's clip is drawn: "uniform", or "falls" (half evenly, half by each clip's smoothed
    # fall rate in that worker's environment, `envs.base.clip_weights`). Measured once, on H1's fifteen-motion
    # clone (RESULTS.md section 13, one seed): three motions performed against seven drawn evenly.
    clip_sampling: str = "uniform"
    # The clips' objects in the scene (a grasp's table and object, the carry's box), each episode's where its
    # clip has them (`envs.clip_objects`); the run's evaluation then reports how many it held up.
    clip_objects: bool = False
    termination_height: float = 0.5
    amp_history: int = 10
    # End an episode after `style_patience` steps under this combined style reward; 0: off (the
    # rule is there and tested; its effect on the samples a behavior needs is not yet measured).
    style_termination: float = 0.0
    style_patience: int = 10


@dataclass
class TrainConfig:
    algo: str = "dail"
    ppo: PPOConfig = field(default_factory=PPOConfig)
    action: ActionConfig = field(default_factory=ActionConfig)
    networks: NetworkConfig = field(default_factory=NetworkConfig)
    style: StyleConfig = field(default_factory=StyleConfig)
    latent: LatentConfig = field(default_factory=LatentConfig)
    warm_start: WarmStartConfig = field(default_factory=WarmStartConfig)
    environment: EnvironmentConfig = field(default_factory=EnvironmentConfig)
    teacher: TeacherConfig = field(default_factory=TeacherConfig)
    # w_g: the weight of a task environment's own reward next to the style reward (`train skill`'s
    # one-level methods, amp and pmp); 0 for behavior primitives, whose environment gives none.
    task_weight: float = 0.0
    torch_threads: int = 2  # for the update; the rollout's per-step policy runs on one (measured: 2 threads made
    # the workers wait, 440 against 640 samples/s for H1 on two workers)

    def validate(self, where: str = "config") -> TrainConfig:
        check_choice(self.algo, "algo", ALGORITHMS, where)
        p, s, lat = self.ppo, self.style, self.latent
        check_number(p.horizon, "ppo.horizon", where, low=1, high=100_000, integer=True)
        check_number(p.gamma, "ppo.gamma", where, low=0.0, high=1.0)
        check_number(p.lam, "ppo.lam", where, low=0.0, high=1.0)
        check_number(p.clip, "ppo.clip", where, low=0.0, high=1.0)
        check_number(p.epochs, "ppo.epochs", where, low=1, high=1000, integer=True)
        check_number(p.minibatch_size, "ppo.minibatch_size", where, low=1, high=1_000_000, integer=True)
        for name in ("learning_rate", "critic_learning_rate"):
            check_number(getattr(p, name), f"ppo.{name}", where, low=0.0, high=1.0)
        check_number(self.action.residual_scale, "action.residual_scale", where, low=0.0, high=2.0)
        check_number(self.action.std, "action.std", where, low=1e-4, high=2.0)
        for part, value in self.action.part_std.items():
            check_choice(part, "action.part_std", TABLE_PARTS, where)
            check_number(value, f"action.part_std.{part}", where, low=1e-4, high=2.0)
        check_choice(self.networks.policy_activation, "networks.policy_activation", ("relu", "elu"), where)
        check_choice(s.grouping, "style.grouping", GROUPINGS, where)
        check_choice(s.combine, "style.combine", COMBINATIONS, where)
        check_choice(s.reward, "style.reward", STYLE_REWARDS, where)
        check_number(s.still_speed, "style.still_speed", where, low=0.0, high=100.0)
        check_number(s.batch_size, "style.batch_size", where, low=1, high=1_000_000, integer=True)
        check_number(s.updates, "style.updates", where, low=0, high=1000, integer=True)
        check_number(s.replay_keep, "style.replay_keep", where, low=0.0, high=1.0)
        check_number(lat.size, "latent.size", where, low=0, high=1024, integer=True)
        check_number(lat.resample_min, "latent.resample_min", where, low=1, high=100_000, integer=True)
        check_number(
            lat.resample_max, "latent.resample_max", where, low=lat.resample_min + 1, high=100_001, integer=True
        )
        check_choice(lat.encoder_reward, "latent.encoder_reward", ENCODER_REWARDS, where)
        check_number(self.warm_start.epochs, "warm_start.epochs", where, low=0, high=100_000, integer=True)
        check_number(self.warm_start.keep_weight, "warm_start.keep_weight", where, low=0.0, high=1e6)
        check_number(self.warm_start.keep_samples, "warm_start.keep_samples", where, low=1, high=10**10, integer=True)
        check_number(self.warm_start.observation_noise, "warm_start.observation_noise", where, low=0.0, high=10.0)
        env = self.environment
        check_number(env.amp_history, "environment.amp_history", where, low=1, high=300, integer=True)
        check_choice(env.clip_sampling, "environment.clip_sampling", CLIP_SAMPLINGS, where)
        check_number(env.control_rate, "environment.control_rate", where, low=1.0, high=1000.0)
        t = self.teacher
        check_number(t.teacher_iterations, "teacher.teacher_iterations", where, low=0, high=10**6, integer=True)
        check_number(t.beta_decay, "teacher.beta_decay", where, low=0.0, high=1.0)
        check_number(t.noise, "teacher.noise", where, low=0.0, high=1.0)
        check_number(t.updates, "teacher.updates", where, low=1, high=100_000, integer=True)
        check_choice(t.joint_weights, "teacher.joint_weights", ("variance", "equal"), where)
        check_number(t.learning_rate, "teacher.learning_rate", where, low=0.0, high=1.0)
        check_number(t.batch_size, "teacher.batch_size", where, low=1, high=1_000_000, integer=True)
        check_number(t.buffer_size, "teacher.buffer_size", where, low=1, high=10**8, integer=True)
        check_number(t.ppo_after, "teacher.ppo_after", where, low=0, high=10**10, integer=True)
        check_number(t.label_weight, "teacher.label_weight", where, low=0.0, high=1e6)
        check_number(t.label_fade_samples, "teacher.label_fade_samples", where, low=1, high=10**10, integer=True)
        if self.algo == "dagger" and not env.teacher:
            raise InputError("dagger learns from the teacher: environment.teacher must be true", where)
        if self.algo == "dagger" and t.ppo_after and not env.tracking_reward:
            raise InputError(
                "teacher.ppo_after: PPO after the clone needs a reward: environment.tracking_reward must be true",
                where,
            )
        check_number(env.style_termination, "environment.style_termination", where, low=0.0, high=1.0)
        check_number(env.style_patience, "environment.style_patience", where, low=1, high=10_000, integer=True)
        check_number(self.task_weight, "task_weight", where, low=0.0, high=100.0)
        check_number(self.torch_threads, "torch_threads", where, low=1, high=256, integer=True)
        for name, selectors in s.groups.items():
            if not isinstance(selectors, list) or not all(isinstance(x, str) for x in selectors):
                raise InputError(f"group {name!r} must be a list of part selectors", where, "style.groups")
        return self

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def preset(algo: str) -> TrainConfig:
    """The configuration of `algo` (dail, amp, ase or pmp) with every shared default."""
    check_choice(algo, "algo", ALGORITHMS, "--algo")
    config = TrainConfig(algo=algo)
    if algo == "dail":  # per-part discriminators and encoders, rewards multiplied
        config.style.grouping, config.style.combine = "default", "product"
    elif algo == "pmp":  # per-part discriminators, rewards averaged, no latent
        config.style.grouping, config.style.combine = "default", "mean"
        config.latent.size = 0
    elif algo == "amp":  # one whole-body discriminator, no latent
        config.style.grouping, config.style.combine = "whole", "single"
        config.latent.size = 0
    elif algo == "ase":  # one whole-body discriminator with an encoder and a latent
        config.style.grouping, config.style.combine = "whole", "single"
    elif algo == "dagger":  # the whole-body controller's actions, on the states the policy visits
        config.latent.size = 0
        config.environment.control_rate, config.environment.teacher = 60.0, True
        config.environment.phase_observation, config.environment.reference_init_probability = True, 1.0
        # A scratch clone of H1's walk from 36k teacher-labelled states reached a held-out R^2 of 0.9-1.0
        # on the legs' actions with (512, 512, 256) ELU layers; these ReLU ones and (256, 128) not measured.
        config.networks.policy_hidden = (512, 512, 256)
        config.ppo.horizon = 600  # 1200 samples an iteration on two workers: the 60 updates then about a fifth of it
    return config


def config_from_dict(data: dict, base: TrainConfig | None = None, where: str = "config") -> TrainConfig:
    """`base` (default: the preset of `data['algo']`, else DAIL) with `data`'s fields over it."""
    if not isinstance(data, dict):
        raise InputError("a training configuration must be a mapping of sections", where)
    config = base or preset(data.get("algo", "dail"))
    _merge(config, data, where, "")
    return config.validate(where)


def load_config(path: str | Path, algo: str | None = None) -> TrainConfig:
    """The preset of `algo` (or of the file's `algo`) overridden by the YAML file at `path`."""
    data = read_config_file(path, algo, "dail")
    return config_from_dict(data, preset(data["algo"]), str(path))


def read_config_file(path: str | Path, algo: str | None, default_algo: str) -> dict:
    """A configuration file's mapping, its `algo` set to `algo` (which the
    file may not contradict), else the file's, else `default_algo`."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except OSError as error:
        raise InputError(f"cannot read it ({error.strerror})", str(path)) from None
    except yaml.YAMLError as error:
        raise InputError(f"not valid YAML ({str(error).splitlines()[0]})", str(path)) from None
    if not isinstance(data, dict):
        raise InputError("a training configuration must be a mapping of sections", str(path))
    if algo and data.get("algo", algo) != algo:
        raise InputError(f"the file says algo {data['algo']!r}, the command line {algo!r}", str(path), "algo")
    return {**data, "algo": algo or data.get("algo", default_algo)}


def _merge(target: Any, data: dict, where: str, prefix: str) -> None:
    fields = {f.name: f for f in dataclasses.fields(target)}
    for key, value in data.items():
        name = f"{prefix}{key}"
        if key not in fields:
            known = ", ".join(fields)
            raise InputError(f"unknown field {name!r} (known here: {known})", where, name)
        current = getattr(target, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                raise InputError(f"{name!r} must be a mapping", where, name)
            _merge(current, value, where, f"{name}.")
        elif fields[key].metadata.get("or_names"):  # a flag, or the names it applies to
            if isinstance(value, list) and all(isinstance(v, str) and v for v in value):
                setattr(target, key, list(value))
            elif isinstance(value, bool):
                setattr(target, key, value)
            else:
                raise InputError(f"{name!r} must be true, false or a list of motion names, not {value!r}", where, name)
        else:
            setattr(target, key, _typed(value, current, where, name))


def _typed(value: Any, current: Any, where: str, name: str) -> Any:
    """`value` as the type of the field's default (tuples from lists, ints as floats)."""
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise InputError(f"{name!r} must be true or false, not {value!r}", where, name)
        return value
    if isinstance(current, float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(f"{name!r} must be a number, not {value!r}", where, name)
        return float(value)
    if isinstance(current, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{name!r} must be a whole number, not {value!r}", where, name)
        return value
    if isinstance(current, str):
        if not isinstance(value, str):
            raise InputError(f"{name!r} must be text, not {value!r}", where, name)
        return value
    if isinstance(current, tuple):
        if not isinstance(value, list | tuple) or not all(isinstance(v, int) and v > 0 for v in value):
            raise InputError(f"{name!r} must be a list of positive whole numbers", where, name)
        return tuple(value)
    if isinstance(current, dict):
        if not isinstance(value, dict):
            raise InputError(f"{name!r} must be a mapping", where, name)
        return dict(value)
    return value
