"""Scenario files: a complete, named diagram described in YAML (`systems/*.yaml`).

Loaded with Drake's `yaml_load_typed` into dataclasses, in the manner of
RussTedrake/manipulation's `station.py`.
"""

from dataclasses import dataclass, field
from pathlib import Path

from pydrake.common.yaml import yaml_load_typed

from hotu_drake.cli import UserError
from hotu_drake.diagrams import PlantSettings
from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.systems.perturbation import CubeLaunch


@dataclass
class StandingScenario:
    """An embodiment dropped onto the floor, its PD holding the standing pose,
    optionally with cubes thrown at it."""

    embodiment: str = "h1"
    hands: str = "none"
    plant: PlantSettings = field(default_factory=PlantSettings)
    drop_height: float = 0.1
    duration: float = 5.0
    perturbations: list[CubeLaunch] = field(default_factory=list)

    def validate(self, source: str = "scenario") -> None:
        if self.embodiment not in EMBODIMENT_NAMES:
            raise UserError(f"{source}: unknown embodiment '{self.embodiment}'")
        if self.hands not in HANDS_VARIANTS:
            raise UserError(f"{source}: hands must be one of {', '.join(HANDS_VARIANTS)}")
        if self.plant.time_step <= 0 or self.duration <= 0 or self.drop_height < 0:
            raise UserError(f"{source}: time_step and duration must be > 0, drop_height >= 0")
        if self.plant.controller not in ("implicit", "explicit"):
            raise UserError(f"{source}: controller must be implicit or explicit")
        for launch in self.perturbations:
            if len(launch.start) != 3 or launch.speed <= 0 or launch.mass <= 0 or launch.size <= 0:
                raise UserError(f"{source}: a perturbation needs a 3-D start and positive speed, mass, size")


def load_standing_scenario(path: str | Path) -> StandingScenario:
    """Read a standing scenario; a bad file raises `UserError` naming it."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such scenario file")
    try:
        scenario = yaml_load_typed(schema=StandingScenario, filename=str(path))
    except Exception as error:  # the YAML reader raises many kinds
        lines = str(error).strip().splitlines() or [type(error).__name__]
        raise UserError(f"{path}: not a valid scenario ({lines[0]})") from None
    scenario.validate(str(path))
    return scenario
