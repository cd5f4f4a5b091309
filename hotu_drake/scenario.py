"""Scenario files: a complete, named diagram described in YAML (`systems/*.yaml`).

Loaded with Drake's `yaml_load_typed` into the dataclasses below, in the
manner of RussTedrake/manipulation's `station.py`. `diagrams.build_simulation`
turns a `Scenario` into a running diagram. Every field has a default, so a
scenario file names only what differs.
"""

from dataclasses import dataclass, field
from pathlib import Path

from pydrake.common.yaml import yaml_load_typed
from pydrake.multibody.plant import MultibodyPlantConfig

from hotu_drake.cli import UserError
from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.systems.perturbation import CubeLaunch

CONTROLLERS = ("implicit", "explicit")


@dataclass
class PlantSettings:
    """The plant's discretisation, contact model and PD controller."""

    time_step: float = 0.005
    discrete_contact_approximation: str = "sap"
    contact_model: str = "point"
    self_collision: bool = True
    # "implicit": the plant's built-in PD (stable at 5 ms); "explicit": a
    # SaturatedPdController on the actuation input (needs about 0.5 ms).
    controller: str = "implicit"
    # Drake's sampled output ports copy the contact results and poses into
    # the state at every step; computing them when read is 10-15% faster
    # here, as most steps read neither.
    sampled_output_ports: bool = False

    def plant_config(self) -> MultibodyPlantConfig:
        return MultibodyPlantConfig(
            time_step=self.time_step,
            discrete_contact_approximation=self.discrete_contact_approximation,
            contact_model=self.contact_model,
            use_sampled_output_ports=self.sampled_output_ports,
        )


@dataclass
class InitialCondition:
    """Where the run starts: the standing pose dropped from `drop_height`
    above standing height, or, when `reference_time` is set (>= 0) and the
    scenario has a reference clip, the clip's state at that time (reference
    state initialisation). On a fixed base `drop_height` lifts the weld."""

    drop_height: float = 0.1
    reference_time: float = -1.0


@dataclass
class ReferenceMotion:
    """A motion for the PD to track: a motion of the generated library
    (e.g. `walk`), retargeted onto the scenario's embodiment when the
    diagram is built, or a path to a `.npz` clip of that embodiment
    (relative to the scenario file). Empty: no reference."""

    motion: str = ""
    loop: bool = True


@dataclass
class PolicySettings:
    """A policy checkpoint (written by training) that sets the PD targets at
    `control_rate`. Its skill latents are held at zero until skills are
    composed. Empty `checkpoint`: no policy."""

    checkpoint: str = ""
    control_rate: float = 30.0


@dataclass
class SceneObject:
    """A task object (box, drill, table or target_marker) at `position`
    with `yaw` (rad). `fixed` welds it to the world; `held` keeps a free
    object floating at its start until the robot first touches it (the
    method's box task). A `target` (3-D) adds a target marker there and is
    the object's goal in the interaction graph."""

    kind: str = "box"
    name: str = ""
    position: list[float] = field(default_factory=lambda: [0.6, 0.0, 0.8])
    yaw: float = 0.0
    fixed: bool = False
    held: bool = False
    target: list[float] = field(default_factory=list)

    @property
    def instance_name(self) -> str:
        return self.name or self.kind


@dataclass
class Visualization:
    """What Meshcat shows when a run is visualised."""

    publish_period: float = 1.0 / 30.0
    contact_forces: bool = False
    collision_geometry: bool = False


@dataclass
class Scenario:
    """An embodiment on the floor (or on a fixed base) under PD control,
    holding its standing pose, tracking a reference clip or driven by a
    policy; with optional task objects, thrown cubes and the pipeline's
    observation and interaction-graph systems in the loop."""

    embodiment: str = "h1"
    hands: str = "none"
    fixed_base: bool = False
    plant: PlantSettings = field(default_factory=PlantSettings)
    initial: InitialCondition = field(default_factory=InitialCondition)
    reference: ReferenceMotion = field(default_factory=ReferenceMotion)
    policy: PolicySettings = field(default_factory=PolicySettings)
    # Add the ObservationSystem even without a policy (its outputs are
    # exported for monitoring and learning).
    observation: bool = False
    objects: list[SceneObject] = field(default_factory=list)
    perturbations: list[CubeLaunch] = field(default_factory=list)
    visualization: Visualization = field(default_factory=Visualization)
    duration: float = 5.0
    # Set by `load_scenario`: the folder relative paths are resolved in.
    base_dir: str = ""

    def resolve(self, path: str) -> Path:
        """A path from the scenario file, relative to the file's folder."""
        p = Path(path).expanduser()
        return p if p.is_absolute() or not self.base_dir else Path(self.base_dir) / p

    def validate(self, source: str = "scenario") -> None:
        """Raise `UserError` naming `source` for the first bad field."""
        from hotu_drake.objects import OBJECTS

        if self.embodiment not in EMBODIMENT_NAMES:
            raise UserError(f"{source}: unknown embodiment '{self.embodiment}'")
        if self.hands not in HANDS_VARIANTS:
            raise UserError(f"{source}: hands must be one of {', '.join(HANDS_VARIANTS)}")
        if self.plant.time_step <= 0 or self.duration <= 0 or self.initial.drop_height < 0:
            raise UserError(f"{source}: time_step and duration must be > 0, drop_height >= 0")
        if self.plant.controller not in CONTROLLERS:
            raise UserError(f"{source}: controller must be implicit or explicit")
        if self.policy.control_rate <= 0 or self.visualization.publish_period <= 0:
            raise UserError(f"{source}: control_rate and publish_period must be > 0")
        if self.initial.reference_time >= 0 and not self.reference.motion:
            raise UserError(f"{source}: initial.reference_time needs a reference motion")
        if self.policy.checkpoint and not self.resolve(self.policy.checkpoint).is_file():
            raise UserError(f"{source}: policy checkpoint {self.policy.checkpoint} not found")
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


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario file; a bad file raises `UserError` naming it."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such scenario file")
    try:
        scenario = yaml_load_typed(schema=Scenario, filename=str(path))
    except Exception as error:  # the YAML reader raises many kinds
        lines = str(error).strip().splitlines() or [type(error).__name__]
        raise UserError(f"{path}: not a valid scenario ({lines[0]})") from None
    scenario.base_dir = str(path.resolve().parent)
    scenario.validate(str(path))
    return scenario
