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

import math
from dataclasses import dataclass, field
from pathlib import Path

from pydrake.common.yaml import yaml_dump, yaml_dump_typed, yaml_load, yaml_load_typed
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.visualization import VisualizationConfig

from hotu_drake.cli import UserError
from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.objects import OBJECTS, SceneObject
from hotu_drake.resources import systems_dir
from hotu_drake.systems.perturbation import CubeLaunch

CONTROLLERS = ("implicit", "explicit")


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


@dataclass
class PolicyCheckpoint:
    """A policy checkpoint (written by training) sets the PD targets at the
    scenario's `control_rate`, from the ObservationSystem; its skill latents
    are held at zero until skills are composed. A path relative to the
    scenario file."""

    checkpoint: str = ""


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


Driver = StandingPose | ReferenceTracking | PolicyCheckpoint | ActionInput | BaseTwist


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


def default_plant_config() -> MultibodyPlantConfig:
    """SAP at 5 ms with point contact; output ports computed when read
    (Drake's sampled output ports copy the contact results and poses into
    the state at every step, and most steps read neither: 10-15% faster)."""
    return MultibodyPlantConfig(
        time_step=0.005, discrete_contact_approximation="sap", contact_model="point", use_sampled_output_ports=False
    )


def default_visualization() -> VisualizationConfig:
    """Illustration geometry at 30 Hz; collision geometry, contact forces
    and inertia on request (`publish_proximity`, `publish_contacts`,
    `publish_inertia`)."""
    return VisualizationConfig(
        publish_period=1.0 / 30.0, publish_proximity=False, publish_contacts=False, publish_inertia=False
    )


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
    # Set by `load_scenario`: the folder relative paths are resolved in.
    base_dir: str = ""

    @property
    def time_step(self) -> float:
        return self.plant_config.time_step

    @property
    def reference_motion(self) -> str:
        """The motion this scenario tracks or starts from ("" for none)."""
        tracked = self.driver.motion if isinstance(self.driver, ReferenceTracking) else ""
        return self.initial.motion or tracked

    def resolve(self, path: str) -> Path:
        """A path from the scenario file, relative to the file's folder."""
        p = Path(path).expanduser()
        return p if p.is_absolute() or not self.base_dir else Path(self.base_dir) / p

    def validate(self, source: str = "scenario") -> None:
        """Raise `UserError` naming `source` for the first bad field."""
        if self.embodiment not in EMBODIMENT_NAMES:
            raise UserError(f"{source}: unknown embodiment '{self.embodiment}'")
        if self.hands not in HANDS_VARIANTS:
            raise UserError(f"{source}: hands must be one of {', '.join(HANDS_VARIANTS)}")
        if not (self.time_step > 0 and self.duration > 0 and self.initial.drop_height >= 0):
            raise UserError(f"{source}: time_step and duration must be > 0, drop_height >= 0")
        if self.controller not in CONTROLLERS:
            raise UserError(f"{source}: controller must be implicit or explicit")
        if not (self.control_rate > 0 and self.visualization.publish_period > 0):
            raise UserError(f"{source}: control_rate and publish_period must be > 0")
        if isinstance(self.driver, ReferenceTracking) and not self.driver.motion:
            raise UserError(f"{source}: driver !ReferenceTracking needs a motion")
        if self.initial.reference_time >= 0 and not self.reference_motion:
            raise UserError(f"{source}: initial.reference_time needs a reference motion")
        if isinstance(self.driver, PolicyCheckpoint) and not self.resolve(self.driver.checkpoint).is_file():
            raise UserError(f"{source}: policy checkpoint {self.driver.checkpoint!r} not found")
        if isinstance(self.driver, BaseTwist) and self.controller != "implicit":
            raise UserError(f"{source}: driver !BaseTwist drives the built-in PD (controller: implicit)")
        names = [o.instance_name for o in self.objects]
        if len(set(names)) != len(names):
            raise UserError(f"{source}: two objects share the name '{max(names, key=names.count)}'")
        for obj in self.objects:
            if obj.kind not in OBJECTS:
                raise UserError(f"{source}: unknown object kind '{obj.kind}'; choose from {', '.join(OBJECTS)}")
            if len(obj.position) != 3 or len(obj.target) not in (0, 3):
                raise UserError(f"{source}: object '{obj.instance_name}' needs a 3-D position (and target)")
            if obj.fixed and obj.held:
                raise UserError(f"{source}: object '{obj.instance_name}' cannot be both fixed and held")
        for launch in self.perturbations:
            if len(launch.start) != 3 or launch.speed <= 0 or launch.mass <= 0 or launch.size <= 0:
                raise UserError(f"{source}: a perturbation needs a 3-D start and positive speed, mass, size")

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


def _scenario_fields() -> set[str]:
    return set(Scenario.__dataclass_fields__)


def _read_raw(path: Path) -> dict:
    try:
        raw = yaml_load(filename=str(path))
    except Exception as error:  # the YAML reader raises many kinds
        raise UserError(f"{path}: not valid YAML ({_first_line(error)})") from None
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise UserError(f"{path}: a scenario file holds a mapping of fields (or of named scenarios)")
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
    raises `UserError` naming it."""
    path = Path(path)
    if not path.is_file():
        shipped = shipped_scenarios()
        moved = path.suffix == ".yaml" and path.parent.resolve() == systems_dir().resolve()
        if name is None and (str(path) in shipped or (moved and path.stem in shipped)):
            # a shipped name, or the 0.1 file of a shipped scenario (now an entry of a catalogue)
            name = path.stem if moved else str(path)
            path = shipped[name]
        elif path.stem in shipped and path.suffix in ("", ".yaml"):
            raise UserError(
                f"{path}: no such scenario file; the shipped scenario '{path.stem}' lives in "
                f"{shipped[path.stem].name} (give its name: {path.stem})"
            )
        else:
            raise UserError(f"{path}: no such scenario file (nor the name of a shipped scenario)")
    raw = _read_raw(path)
    where = str(path)
    if is_catalogue(raw):
        names = catalogue_names(raw)
        if name is None and len(names) == 1:
            name = names[0]
        if name not in names:
            wanted = "give one of" if name is None else f"no scenario '{name}'; choose from"
            raise UserError(f"{path}: {wanted} {', '.join(names)}")
        raw, where = raw[name], f"{path} ({name})"
        if not isinstance(raw, dict):
            raise UserError(f"{where}: a scenario is a mapping of fields")
    elif name is not None and name != path.stem:
        raise UserError(f"{path}: holds one scenario, not a catalogue with '{name}'")
    try:
        if _is_legacy(raw):
            data, driver = _upgrade_legacy(raw)
            scenario = yaml_load_typed(schema=Scenario, data=yaml_dump(data), defaults=Scenario(driver=driver))
        else:
            scenario = yaml_load_typed(schema=Scenario, data=yaml_dump(raw))
    except Exception as error:  # the YAML reader raises many kinds
        raise UserError(f"{where}: not a valid scenario ({_first_line(error)})") from None
    scenario.base_dir = str(path.resolve().parent)
    _check_finite(scenario, where)
    scenario.validate(where)
    return scenario


def _check_finite(scenario: Scenario, where: str) -> None:
    numbers = [scenario.time_step, scenario.duration, scenario.control_rate, scenario.initial.drop_height]
    if not all(math.isfinite(x) for x in numbers):
        raise UserError(f"{where}: time_step, duration, control_rate and drop_height must be finite numbers")
