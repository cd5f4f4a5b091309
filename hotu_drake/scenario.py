"""Scenarios: a complete, named diagram described in YAML (`systems/*.yaml`).

Loaded with Drake's `yaml_load_typed` into the dataclasses below, in the
manner of RussTedrake/manipulation's `station.py`: Drake's own configs are
embedded where they exist (`MultibodyPlantConfig`, `VisualizationConfig`),
and what drives the PD targets is one field, `driver`, a union of small
dataclasses chosen with a YAML tag (`driver: !ReferenceTracking {motion:
walk}`). `diagrams.build_simulation` turns a `Scenario` into a running
diagram. Every field has a default, so a scenario names only what differs.

A scenario file holds one scenario, or several by name (a catalogue: every
top-level key not starting with `_` is a scenario; YAML anchors and merge
keys `<<: *defaults` share what they have in common). The shipped
catalogues in `systems/` are found by scenario name (`stand_h1`). Files in
the layout of hotu_drake 0.1 (`plant:`, `reference:`, `policy:` sections)
still load; `LEGACY_FIELDS` says where each of their fields went.
"""

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from pathlib import Path

from pydrake.common.yaml import yaml_dump, yaml_dump_typed, yaml_load, yaml_load_typed
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.visualization import VisualizationConfig

from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.errors import InputError, check_bool, check_choice, check_number, check_vector
from hotu_drake.motion.library import is_library_motion
from hotu_drake.objects import OBJECTS, SceneObject
from hotu_drake.resources import systems_dir
from hotu_drake.systems.perturbation import CubeLaunch

CONTROLLERS = ("implicit", "explicit")
APPROXIMATIONS = ("sap", "lagged", "similar")  # Drake's discrete approximations (TAMSI is gone from newer Drake)
CONTACT_MODELS = ("point", "hydroelastic", "hydroelastic_with_fallback")
SURFACES = ("triangle", "polygon")
# Ranges of a scenario's numbers: what a humanoid simulation can use.
LIMITS: dict[str, dict] = {
    "time_step": {"low": 1e-5, "high": 0.05, "unit": "s"},  # above 50 ms contact is not resolved at all
    "sap_near_rigid_threshold": {"low": 0.0, "high": 1.0},
    "penetration_allowance": {"low": 0.0, "high": 0.1, "low_open": True, "unit": "m"},
    "stiction_tolerance": {"low": 0.0, "high": 1.0, "low_open": True, "unit": "m/s"},
    "control_rate": {"low": 1.0, "high": 1000.0, "unit": "Hz"},
    "duration": {"low": 0.0, "high": 3600.0, "low_open": True, "unit": "s"},
    "publish_period": {"low": 1e-3, "high": 1.0, "unit": "s"},
    "drop_height": {"low": 0.0, "high": 2.0, "unit": "m"},  # a fall from higher breaks any humanoid
    "position": {"high": 100.0},  # m from the origin, any axis
    "cube_speed": {"low": 0.0, "high": 50.0, "low_open": True, "unit": "m/s"},
    "cube_mass": {"low": 0.0, "high": 100.0, "low_open": True, "unit": "kg"},
    "cube_size": {"low": 0.01, "high": 1.0, "unit": "m"},
    "cube_aim_height": {"low": -3.0, "high": 3.0, "unit": "m"},
}
MAX_LEAD_IN = 10.0  # s: the longest a `!WholeBodyTracking` clip's first frame is held before it
MAX_PLANT_STEPS = 5e6  # per run: about an hour of a humanoid at 1 ms, hours of wall clock


# --- what drives the PD targets ------------------------------------------------------


@dataclass
class StandingPose:
    """The PD holds the embodiment's standing pose."""


@dataclass
class ReferenceTracking:
    """The PD tracks a reference motion: a motion of the generated library
    (e.g. `walk`), retargeted onto the scenario's embodiment when the
    diagram is built, or a path to a `.npz` clip of that embodiment
    (relative to the scenario file); looping or holding its last frame."""

    motion: str = "walk"
    loop: bool = True


LATENT_CHOICES = ("prior", "zero")  # `PolicyCheckpoint.latents` besides a motion


@dataclass
class PolicyCheckpoint:
    """A policy checkpoint (written by `python -m hotu_drake.train`) sets the
    PD targets at the scenario's `control_rate`, from the ObservationSystem.
    Its latents are drawn from the prior it was trained with (`prior`,
    seeded by `latent_seed`) or held at zero (`zero`). A controller that
    follows a clip (a clone that observes its phase, or its reference:
    `systems.motion_reference`) is asked for one of its motions by name
    (`walk`, or a `.npz` clip of the embodiment), followed from where the
    robot starts. Paths relative to the scenario file."""

    checkpoint: str = ""
    latents: str = "prior"
    latent_seed: int = 0


@dataclass
class SkillCheckpoint:
    """A skill learned by `python -m hotu_drake.train skill`: its high level
    (`skill`, the run's `policy.pt`) chooses the latents of the frozen
    behavior controller (`llc`, that run's `policy.pt`), which sets the PD
    targets at the scenario's `control_rate`. Needs a task object (a box or
    a drill) in `objects`, with its `target`. A layer fine-tuned by
    `train finetune` also takes its `reference` (a `.npz` clip of the robot,
    one of the run's `references/`), which it tracks from t = 0. Paths
    relative to the scenario file."""

    skill: str = ""
    llc: str = ""
    reference: str = ""


@dataclass
class ActionInput:
    """Normalised PD targets come from the diagram's exported `action`
    input port (how an environment drives the diagram); it holds the
    standing action until set."""


@dataclass
class BaseTwist:
    """Planar-base robots (CURI): the exported `twist` input (vx, vy in the
    base frame, yaw rate) moves the base; every other joint holds the
    standing pose. It drives the built-in PD (implicit controller)."""


@dataclass
class WholeBodyTracking:
    """The whole-body controller (`systems.whole_body.WholeBodyController`)
    performs a reference motion: a library motion retargeted onto the
    scenario's embodiment, or a `.npz` clip of it (as `!ReferenceTracking`
    takes), looping with its root motion or holding its end. It solves its
    QP at the scenario's `control_rate` and drives the built-in PD
    (controller: implicit). A clip that does not loop, started from its
    first frame, is held there `lead_in` s before it moves (negative: as
    long as the robot needs, `control.clip_plan.lead_in_for`); the
    scenario's time counts from the start of the hold."""

    motion: str = "walk"
    loop: bool = True
    lead_in: float = -1.0


Driver = (
    StandingPose | ReferenceTracking | PolicyCheckpoint | SkillCheckpoint | ActionInput | BaseTwist | WholeBodyTracking
)


# --- the scenario --------------------------------------------------------------------


@dataclass
class InitialCondition:
    """Where the run starts: the standing pose dropped from `drop_height`
    above standing height, or, when `reference_time` is set (>= 0), the
    state of a reference motion at that time (reference state
    initialisation): `motion`, else the tracked one. On a fixed base
    `drop_height` lifts the weld."""

    drop_height: float = 0.1
    reference_time: float = -1.0
    motion: str = ""


# Chosen with `python -m hotu_drake.bench fidelity` (BENCHMARKS.md): with SAP's
# near-rigid threshold at 0.1 (Drake's default of 1.0 softens contact: every
# legged robot falls standing at 1/90 s and coarser), a 1/60 s step keeps the
# pelvis, head, hands and feet of every legged robot within 7.3 mm of a
# 1/1440 s reference while standing, squatting and being pushed, with no
# fall, at 3-4 times the speed of 1/180 s.
DEFAULT_TIME_STEP = 1.0 / 60.0
DEFAULT_NEAR_RIGID_THRESHOLD = 0.1


def default_plant_config() -> MultibodyPlantConfig:
    """SAP at `DEFAULT_TIME_STEP` with point contact and the near-rigid
    threshold at `DEFAULT_NEAR_RIGID_THRESHOLD`; output ports computed when
    read (Drake's sampled output ports copy the contact results and poses
    into the state at every step, and most steps read neither: 10-15% faster)."""
    return MultibodyPlantConfig(
        time_step=DEFAULT_TIME_STEP,
        discrete_contact_approximation="sap",
        contact_model="point",
        sap_near_rigid_threshold=DEFAULT_NEAR_RIGID_THRESHOLD,
        use_sampled_output_ports=False,
    )


def default_visualization() -> VisualizationConfig:
    """Illustration geometry at 30 Hz; collision geometry, contact forces
    and inertia on request (`publish_proximity`, `publish_contacts`,
    `publish_inertia`)."""
    return VisualizationConfig(
        publish_period=1.0 / 30.0, publish_proximity=False, publish_contacts=False, publish_inertia=False
    )


@dataclass
class Variation:
    """What a scenario draws at random from its `seed` (`simulate --seed N`
    sets it), so one scenario is a family to evaluate over many seeds: each
    [low, high] range uniformly, `push_speed` for every thrown cube, `task`
    the task object's start and target from its task's own distribution
    (`BoxCarry-v0`'s or `DrillGrasp-v0`'s, as the environment draws them);
    a policy's latent draws follow the seed too. The draws come from one
    generator in the fields' order (a field added to `vary` changes the
    draws of those after it). Empty ranges and no `task` draw nothing:
    the scenario as written."""

    drop_height: list[float] = field(default_factory=list)
    reference_time: list[float] = field(default_factory=list)
    push_speed: list[float] = field(default_factory=list)
    task: bool = False


@dataclass
class Scenario:
    """An embodiment on the floor (or on a fixed base) under PD control,
    driven by `driver`; with optional task objects, thrown cubes and the
    pipeline's observation and interaction-graph systems in the loop.

    `controller`: `implicit` uses the plant's built-in PD (stable at 5 ms);
    `explicit` a SaturatedPdController on the actuation input (needs about
    0.5 ms). `control_rate` is the rate of a policy and of the environment's
    actions, and the period of event-driven checks (held objects).
    `observation` adds the ObservationSystem even without a policy (its
    outputs are exported for monitoring and learning)."""

    embodiment: str = "h1"
    hands: str = "none"
    fixed_base: bool = False
    plant_config: MultibodyPlantConfig = field(default_factory=default_plant_config)
    self_collision: bool = True
    controller: str = "implicit"
    control_rate: float = 30.0
    initial: InitialCondition = field(default_factory=InitialCondition)
    driver: Driver = field(default_factory=StandingPose)
    observation: bool = False
    objects: list[SceneObject] = field(default_factory=list)
    perturbations: list[CubeLaunch] = field(default_factory=list)
    visualization: VisualizationConfig = field(default_factory=default_visualization)
    duration: float = 5.0
    seed: int = 0
    vary: Variation = field(default_factory=Variation)
    # Set by `load_scenario`: the folder relative paths are resolved in, and
    # where the scenario came from (named in errors found when it is built).
    base_dir: str = ""
    source: str = ""

    @property
    def time_step(self) -> float:
        return self.plant_config.time_step

    @property
    def followed_motion(self) -> str:
        """The motion the driver tracks or follows ("" for none): a tracking
        driver's, or the one a clip-following policy is asked for."""
        if isinstance(self.driver, ReferenceTracking | WholeBodyTracking):
            return self.driver.motion
        if isinstance(self.driver, PolicyCheckpoint) and self.driver.latents not in LATENT_CHOICES:
            return self.driver.latents
        return ""

    @property
    def reference_motion(self) -> str:
        """The motion this scenario tracks or starts from ("" for none)."""
        return self.initial.motion or self.followed_motion

    def resolve(self, path: str) -> Path:
        """A path from the scenario file, relative to the file's folder."""
        p = Path(path).expanduser()
        return p if p.is_absolute() or not self.base_dir else Path(self.base_dir) / p

    def validate(self, source: str = "scenario") -> None:
        """Raise `InputError` naming `source` and the field for the first bad
        value: unknown names, non-finite numbers, values outside the ranges
        of `LIMITS` (physically motivated), and runs too long to simulate."""
        check_choice(self.embodiment, "embodiment", EMBODIMENT_NAMES, source)
        check_choice(self.hands, "hands", HANDS_VARIANTS, source)
        check_choice(self.controller, "controller", CONTROLLERS, source)
        for name in ("fixed_base", "self_collision", "observation"):
            check_bool(getattr(self, name), name, source)
        pc = self.plant_config
        check_choice(
            pc.discrete_contact_approximation, "plant_config.discrete_contact_approximation", APPROXIMATIONS, source
        )
        check_choice(pc.contact_model, "plant_config.contact_model", CONTACT_MODELS, source)
        check_choice(pc.contact_surface_representation, "plant_config.contact_surface_representation", SURFACES, source)
        for name in ("time_step", "sap_near_rigid_threshold", "penetration_allowance", "stiction_tolerance"):
            check_number(getattr(pc, name), f"plant_config.{name}", source, **LIMITS[name])
        for name in ("control_rate", "duration"):
            check_number(getattr(self, name), name, source, **LIMITS[name])
        check_number(
            self.visualization.publish_period, "visualization.publish_period", source, **LIMITS["publish_period"]
        )
        check_number(self.initial.drop_height, "initial.drop_height", source, **LIMITS["drop_height"])
        reference_time = check_number(self.initial.reference_time, "initial.reference_time", source, low=-1.0)
        if -1.0 < reference_time < 0.0:
            raise InputError(
                f"{reference_time:g} s: give a time >= 0, or -1 for no reference start",
                source,
                "initial.reference_time",
            )
        steps = self.duration / self.time_step
        if steps > MAX_PLANT_STEPS:
            raise InputError(
                f"{self.duration:g} s at {self.time_step:g} s a step is {steps:.3g} plant steps; at most "
                f"{MAX_PLANT_STEPS:.0e} in one run (shorten it or take a larger step)",
                source,
                "duration",
            )
        if isinstance(self.driver, ReferenceTracking | WholeBodyTracking) and not self.driver.motion:
            raise InputError(f"!{type(self.driver).__name__} needs a motion", source, "driver.motion")
        if isinstance(self.driver, WholeBodyTracking):
            if self.controller != "implicit":
                raise InputError("!WholeBodyTracking drives the built-in PD (controller: implicit)", source, "driver")
            if self.fixed_base:
                raise InputError(
                    "!WholeBodyTracking stands the robot on its feet: not on a fixed base", source, "fixed_base"
                )
            if self.initial.reference_time < 0:
                raise InputError(
                    "!WholeBodyTracking starts the robot on its clip: give initial.reference_time >= 0",
                    source,
                    "initial.reference_time",
                )
            if not math.isfinite(self.driver.lead_in) or self.driver.lead_in > MAX_LEAD_IN:
                raise InputError(
                    f"lead_in {self.driver.lead_in:g} s: give at most {MAX_LEAD_IN:g} s (negative: as the robot needs)",
                    source,
                    "driver.lead_in",
                )
            starts_later = self.initial.reference_time != 0.0 or bool(self.vary.reference_time)
            if self.driver.lead_in > 0.0 and (self.driver.loop or starts_later):
                raise InputError(
                    "lead_in holds a clip's first frame: give it for a clip that does not loop (loop: false), "
                    "started at its first frame (initial.reference_time 0, no vary.reference_time)",
                    source,
                    "driver.lead_in",
                )
        followed = self.followed_motion
        if self.initial.motion and followed and self.initial.motion != followed:
            raise InputError(
                f"starts on {self.initial.motion!r} but its driver follows {followed!r}: give one motion "
                "(or leave initial.motion out: a reference start is on the followed motion)",
                source,
                "initial.motion",
            )
        if self.initial.reference_time >= 0 and not self.reference_motion:
            raise InputError(
                "needs a reference motion (initial.motion or driver !ReferenceTracking)",
                source,
                "initial.reference_time",
            )
        if isinstance(self.driver, PolicyCheckpoint):
            if not self.resolve(self.driver.checkpoint).is_file():
                raise InputError(f"policy checkpoint {self.driver.checkpoint!r} not found", source, "driver.checkpoint")
            latents = self.driver.latents
            if latents not in LATENT_CHOICES and not is_library_motion(latents) and not str(latents).endswith(".npz"):
                raise InputError(
                    f"{latents!r} is not one of {', '.join(LATENT_CHOICES)}, nor a library motion or .npz clip",
                    source,
                    "driver.latents",
                )
            check_number(self.driver.latent_seed, "driver.latent_seed", source, low=0, high=2**31 - 1, integer=True)
        if isinstance(self.driver, SkillCheckpoint):
            for name in ("skill", "llc"):
                path = getattr(self.driver, name)
                if not path or not self.resolve(path).is_file():
                    raise InputError(f"{name} checkpoint {path!r} not found", source, f"driver.{name}")
            if not any(o.is_task_object for o in self.objects):
                raise InputError("!SkillCheckpoint needs a task object (a free box or drill)", source, "objects")
        if isinstance(self.driver, BaseTwist) and self.controller != "implicit":
            raise InputError("!BaseTwist drives the built-in PD (controller: implicit)", source, "driver")
        names = [o.instance_name for o in self.objects]
        if len(set(names)) != len(names):
            raise InputError(f"two objects share the name '{max(names, key=names.count)}'", source, "objects")
        for i, obj in enumerate(self.objects):
            field_ = f"objects[{i}]"
            check_choice(obj.kind, f"{field_}.kind", OBJECTS, source)
            check_vector(obj.position, f"{field_}.position", source, bound=LIMITS["position"]["high"], unit="m")
            if obj.target:
                check_vector(obj.target, f"{field_}.target", source, bound=LIMITS["position"]["high"], unit="m")
            check_number(obj.yaw, f"{field_}.yaw", source, low=-10.0, high=10.0, unit="rad")
            if obj.fixed and obj.held:
                raise InputError(f"object '{obj.instance_name}' cannot be both fixed and held", source, field_)
        check_number(self.seed, "seed", source, low=0, high=2**31 - 1, integer=True)
        bounds = {
            "drop_height": LIMITS["drop_height"],
            "reference_time": {"low": 0.0},
            "push_speed": LIMITS["cube_speed"],
        }
        for name, limits in bounds.items():
            span = getattr(self.vary, name)
            if span and (len(span) != 2 or span[0] > span[1]):
                raise InputError(f"give [low, high] with low <= high, not {span}", source, f"vary.{name}")
            for value in span:
                check_number(value, f"vary.{name}", source, **limits)
        if self.vary.reference_time and not self.reference_motion:
            raise InputError("vary.reference_time draws a start on a reference motion: give one", source, "vary")
        if self.vary.push_speed and not self.perturbations:
            raise InputError("vary.push_speed draws the thrown cubes' speed: add perturbations", source, "vary")
        check_bool(self.vary.task, "vary.task", source)
        if self.vary.task and not any(o.is_task_object for o in self.objects):
            raise InputError("vary.task draws a task object's instance: add a free box or drill", source, "vary.task")
        for i, launch in enumerate(self.perturbations):
            field_ = f"perturbations[{i}]"
            check_vector(launch.start, f"{field_}.start", source, bound=LIMITS["position"]["high"], unit="m")
            check_number(launch.time, f"{field_}.time", source, low=0.0, high=self.duration, unit="s")
            for name in ("speed", "mass", "size", "aim_height"):
                check_number(getattr(launch, name), f"{field_}.{name}", source, **LIMITS[f"cube_{name}"])

    def drawn(self) -> tuple["Scenario", dict]:
        """The member of the scenario's family its `seed` picks (`vary`): a
        copy with the drawn values set, and those values by field name (empty
        when nothing varies)."""
        import copy

        import numpy as np

        out, values = copy.deepcopy(self), {}
        rng = np.random.default_rng(self.seed)
        if self.vary.drop_height:
            out.initial.drop_height = values["initial.drop_height"] = float(rng.uniform(*self.vary.drop_height))
        if self.vary.reference_time:
            out.initial.reference_time = float(rng.uniform(*self.vary.reference_time))
            values["initial.reference_time"] = out.initial.reference_time
        if self.vary.push_speed:
            for i, launch in enumerate(out.perturbations):
                launch.speed = values[f"perturbations[{i}].speed"] = float(rng.uniform(*self.vary.push_speed))
        if self.vary.task:
            from hotu_drake.motion.library.object_tasks import sample_box_carry, sample_drill_grasp

            obj = next(o for o in out.objects if o.is_task_object)
            task = (sample_box_carry if obj.kind == "box" else sample_drill_grasp)(rng)
            obj.position, obj.yaw, obj.target = list(task.start), task.start_yaw, list(task.target)
            values[f"{obj.instance_name}.start"] = [round(x, 4) for x in task.start]
            values[f"{obj.instance_name}.target"] = [round(x, 4) for x in task.target]
        if isinstance(out.driver, PolicyCheckpoint) and out.driver.latents == "prior" and self.seed:
            out.driver.latent_seed = values["driver.latent_seed"] = (self.driver.latent_seed + self.seed) % 2**31
        return out, {name: round(value, 4) if isinstance(value, float) else value for name, value in values.items()}

    def to_yaml(self) -> str:
        """The scenario as YAML (what `load_scenario` reads back)."""
        return yaml_dump_typed(self)

    def __reduce__(self):
        # Drake's config structs do not pickle; YAML carries the whole scenario
        # to worker processes.
        return (_scenario_from_yaml, (self.to_yaml(),))


def _scenario_from_yaml(text: str) -> Scenario:
    return yaml_load_typed(schema=Scenario, data=text)


# --- loading ---------------------------------------------------------------------------

# Fields of the hotu_drake 0.1 layout and where they went.
LEGACY_FIELDS = {
    "plant.time_step": "plant_config.time_step",
    "plant.discrete_contact_approximation": "plant_config.discrete_contact_approximation",
    "plant.contact_model": "plant_config.contact_model",
    "plant.sampled_output_ports": "plant_config.use_sampled_output_ports",
    "plant.self_collision": "self_collision",
    "plant.controller": "controller",
    "reference.motion, reference.loop": "driver: !ReferenceTracking {motion, loop} (or initial.motion with a policy)",
    "policy.checkpoint": "driver: !PolicyCheckpoint {checkpoint}",
    "policy.control_rate": "control_rate",
    "visualization.contact_forces": "visualization.publish_contacts",
    "visualization.collision_geometry": "visualization.publish_proximity",
}
_PLANT_CONFIG_NAMES = {"sampled_output_ports": "use_sampled_output_ports"}
_VISUALIZATION_NAMES = {"contact_forces": "publish_contacts", "collision_geometry": "publish_proximity"}


def _is_legacy(raw: dict) -> bool:
    visualization = raw.get("visualization") or {}
    return bool({"plant", "reference", "policy"} & raw.keys() or _VISUALIZATION_NAMES.keys() & visualization.keys())


def _upgrade_legacy(raw: dict) -> tuple[dict, Driver]:
    """A 0.1-layout scenario as the current layout, and its driver."""
    data = {k: v for k, v in raw.items() if k not in ("plant", "reference", "policy")}
    plant = dict(raw.get("plant") or {})
    for key in ("self_collision", "controller"):
        if key in plant:
            data[key] = plant.pop(key)
    if plant:
        data["plant_config"] = {_PLANT_CONFIG_NAMES.get(k, k): v for k, v in plant.items()}
    if "visualization" in raw:
        data["visualization"] = {_VISUALIZATION_NAMES.get(k, k): v for k, v in (raw["visualization"] or {}).items()}
    reference, policy = dict(raw.get("reference") or {}), dict(raw.get("policy") or {})
    if "control_rate" in policy:
        data["control_rate"] = policy.pop("control_rate")
    driver: Driver = StandingPose()
    if policy.get("checkpoint"):
        driver = PolicyCheckpoint(policy["checkpoint"])
        if reference.get("motion"):  # a policy starting from a reference state
            data.setdefault("initial", {})["motion"] = reference["motion"]
    elif reference.get("motion"):
        driver = ReferenceTracking(reference["motion"], bool(reference.get("loop", True)))
    return data, driver


def _mistyped(raw, default, prefix: str = "") -> tuple[str, object, str] | None:
    """(field, value, what it should be) of the first value in a raw scenario
    mapping that cannot fill the field of `default` it names, or None."""
    if not isinstance(raw, dict):
        return None
    hints = typing.get_type_hints(type(default)) if dataclasses.is_dataclass(default) else {}
    for key, value in raw.items():
        if str(key).startswith("_"):
            continue
        field, current = f"{prefix}{key}", getattr(default, str(key), None)
        if isinstance(current, bool):
            if not isinstance(value, bool):
                return field, value, "true or false"
        elif isinstance(current, int | float):
            if isinstance(value, bool) or not isinstance(value, int | float):
                return field, value, "a number"
        elif isinstance(current, str):
            if not isinstance(value, str):
                return field, value, "a name"
        elif isinstance(current, list):
            if not isinstance(value, list):
                return field, value, "a list"
            element = typing.get_args(hints.get(str(key), list))[:1]
            for i, item in enumerate(value):
                if element and dataclasses.is_dataclass(element[0]):
                    found = _mistyped(item, element[0](), f"{field}[{i}].")
                elif isinstance(item, bool) or not isinstance(item, int | float):
                    found = (f"{field}[{i}]", item, "a number")
                else:
                    found = None
                if found:
                    return found
        elif current is not None:
            if isinstance(value, dict) and "_tag" in value:  # a tagged union (the driver)
                kinds = {cls.__name__: cls for cls in typing.get_args(Driver)}
                current = kinds.get(str(value["_tag"]).lstrip("!"), type(current))()
            found = _mistyped(value, current, f"{field}.")
            if found:
                return found
    return None


def _scenario_fields() -> set[str]:
    return set(Scenario.__dataclass_fields__)


def _read_raw(path: Path) -> dict:
    try:
        raw = yaml_load(filename=str(path))
    except Exception as error:  # the YAML reader raises many kinds
        raise InputError(f"{path}: not valid YAML ({_first_line(error)})") from None
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise InputError(f"{path}: a scenario file holds a mapping of fields (or of named scenarios)")
    return raw


def _first_line(error: Exception) -> str:
    lines = str(error).strip().splitlines()
    return lines[0] if lines else type(error).__name__


def is_catalogue(raw: dict) -> bool:
    """Whether a file's top level names scenarios (rather than being one)."""
    return bool(raw) and not (raw.keys() & (_scenario_fields() | {"plant", "reference", "policy"}))


def catalogue_names(raw: dict) -> list[str]:
    return [name for name in raw if not str(name).startswith("_")]


def shipped_scenarios() -> dict[str, Path]:
    """Name -> file of every scenario shipped in `systems/`."""
    names = {}
    for path in sorted(systems_dir().glob("*.yaml")):
        raw = _read_raw(path)
        for name in catalogue_names(raw) if is_catalogue(raw) else [path.stem]:
            names[name] = path
    return names


def load_scenario(path: str | Path, name: str | None = None) -> Scenario:
    """Read a scenario: a file (one scenario, or a catalogue and the `name`
    of one of its entries), or the name of a shipped scenario. A bad file
    raises `InputError` naming it."""
    path = Path(path)
    if not path.is_file():
        shipped = shipped_scenarios()
        moved = path.suffix == ".yaml" and path.parent.resolve() == systems_dir().resolve()
        if name is None and (str(path) in shipped or (moved and path.stem in shipped)):
            # a shipped name, or the 0.1 file of a shipped scenario (now an entry of a catalogue)
            name = path.stem if moved else str(path)
            path = shipped[name]
        elif path.stem in shipped and path.suffix in ("", ".yaml"):
            raise InputError(
                f"{path}: no such scenario file; the shipped scenario '{path.stem}' lives in "
                f"{shipped[path.stem].name} (give its name: {path.stem})"
            )
        else:
            raise InputError(f"{path}: no such scenario file (nor the name of a shipped scenario)")
    raw = _read_raw(path)
    where = str(path)
    if is_catalogue(raw):
        names = catalogue_names(raw)
        if name is None and len(names) == 1:
            name = names[0]
        if name not in names:
            wanted = "give one of" if name is None else f"no scenario '{name}'; choose from"
            raise InputError(f"{path}: {wanted} {', '.join(names)}")
        raw, where = raw[name], f"{path} ({name})"
        if not isinstance(raw, dict):
            raise InputError(f"{where}: a scenario is a mapping of fields")
    elif name is not None and name != path.stem:
        raise InputError(f"{path}: holds one scenario, not a catalogue with '{name}'")
    try:
        if _is_legacy(raw):
            data, driver = _upgrade_legacy(raw)
            scenario = yaml_load_typed(schema=Scenario, data=yaml_dump(data), defaults=Scenario(driver=driver))
        else:
            scenario = yaml_load_typed(schema=Scenario, data=yaml_dump(raw))
    except Exception as error:  # the YAML reader raises many kinds
        found = _mistyped(raw, Scenario())
        if found is not None:
            field, value, kind = found
            raise InputError(f"{value!r} is not {kind}", where, field) from None
        raise InputError(f"{where}: not a valid scenario ({_first_line(error)})") from None
    scenario.base_dir = str(path.resolve().parent)
    scenario.source = where
    scenario.validate(where)
    return scenario
