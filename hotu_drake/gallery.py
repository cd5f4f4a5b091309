"""The six embodiments standing side by side, as a self-contained Meshcat HTML page.

Visual geometry is coloured by functional part (the colours of
`hotu_drake.embodiment.spec.PART_COLORS`).
"""

from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, StartMeshcat
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.io import write_text_atomic
from hotu_drake.plant import actuated_joint_order

SPACING = 1.6  # metres between neighbours, along y


def render_gallery(
    names: tuple[str, ...] = embodiment.EMBODIMENT_NAMES,
    hands: str = "full",
    meshcat: Meshcat | None = None,
    camera: tuple[tuple[float, float, float], tuple[float, float, float]] = ((4.6, 0.0, 1.5), (0.0, 0.0, 0.75)),
) -> Meshcat:
    """Show `names` standing in a row (first on the left as seen from the front).

    `camera` is the camera position and the point it looks at.
    """
    meshcat = meshcat or StartMeshcat()
    meshcat.Delete()
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    loaded = [embodiment.load(name, hands) for name in names]
    models = [emb.add_to_plant(plant) for emb in loaded]
    plant.Finalize()
    MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)

    offsets = (np.arange(len(names)) - (len(names) - 1) / 2.0) * SPACING
    positions = plant.GetPositions(plant_context)
    for emb, model, y in zip(loaded, models, offsets):
        for name, q in zip(actuated_joint_order(plant, model), emb.standing_pose):
            positions[plant.GetJointByName(name, model).position_start()] = q
        if not emb.floating_base:
            positions[plant.GetJointByName("base_y", model).position_start()] = y
    plant.SetPositions(plant_context, positions)
    for emb, model, y in zip(loaded, models, offsets):
        if emb.floating_base:
            root = plant.GetBodyByName(emb.spec.root.name, model)
            plant.SetFreeBodyPose(plant_context, root, RigidTransform([0.0, y, emb.standing_root_height]))
    meshcat.SetProperty("/Axes", "visible", False)
    meshcat.SetCameraPose(np.array(camera[0]), np.array(camera[1]))
    diagram.ForcedPublish(context)
    return meshcat


def write_gallery(path: str | Path, hands: str = "full", meshcat: Meshcat | None = None) -> Path:
    """Write the gallery as one self-contained HTML file."""
    meshcat = render_gallery(hands=hands, meshcat=meshcat)
    return write_text_atomic(path, meshcat.StaticHtml())
