"""Builders of simulation diagrams: a MultibodyPlant plus the pipeline's systems.

This first builder stands an embodiment on the floor with the plant's
built-in PD holding its default pose; later scenarios extend it.
"""

from dataclasses import dataclass, field

import numpy as np
from pydrake.geometry import Box, CollisionFilterDeclaration, GeometrySet, Meshcat, MeshcatVisualizer
from pydrake.math import RigidTransform
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder

from hotu_drake.embodiment import Embodiment

GROUND_FRICTION = 1.0


@dataclass
class PlantSettings:
    """The plant's discretisation and contact model."""

    time_step: float = 0.005
    discrete_contact_approximation: str = "sap"
    contact_model: str = "point"
    self_collision: bool = True
    # "implicit": the plant's built-in PD (stable at 5 ms); "explicit": a
    # SaturatedPdController on the actuation input (needs about 0.5 ms).
    controller: str = "implicit"

    def plant_config(self) -> MultibodyPlantConfig:
        return MultibodyPlantConfig(
            time_step=self.time_step,
            discrete_contact_approximation=self.discrete_contact_approximation,
            contact_model=self.contact_model,
        )


def add_ground(plant: MultibodyPlant, friction: float = GROUND_FRICTION, size: float = 40.0) -> None:
    """A flat floor with its top at z = 0 (a thick box: collision and visual)."""
    slab = Box(size, size, 1.0)
    pose = RigidTransform([0.0, 0.0, -0.5])
    plant.RegisterCollisionGeometry(plant.world_body(), pose, slab, "ground", CoulombFriction(friction, friction))
    plant.RegisterVisualGeometry(plant.world_body(), pose, slab, "ground_visual", np.array([0.85, 0.85, 0.82, 1.0]))


def disable_self_collision(plant: MultibodyPlant, scene_graph, model) -> None:
    """Ignore every collision between two bodies of `model`."""
    bodies = [plant.get_body(i) for i in plant.GetBodyIndices(model)]
    geometries = GeometrySet()
    for body in bodies:
        geometries.Add(plant.GetCollisionGeometriesForBody(body))
    scene_graph.collision_filter_manager().Apply(CollisionFilterDeclaration().ExcludeWithin(geometries))


def actuated_joint_order(plant: MultibodyPlant, model) -> list[str]:
    """Joint names in the order of the model's actuation and desired-state ports."""
    return [plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices(model)]


@dataclass
class StandingSimulation:
    """A built standing diagram and handles to its parts."""

    diagram: Diagram
    plant: MultibodyPlant
    model: object
    simulator: Simulator
    embodiment: Embodiment
    meshcat: Meshcat | None = None
    extras: dict = field(default_factory=dict)

    def pelvis_height(self) -> float:
        context = self.plant.GetMyContextFromRoot(self.simulator.get_context())
        body = self.plant.GetBodyByName(self.embodiment.key_bodies["pelvis"], self.model)
        return float(self.plant.EvalBodyPoseInWorld(context, body).translation()[2])

    def joint_positions(self) -> dict[str, float]:
        context = self.plant.GetMyContextFromRoot(self.simulator.get_context())
        return {
            name: float(self.plant.GetJointByName(name, self.model).GetOnePosition(context))
            for name in self.embodiment.joint_names
        }


def build_standing_simulation(
    embodiment: Embodiment,
    settings: PlantSettings | None = None,
    drop_height: float = 0.1,
    meshcat: Meshcat | None = None,
    base_command: bool = False,
    perturbations: list | None = None,
) -> StandingSimulation:
    """Drop an embodiment from `drop_height` with its PD holding the standing pose.

    With `base_command=True` (planar-base robots) a `PlanarBaseCommand`
    feeds the desired state and its `twist` input is exported as `twist`.
    `perturbations` (a list of `CubeLaunch`) throws cubes at the torso.
    """
    settings = settings or PlantSettings()
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(settings.plant_config(), builder)
    explicit = settings.controller == "explicit"
    if settings.controller not in ("implicit", "explicit"):
        raise ValueError(f"controller must be 'implicit' or 'explicit', not {settings.controller!r}")
    if explicit and base_command:
        raise ValueError("the planar base command drives the built-in PD; use the implicit controller")
    model = embodiment.add_to_plant(plant, builtin_pd=not explicit)
    add_ground(plant)
    if not settings.self_collision:
        disable_self_collision(plant, scene_graph, model)
    cubes = []
    if perturbations:
        from hotu_drake.systems.perturbation import add_perturbation_cubes

        cubes = add_perturbation_cubes(plant, perturbations)
    plant.Finalize()
    if perturbations:
        from hotu_drake.systems.perturbation import Perturbation

        torso = plant.GetBodyByName(embodiment.key_bodies["torso"], model)
        thrower = builder.AddNamedSystem(
            "perturbation", Perturbation(plant, cubes, perturbations, torso, settings.time_step)
        )
        builder.Connect(plant.get_body_poses_output_port(), thrower.get_input_port(0))
        builder.Connect(thrower.get_output_port(0), plant.get_applied_spatial_force_input_port())

    order = actuated_joint_order(plant, model)
    if order != embodiment.joint_names:
        raise RuntimeError(f"{embodiment.name}: actuator order differs from the spec's joint order")
    q_stand = embodiment.standing_pose
    extras = {}
    if explicit:
        from pydrake.systems.primitives import ConstantVectorSource

        from hotu_drake.systems.pd import SaturatedPdController

        controller = builder.AddNamedSystem("pd", SaturatedPdController(plant, model, embodiment))
        targets = builder.AddNamedSystem("standing_targets", ConstantVectorSource(q_stand))
        builder.Connect(plant.get_state_output_port(model), controller.get_input_port(0))
        builder.Connect(targets.get_output_port(), controller.get_input_port(1))
        builder.Connect(controller.get_output_port(0), plant.get_actuation_input_port(model))
        extras["controller"] = controller
    if base_command:
        from hotu_drake.systems import PlanarBaseCommand

        base = tuple(order.index(n) for n in embodiment.base_joints)
        if len(base) != 3:
            raise ValueError(f"{embodiment.name} has no planar base to command")
        command = builder.AddNamedSystem("base_command", PlanarBaseCommand(q_stand, base, settings.time_step))
        builder.Connect(command.get_output_port(), plant.get_desired_state_input_port(model))
        builder.ExportInput(command.get_input_port(), "twist")
        extras["base_command"] = command
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()

    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    if base_command:
        diagram.get_input_port(0).FixValue(context, np.zeros(3))
    elif not explicit:
        plant.get_desired_state_input_port(model).FixValue(
            plant_context, np.concatenate([q_stand, np.zeros_like(q_stand)])
        )
    positions = plant.GetPositions(plant_context)
    for name, q in zip(order, q_stand):
        positions[plant.GetJointByName(name, model).position_start()] = q
    plant.SetPositions(plant_context, positions)
    if embodiment.floating_base:
        root = plant.GetBodyByName(embodiment.spec.root.name, model)
        height = embodiment.standing_root_height + drop_height
        plant.SetFreeBodyPose(plant_context, root, RigidTransform([0.0, 0.0, height]))
    if perturbations:
        from hotu_drake.systems.perturbation import place_perturbation_cubes

        place_perturbation_cubes(plant, plant_context, cubes, perturbations)
    simulator.Initialize()
    return StandingSimulation(diagram, plant, model, simulator, embodiment, meshcat, extras)
