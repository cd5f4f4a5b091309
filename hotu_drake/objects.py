"""Task objects of the method: box, drill, table and a target marker (models/objects/)."""

from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from hotu_drake.resources import models_dir

OBJECTS: tuple[str, ...] = ("box", "drill", "table", "target_marker")


def add_object(plant: MultibodyPlant, name: str, instance_name: str | None = None, weld: RigidTransform | None = None):
    """Add a task object to a plant (welded at `weld` if given, else free)."""
    if name not in OBJECTS:
        raise ValueError(f"unknown object {name!r}; choose from {', '.join(OBJECTS)}")
    parser = Parser(plant, instance_name) if instance_name else Parser(plant)
    (model,) = parser.AddModels(str(models_dir() / "objects" / f"{name}.sdf"))
    if weld is not None:
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(name, model), weld)
    return model
