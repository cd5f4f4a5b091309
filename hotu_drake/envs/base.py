"""DiagramEnv: a gymnasium environment over a scenario diagram.

The environment builds one diagram from a `Scenario` (by default the
environment's own: the robot on the floor, the default plant (1/60 s,
near-rigid threshold 0.1), actions at 30 Hz; or a scenario file or
shipped name given as `scenario=`), with the
`ActionInput` driver, and reuses it for every episode (a reset rewrites
the context). One `step` holds the action (normalised PD targets) for one
control period (1/30 s by default) while the simulator advances the plant
and its PD, then reads the ObservationSystem's outputs.

Every step's `info` carries `amp`: per functional part, the AMP
observations of the last K frames (oldest first, shape (K, d_part)), for
the per-part discriminators. A Drake failure during the step (the contact
solver not converging) or a diverged state ends the episode as truncated,
with a logged warning and the last good observation.
"""

import copy
import logging
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from pydrake.math import RigidTransform

from hotu_drake import embodiment as embodiments
from hotu_drake.diagrams import Simulation, build_simulation
from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS, Embodiment
from hotu_drake.embodiment.actions import standing_action
from hotu_drake.errors import InputError, check_bool, check_choice, check_number
from hotu_drake.learning.config import CLIP_SAMPLINGS
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.objects import SceneObject, place_objects
from hotu_drake.plant import (
    FallCheck,
    actuated_state_indices,
    alignment,
    move_free_body,
    placed_under,
    set_robot_state,
)
from hotu_drake.scenario import LIMITS, ActionInput, InitialCondition, Scenario, load_scenario
from hotu_drake.systems.motion_reference import (
    EXTRAS,
    PHASE_SIZE,
    clip_phase,
    extra_size,
    pose_features,
    reference_features,
)

log = logging.getLogger("hotu_drake.envs")
MAX_AMP_HISTORY = 300  # frames (10 s at 30 Hz) of AMP observation kept per step

# The environments' own scenario, where no `scenario=` is given.
DEFAULT_ROBOT, DEFAULT_HANDS = "h1", "none"
DEFAULT_CONTROL_RATE = 30.0  # the plant's step and contact: the scenario default (`scenario.DEFAULT_TIME_STEP`)


def environment_scenario(
    scenario: Scenario | str | None = None,
    robot: str | None = None,
    hands: str | None = None,
    time_step: float | None = None,
    control_rate: float | None = None,
    sampled_output_ports: bool | None = None,
    objects: list[SceneObject] | None = None,
) -> Scenario:
    """The scenario an environment builds: `scenario` (a `Scenario`, a
    scenario file or a shipped name; default the environment's own) with
    the keywords that are given overriding its fields, the `ActionInput`
    driver, and `objects` added to its own."""
    if scenario is None:
        base = Scenario(embodiment=DEFAULT_ROBOT, hands=DEFAULT_HANDS, control_rate=DEFAULT_CONTROL_RATE)
    else:
        base = load_scenario(scenario) if isinstance(scenario, str) else copy.deepcopy(scenario)
    base.embodiment = check_choice(robot, "robot", EMBODIMENT_NAMES, "environment") if robot else base.embodiment
    base.hands = check_choice(hands, "hands", HANDS_VARIANTS, "environment") if hands else base.hands
    if time_step is not None:
        base.plant_config.time_step = check_number(time_step, "time_step", "environment", **LIMITS["time_step"])
    if sampled_output_ports is not None:
        base.plant_config.use_sampled_output_ports = check_bool(
            sampled_output_ports, "sampled_output_ports", "environment"
        )
    if control_rate is not None:
        base.control_rate = check_number(control_rate, "control_rate", "environment", **LIMITS["control_rate"])
    base.initial = InitialCondition(drop_height=0.0)
    base.driver = ActionInput()
    base.objects = [*base.objects, *(objects or [])]
    base.validate(base.source or "environment")
    return base


@dataclass
class EnvTimings:
    """Wall-clock seconds spent in each part of `step` since the last reset of the counters."""

    steps: int = 0
    total: float = 0.0
    physics: float = 0.0
    observation: float = 0.0
    amp_observation: float = 0.0

    def per_step_ms(self) -> dict[str, float]:
        n = max(self.steps, 1)
        python = self.total - self.physics - self.observation - self.amp_observation
        parts = {"physics": self.physics, "observation": self.observation}
        parts |= {"amp_observation": self.amp_observation, "python_overhead": python, "total": self.total}
        return {k: round(1000 * v / n, 4) for k, v in parts.items()}


def clip_weights(falls: np.ndarray, episodes: np.ndarray) -> np.ndarray:
    """How often to draw each clip by its episodes' falls: half evenly, half
    in proportion to its fall rate smoothed as (falls + 1) / (episodes + 2)
    (a clip not yet tried counts as falling half the time), so the clips a
    policy falls in get more episodes and those it performs keep theirs."""
    rates = (np.asarray(falls, float) + 1.0) / (np.asarray(episodes, float) + 2.0)
    return 0.5 / len(rates) + 0.5 * rates / rates.sum()


def _per_clip(loop: bool | Sequence[bool], clips: int, where: str) -> tuple[bool, ...]:
    """`loop` as one flag per clip (one flag for all, or one each)."""
    if isinstance(loop, bool | np.bool_):
        return (bool(loop),) * clips
    flags = tuple(loop) if isinstance(loop, Sequence) else ()
    if len(flags) != clips or not all(isinstance(flag, bool | np.bool_) for flag in flags):
        raise InputError(f"{loop!r}: give true, false or one flag per clip ({clips})", where, "loop")
    return tuple(bool(flag) for flag in flags)


class DiagramEnv(gym.Env):
    """Shared machinery of the hotu_drake environments (not registered itself)."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        scenario: Scenario,
        clips: list[MotionClip] | None = None,
        embodiment: Embodiment | None = None,
        amp_history: int = 10,
        reference_init_probability: float = 0.8,
        drop_height: float = 0.05,
        termination_height: float = 0.5,
        teacher: bool = False,
        phase_observation: bool = False,
        loop: bool | Sequence[bool] = False,
        reference_start_time: float | None = None,
        reference_observation: bool = False,
        pose_observation: bool = False,
        standing_follow: bool = False,
        clip_sampling: str = "uniform",
    ):
        """`scenario` as `environment_scenario` makes it; `embodiment`
        overrides its robot (e.g. a resized UDH). With `teacher`, every
        step's `info["teacher_action"]` is the whole-body controller's
        action for the state the robot is in (`teacher_action`). With
        `phase_observation`, the observation ends with where the episode is
        in its clip (`clip_phase`). With `loop` (every clip, or one flag
        per clip), the clips repeat (the teacher's and the phase's; a
        walk's reference goes on past its clip). A reference start begins
        at `reference_start_time` in its clip (s; default anywhere),
        dropped from up to `drop_height` as a default start is (evaluation
        episodes then differ). With
        `reference_observation` (and `teacher`), the observation ends with
        where the teacher's reference is against the robot
        (`reference_features`); with `pose_observation`, with the clip's
        joints against the robot's (`reference_pose`). With
        `standing_follow`, a default start (the standing pose, dropped)
        follows one of the clips from `reference_start_time` (default 0),
        the clip placed under the robot as `MotionReference` places it: the
        start a deployed clip-following policy gets. `clip_sampling`: how
        an episode's clip is drawn, evenly ("uniform") or by how often this
        environment's episodes fell in each ("falls", `clip_weights`). Bad
        keywords raise `InputError`."""
        where = type(self).__name__
        amp_history = check_number(amp_history, "amp_history", where, low=1, high=MAX_AMP_HISTORY, integer=True)
        reference_init_probability = check_number(
            reference_init_probability, "reference_init_probability", where, low=0.0, high=1.0
        )
        drop_height = check_number(drop_height, "drop_height", where, low=0.0, high=1.0, unit="m")
        termination_height = check_number(termination_height, "termination_height", where, low=0.0, high=1.0)
        self.teacher = check_bool(teacher, "teacher", where)
        self.phase_observation = check_bool(phase_observation, "phase_observation", where)
        self.reference_observation = check_bool(reference_observation, "reference_observation", where)
        self.pose_observation = check_bool(pose_observation, "pose_observation", where)
        self.standing_follow = check_bool(standing_follow, "standing_follow", where)
        self.clip_sampling = check_choice(clip_sampling, "clip_sampling", CLIP_SAMPLINGS, where)
        if self.reference_observation and not self.teacher:
            raise InputError("the reference observation is the teacher's reference: give teacher=True", where)
        if reference_start_time is not None:
            check_number(reference_start_time, "reference_start_time", where, low=0.0, high=1e6, unit="s")
        self.reference_start_time = reference_start_time
        if self.teacher and scenario.fixed_base:
            raise InputError(
                "the teacher (the whole-body controller) needs the robot on its feet, not a fixed base",
                where,
                "teacher",
            )
        substeps = round(1.0 / (scenario.control_rate * scenario.time_step))
        if substeps < 1 or abs(substeps * scenario.time_step * scenario.control_rate - 1.0) > 1e-9:
            # Otherwise actions would be held, and AMP frames spaced, unevenly.
            raise InputError(
                f"the control period 1/{scenario.control_rate:g} s must be a whole number of "
                f"{scenario.time_step:g} s plant steps",
                where,
                "control_rate",
            )
        self.embodiment = embodiment or embodiments.load(scenario.embodiment, scenario.hands)
        emb = self.embodiment
        self.scenario = scenario
        self.clips = list(clips or [])
        self.loops = _per_clip(loop, len(self.clips), where)
        self.clip_episodes = np.zeros(len(self.clips))  # episodes begun on each clip, and those that fell
        self.clip_falls = np.zeros(len(self.clips))
        self.control_period = 1.0 / scenario.control_rate
        self.amp_history = amp_history
        self.reference_init_probability = reference_init_probability if self.clips else 0.0
        self.drop_height = drop_height
        self.sim: Simulation = build_simulation(scenario, embodiment=emb)
        sim = self.sim
        self._context = sim.simulator.get_mutable_context()
        self._plant_context = sim.plant.GetMyMutableContextFromRoot(self._context)
        self._action_port = sim.diagram.GetInputPort("action")
        self._observation_port = sim.diagram.GetOutputPort("observation")
        self._amp_port = sim.diagram.GetOutputPort("amp_observation")
        self._observer = sim.systems["observation"]
        self._root = sim.plant.GetBodyByName(emb.spec.root.name, sim.model)
        self._pelvis = sim.plant.GetBodyByName(emb.key_bodies["pelvis"], sim.model)  # `info["root_xy"]`, every step
        self.part_slices: dict[str, slice] = dict(self._observer.part_slices)
        self._fall = FallCheck(sim.plant, sim.model, emb, height_fraction=termination_height)
        self.termination_height = self._fall.min_pelvis_height
        self._playbacks = [ClipPlayback(c, loop=False) for c in self.clips]
        self._joint_playbacks = [ClipPlayback(c, loop) for c, loop in zip(self.clips, self.loops)]  # `reference_pose`
        self._joints = actuated_state_indices(sim.plant, sim.model, emb.joint_names)
        n = len(emb.joint_names)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (n,), np.float32)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (self._observation_size(),), np.float32)
        self._history: deque = deque(maxlen=amp_history)
        self._standing_action = standing_action(emb)
        # Scratch contexts of the plant and the observation system, for AMP frames of clip states.
        self._scratch_plant = sim.plant.CreateDefaultContext()
        self._scratch_observer = self._observer.CreateDefaultContext()
        self.timings = EnvTimings()
        self.init_kind = "default"
        # The teacher: a whole-body controller per reference clip (None: the standing pose), built when first
        # asked for. The episode's clip (None after a default start), its clip time at the start, and where the
        # clip's frame sits in the world: the teacher's and the phase's.
        self._teachers: dict = {}
        self._episode_clip: int | None = None
        self._episode_start = 0.0
        self._episode_frame = RigidTransform()

    # -- what subclasses extend ------------------------------------------------

    def _extras(self) -> tuple[str, ...]:
        """What the observation has after the robot's (`systems.motion_reference.EXTRAS`, in order)."""
        return tuple(extra for extra in EXTRAS if getattr(self, f"{extra}_observation"))

    def _observation_size(self) -> int:
        return self._observer.observation_size + sum(extra_size(extra, self.embodiment) for extra in self._extras())

    def _extra_observation(self) -> np.ndarray:
        made = {"phase": self.clip_phase, "reference": self.reference_features, "pose": self.reference_pose}
        return np.concatenate([np.zeros(0), *(made[extra]() for extra in self._extras())])

    def _place_task(self) -> None:
        """Put task objects at their episode's start (subclasses)."""

    def _task_reward(self, info: dict) -> float:
        return 0.0

    # -- gymnasium API ---------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = self._check_reset_options(options or {})
        context = self._context
        self.sim.diagram.SetDefaultContext(context)
        context.SetTime(0.0)
        kind = options.get("init")
        if kind is None:
            if {"clip", "time"} & options.keys():
                kind = "reference"
            else:
                kind = "reference" if self.np_random.random() < self.reference_init_probability else "default"
        history = None
        self._episode_clip, self._episode_start, self._episode_frame = None, 0.0, RigidTransform()
        if kind == "reference":
            index = options.get("clip", self._draw_clip())
            clip = self.clips[index]
            start, drop = options.get("time", self.reference_start_time), 0.0
            if start is None:
                start = float(self.np_random.uniform(0.0, max(clip.duration - 0.1, 0.0)))
            elif "time" not in options:  # from the fixed start, dropped as a standing start is
                drop = float(self.np_random.uniform(0.0, self.drop_height))
            start = min(float(start), clip.duration)
            self._set_reference_state(self._playbacks[index], start, drop)
            self._episode_clip, self._episode_start = index, start
            self._episode_frame = alignment(self._playbacks[index], start)
            # The AMP history before the start is the clip's own past frames.
            past = start - self.control_period * np.arange(self.amp_history - 1, 0, -1)
            history = [self.clip_amp_frame(index, t) for t in past]
        else:
            self._set_default_state(float(self.np_random.uniform(0.0, self.drop_height)))
            if self.standing_follow and self.clips:
                index = options.get("clip", self._draw_clip())
                start = min(float(options.get("time", self.reference_start_time or 0.0)), self.clips[index].duration)
                root = self.sim.plant.EvalBodyPoseInWorld(self._plant_context, self._root)
                self._episode_clip, self._episode_start = index, start
                self._episode_frame = placed_under(root, alignment(self._playbacks[index], start))
        self.init_kind = kind
        if self._episode_clip is not None:
            self.clip_episodes[self._episode_clip] += 1
        if self.teacher:
            self._teacher().reset()
        self._place_objects()
        self._place_task()
        self._action_port.FixValue(context, self._standing_action)
        self.sim.simulator.Initialize()
        amp = self._amp_port.Eval(context).copy()
        self._history.clear()
        self._history.extend(history or [amp] * (self.amp_history - 1))
        self._history.append(amp)
        self._last = (self._observe(), self._info(terminated=False))
        return self._last

    def _draw_clip(self) -> int:
        """An episode's clip: evenly, or by `clip_weights` of this environment's falls."""
        if self.clip_sampling == "uniform":
            return int(self.np_random.integers(len(self.clips)))
        return int(self.np_random.choice(len(self.clips), p=clip_weights(self.clip_falls, self.clip_episodes)))

    def _check_reset_options(self, options: dict) -> dict:
        """`init` ('reference' or 'default'; a `clip` or `time` alone means
        'reference'), and for a start on a clip (a reference start, or a
        default one with `standing_follow`) the `clip` index and the `time`
        (s) in it; `InputError` otherwise."""
        where = f"{type(self).__name__}.reset"
        if not isinstance(options, dict):
            raise InputError(f"{options!r} is not a dict", where, "options")
        unknown = sorted(set(options) - {"init", "clip", "time"})
        if unknown:
            raise InputError(f"unknown option(s) {', '.join(map(repr, unknown))} (known: init, clip, time)", where)
        if "init" in options:
            check_choice(options["init"], "options['init']", ("reference", "default"), where)
        chosen = {"clip", "time"} & options.keys()
        if options.get("init") == "default" and chosen and not self.standing_follow:
            raise InputError(
                "a default start follows no clip unless the env has standing_follow=True", where, "options['clip']"
            )
        if (options.get("init") == "reference" or chosen) and not self.clips:
            raise InputError("a start on a clip needs reference clips (the env has none)", where, "options['init']")
        if "clip" in options:
            high = len(self.clips) - 1
            check_number(options["clip"], "options['clip']", where, low=0, high=high, integer=True)
        if "time" in options:
            clip = (
                self.clips[int(options.get("clip", 0))]
                if "clip" in options
                else min(self.clips, key=lambda c: c.duration)
            )
            check_number(options["time"], "options['time']", where, low=0.0, high=clip.duration, unit="s")
        return options

    def step(self, action):
        start = time.perf_counter()
        try:
            action = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(
                f"not an array of {self.action_space.shape[0]} numbers", type(self).__name__, "action"
            ) from None
        if action.shape != self.action_space.shape or not np.all(np.isfinite(action)):
            raise InputError(
                f"must be {self.action_space.shape[0]} finite numbers, got shape {action.shape}",
                type(self).__name__,
                "action",
            )
        self._action_port.FixValue(self._context, np.clip(action, -1.0, 1.0))
        target = self._context.get_time() + self.control_period
        try:
            tick = time.perf_counter()
            self._advance_to(target)
            self.timings.physics += time.perf_counter() - tick
            tick = time.perf_counter()
            observation = self._observe()
            self.timings.observation += time.perf_counter() - tick
            tick = time.perf_counter()
            amp = self._amp_port.Eval(self._context).copy()
            self.timings.amp_observation += time.perf_counter() - tick
            if not np.isfinite(observation).all():  # the AMP frame is drawn from the same features
                raise FloatingPointError("the state diverged (non-finite observation)")
            self._history.append(amp)
            terminated = self._fell()
            if terminated and self._episode_clip is not None:
                self.clip_falls[self._episode_clip] += 1
            info = self._info(terminated)
            reward = self._task_reward(info)
        except (RuntimeError, FloatingPointError) as error:  # Drake reports solver failures as RuntimeError
            return self._truncate_after_failure(error, target)
        self._last = (observation, info)
        self.timings.steps += 1
        self.timings.total += time.perf_counter() - start
        return observation, float(reward), bool(terminated), False, info

    def clip_times(self, clip_index: int) -> np.ndarray:
        """Reference clip `clip_index`'s frames at the control rate: 0, one
        control period, ... up to its duration (the demonstrations' times)."""
        period = self.control_period
        return np.arange(int(np.floor(self.clips[clip_index].duration / period + 1e-9)) + 1) * period

    def clip_amp_frame(self, clip_index: int, time_: float) -> np.ndarray:
        """The AMP frame of reference clip `clip_index` at `time_` (clamped to
        the clip), aligned as reference starts are; for the history at a
        reference start and for the discriminators' demonstration frames."""
        sim = self.sim
        playback = self._playbacks[clip_index]
        set_robot_state(sim.plant, self._scratch_plant, sim.model, self.embodiment, playback, time_, align=True)
        self._observer.fix_inputs_from_plant(self._scratch_observer, sim.plant, self._scratch_plant, sim.model)
        return self._observer.GetOutputPort("amp_observation").Eval(self._scratch_observer).copy()

    def clip_observation(self, clip_index: int, time_: float) -> np.ndarray:
        """The policy observation at reference clip `clip_index`'s state at
        `time_`, aligned as reference starts are (for behavior cloning)."""
        self.clip_amp_frame(clip_index, time_)  # sets the scratch contexts to that state
        robot = self._observer.GetOutputPort("observation").Eval(self._scratch_observer)
        extra = self._extra_observation()  # a task's goal after the extras stays the episode's
        on_clip = {  # each extra at the clip's state: its phase then, not the episode's; nothing off its own
            "phase": lambda: self._phase_at(clip_index, time_),
            "reference": self._features_on_reference,  # but where its own feet are
            "pose": lambda: np.zeros(extra_size("pose", self.embodiment)),
        }
        at = 0
        for name in self._extras():
            size = extra_size(name, self.embodiment)
            extra[at : at + size] = on_clip[name]()
            at += size
        return np.concatenate([robot, extra]).astype(np.float32)

    def _features_on_reference(self) -> np.ndarray:
        """`reference_features` of the state in the scratch context against itself."""
        plant, scratch, model = self.sim.plant, self._scratch_plant, [self.sim.model]
        root = plant.EvalBodyPoseInWorld(scratch, self._root)
        com = plant.CalcCenterOfMassPositionInWorld(scratch, model)
        velocity = plant.CalcCenterOfMassTranslationalVelocityInWorld(scratch, model)
        feet = None
        if self._has_feet():
            bodies = [plant.GetBodyByName(self.embodiment.key_bodies[f"{s}_foot"], model[0]) for s in ("left", "right")]
            feet = [plant.EvalBodyPoseInWorld(scratch, body).translation() for body in bodies]
        return reference_features(root, com, velocity, root, com, velocity, feet, RigidTransform(), np.zeros(3))

    def amp_layout(self) -> dict[str, list[str]]:
        """The column labels of each key of `info["amp"]` (`learning.parts.AmpLayout`)."""
        return {key: list(labels) for key, labels in self._observer.amp_labels.items()}

    def joint_position_columns(self) -> np.ndarray:
        """The observation's columns holding the joint positions, in joint order."""
        return self._observer.joint_position_columns.copy()

    def _truncate_after_failure(self, error: Exception, when: float):
        """End the episode as truncated, returning the last good observation and info."""
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        log.warning("%s: simulation failed at t=%.3f s (%s); episode truncated", self.spec_id, when, reason)
        observation, info = self._last
        info = dict(info, simulation_failure=reason)
        return observation, 0.0, False, True, info

    # -- internals -------------------------------------------------------------

    @property
    def spec_id(self) -> str:
        return self.spec.id if self.spec is not None else type(self).__name__

    def _advance_to(self, time_: float) -> None:
        self.sim.simulator.AdvanceTo(time_)

    def standing_action(self) -> np.ndarray:
        """The action that holds the standing pose."""
        return self._standing_action.copy()

    def _set_default_state(self, drop: float) -> None:
        sim = self.sim
        set_robot_state(sim.plant, self._plant_context, sim.model, self.embodiment, drop_height=drop)

    def _set_reference_state(self, playback: ClipPlayback, time_: float, drop: float = 0.0) -> None:
        """The clip's state at `time_`, aligned, `drop` (m) above it (a floating base)."""
        sim = self.sim
        set_robot_state(sim.plant, self._plant_context, sim.model, self.embodiment, playback, time_, align=True)
        if drop > 0.0 and self.embodiment.floating_base and not self.scenario.fixed_base:
            pose = sim.plant.GetFreeBodyPose(self._plant_context, self._root)
            sim.plant.SetFreeBodyPose(self._plant_context, self._root, RigidTransform([0.0, 0.0, drop]) @ pose)

    def _place_objects(self) -> None:
        """Free objects back at their configured poses (tasks then draw theirs)."""
        place_objects(self.sim.plant, self._plant_context, self.sim.objects, self.scenario.objects)

    def _observe(self) -> np.ndarray:
        robot = self._observation_port.Eval(self._context)
        return np.concatenate([robot, self._extra_observation()]).astype(np.float32)

    def _info(self, terminated: bool) -> dict:
        frames = np.asarray(self._history, dtype=np.float32)
        amp = {part: frames[:, s] for part, s in self.part_slices.items()}
        info = {"amp": amp, "time": self._context.get_time(), "init": self.init_kind}
        info["root_xy"] = self.sim.plant.EvalBodyPoseInWorld(self._plant_context, self._pelvis).translation()[:2]
        if self.teacher:
            info["teacher_action"] = self.teacher_action().astype(np.float32)
            reference = self._teacher().plan.root_position(self._clip_time())  # in the clip's frame
            info["reference_root_xy"] = (self._episode_frame @ reference)[:2]
        return info

    def _clip_time(self) -> float:
        """The episode's clip time now (after a default start, the time since it)."""
        return self._episode_start + self._context.get_time()

    # -- the teacher -----------------------------------------------------------

    def _teacher(self):
        """The whole-body controller of the episode's clip (the standing pose
        after a default start); for a robot with fingers, solved without them
        (`systems.fingerless_teacher`: the same grasps held, at less than half the cost)."""
        from hotu_drake.control.clip_plan import standing_clip
        from hotu_drake.systems.fingerless_teacher import FingerlessTeacher, has_fingers
        from hotu_drake.systems.whole_body import WholeBodyController

        key = self._episode_clip
        if key not in self._teachers:
            clip = self.clips[key] if key is not None else standing_clip(self.embodiment)
            step = self.scenario.time_step
            loop = key is not None and self.loops[key]
            if has_fingers(self.embodiment):
                self._teachers[key] = FingerlessTeacher(self.embodiment, clip, self.control_period, loop, step)
            else:
                self._teachers[key] = WholeBodyController(
                    self.embodiment, clip, self.control_period, loop, None, 0.0, step
                )
        return self._teachers[key]

    def teacher_action(self) -> np.ndarray:
        """The whole-body controller's action (normalised PD targets, a
        policy's) for the robot's state now and the reference's time now:
        the episode's clip from where a reference start began it (the
        standing pose after a default start), the state taken into the
        clip's own frame (a reference start turns and moves the clip to
        start at the origin facing +x). The controller carries its warm
        start and footing from one call to the next within an episode, as
        it would running in the loop, so ask once per step."""
        plant, model, scratch = self.sim.plant, self.sim.model, self._scratch_plant
        plant.SetPositionsAndVelocities(scratch, model, plant.GetPositionsAndVelocities(self._plant_context, model))
        if self.embodiment.floating_base and not self.scenario.fixed_base:
            move_free_body(plant, scratch, self._root, self._episode_frame.inverse())
        state = plant.GetPositionsAndVelocities(scratch, model)
        return self._teacher().act(state, self._clip_time())

    def _has_feet(self) -> bool:
        return all(f"{side}_foot" in self.embodiment.key_bodies for side in ("left", "right"))

    def reference_features(self) -> np.ndarray:
        """Where the teacher's reference is against the robot now
        (`systems.motion_reference.reference_features`), at the episode's
        clip time, where the teacher tracks it (its `footing_shift` as it
        was after the last step): what the teacher's action depends on
        besides the robot's own state and the phase."""
        teacher = self._teacher()
        plan, reference, clip_plant = teacher.plan, teacher.reference_context, teacher.plant
        time_ = self._clip_time()
        plan.set_reference(reference, time_)
        plant, context, model = self.sim.plant, self._plant_context, [self.sim.model]
        com, com_velocity, _ = plan.com_reference(time_)
        return reference_features(
            plant.EvalBodyPoseInWorld(context, self._root),
            plant.CalcCenterOfMassPositionInWorld(context, model),
            plant.CalcCenterOfMassTranslationalVelocityInWorld(context, model),
            clip_plant.EvalBodyPoseInWorld(reference, plan.root_body),
            com,
            com_velocity,
            plan.feet_positions(reference),
            self._episode_frame,
            teacher.footing_shift,
        )

    def reference_pose(self) -> np.ndarray:
        """The episode's clip's joint positions and velocities at its clip
        time now less the robot's (`systems.motion_reference.pose_features`;
        zeros after a default start)."""
        if self._episode_clip is None:
            return np.zeros(extra_size("pose", self.embodiment))
        state = self.sim.plant.GetPositionsAndVelocities(self._plant_context, self.sim.model)
        reference = self._joint_playbacks[self._episode_clip].joints_at(self._clip_time())
        return pose_features(reference, state[self._joints[0]], state[self._joints[1]])

    def clip_phase(self) -> np.ndarray:
        """Where the episode is in its clip now, as the sine and cosine of an
        angle: a looped clip's share of its cycle times 2 pi, another's share
        of its duration times pi (so its start and end differ). Zeros after a
        default start (no clip)."""
        if self._episode_clip is None:
            return np.zeros(PHASE_SIZE)
        return self._phase_at(self._episode_clip, self._clip_time())

    def _phase_at(self, clip_index: int, clip_time: float) -> np.ndarray:
        return clip_phase(clip_time, self.clips[clip_index].duration, self.loops[clip_index])

    def pelvis_height(self) -> float:
        return self._fall.pelvis_height(self._plant_context)

    def body_position(self, key_body: str) -> np.ndarray:
        """A key body's (`embodiment.key_bodies`: pelvis, hands, feet) position in the world now."""
        body = self.sim.plant.GetBodyByName(self.embodiment.key_bodies[key_body], self.sim.model)
        return self.sim.plant.EvalBodyPoseInWorld(self._plant_context, body).translation().copy()

    def _fell(self) -> bool:
        return self._fall(self._plant_context)
