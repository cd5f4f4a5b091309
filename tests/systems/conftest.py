"""A tiny diagram to add systems to: BRUCE (16 joints) on the floor."""

from dataclasses import dataclass

import pytest
from pydrake.geometry import SceneGraph
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.embodiment import Embodiment
from hotu_drake.plant import add_ground, add_robot
from hotu_drake.scenario import default_plant_config


@dataclass
class Scene:
    embodiment: Embodiment
    builder: DiagramBuilder
    plant: MultibodyPlant
    scene_graph: SceneGraph
    model: object


def make_scene(name: str = "bruce", hands: str = "none", finalize: bool = True, **robot) -> Scene:
    emb = embodiment.load(name, hands)
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(default_plant_config(), builder)
    model = add_robot(plant, scene_graph, emb, **robot)
    add_ground(plant)
    if finalize:
        plant.Finalize()
    return Scene(emb, builder, plant, scene_graph, model)


@pytest.fixture
def bruce() -> Scene:
    return make_scene()
