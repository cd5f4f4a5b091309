"""Builders of simulation diagrams: a MultibodyPlant plus the pipeline's systems.

`build_simulation(scenario)` wires what a `Scenario` describes:

    PD targets ──> plant (built-in PD, or SaturatedPdController ──> actuation)
      from: the standing pose | ReferenceMotionSource | PolicySystem
            (observation ──> policy ──> action ──> targets, at 30 Hz)
    plant ──> ObservationSystem, InteractionGraphSystem (with task objects)
    Perturbation, ObjectHolder ──> applied spatial forces ──> plant
    scene graph ──> Meshcat (when given one)

Every system is added by name (`pd`, `reference`, `policy`, `observation`,
`interaction_graph`, `perturbation`, `object_holder`, ...) and its useful
outputs are exported from the diagram under the same names.
"""

from dataclasses import dataclass, field

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.geometry import (
    Box,
    CollisionFilterDeclaration,
    GeometrySet,
    Meshcat,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Role,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    ExternallyAppliedSpatialForceMultiplexer,
    MultibodyPlant,
)
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import AffineSystem, ConstantVectorSource, Multiplexer

from hotu_drake import embodiment as embodiments
from hotu_drake.cli import UserError
from hotu_drake.embodiment import Embodiment
from hotu_drake.motion.clip import MotionClip
from hotu_drake.objects import add_object
from hotu_drake.scenario import InitialCondition, PlantSettings, Scenario, SceneObject
from hotu_drake.systems.base_command import PlanarBaseCommand
from hotu_drake.systems.interaction_graph import InteractionGraphSystem
from hotu_drake.systems.object_holder import ObjectHolder
from hotu_drake.systems.observation import ObservationSystem, heading_rotation
from hotu_drake.systems.pd import ActionScaling, SaturatedPdController
from hotu_drake.systems.perturbation import Perturbation, add_perturbation_cubes, place_perturbation_cubes
from hotu_drake.systems.reference import ReferenceMotionSource

__all__ = ["PlantSettings", "Simulation", "build_simulation", "build_standing_simulation"]

GROUND_FRICTION = 1.0


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


FEET = ("left_foot", "right_foot")


class FloorContact:
    """Whether a body of the robot other than its feet touches the floor.

    Checked on geometry (a floor geometry penetrating one of those bodies',
    the condition for point contact), so it costs a collision query, not a
    contact solve."""

    def __init__(self, plant: MultibodyPlant, model, embodiment: Embodiment):
        feet = {
            plant.GetBodyByName(embodiment.key_bodies[r], model).index() for r in FEET if r in embodiment.key_bodies
        }
        self._plant = plant
        self._floor = set(plant.GetCollisionGeometriesForBody(plant.world_body()))
        self._body = {
            geometry
            for index in plant.GetBodyIndices(model)
            if index not in feet
            for geometry in plant.GetCollisionGeometriesForBody(plant.get_body(index))
        }

    def __call__(self, plant_context) -> bool:
        query = self._plant.get_geometry_query_input_port().Eval(plant_context)
        floor, body = self._floor, self._body
        for pair in query.ComputePointPairPenetration():
            a, b = pair.id_A, pair.id_B
            if (a in floor and b in body) or (b in floor and a in body):
                return True
        return False


@dataclass
class Simulation:
    """A built diagram, its simulator and handles to its parts."""

    diagram: Diagram
    plant: MultibodyPlant
    model: object
    simulator: Simulator
    embodiment: Embodiment
    meshcat: Meshcat | None = None
    systems: dict = field(default_factory=dict)  # name -> system added to the diagram
    objects: dict = field(default_factory=dict)  # object name -> model instance
    reference: MotionClip | None = None

    def plant_context(self):
        return self.plant.GetMyContextFromRoot(self.simulator.get_context())

    def pelvis_height(self) -> float:
        body = self.plant.GetBodyByName(self.embodiment.key_bodies["pelvis"], self.model)
        return float(self.plant.EvalBodyPoseInWorld(self.plant_context(), body).translation()[2])

    def joint_positions(self) -> dict[str, float]:
        context = self.plant_context()
        return {
            name: float(self.plant.GetJointByName(name, self.model).GetOnePosition(context))
            for name in self.embodiment.joint_names
        }

    def output(self, name: str) -> np.ndarray:
        """Evaluate one of the diagram's exported vector outputs (e.g. `observation`)."""
        return self.diagram.GetOutputPort(name).Eval(self.simulator.get_context())


def reference_clip(scenario: Scenario, emb: Embodiment) -> MotionClip | None:
    """The scenario's reference motion on its embodiment, or None."""
    if not scenario.reference.motion:
        return None
    from hotu_drake.retarget.references import reference_clip as load_reference

    return load_reference(scenario.reference.motion, emb, scenario.base_dir or None)


def build_simulation(
    scenario: Scenario,
    meshcat: Meshcat | None = None,
    embodiment: Embodiment | None = None,
    base_command: bool = False,
    action_input: bool = False,
) -> Simulation:
    """Build the diagram a scenario describes and initialise its simulator.

    `embodiment` overrides the scenario's (e.g. a resized UDH). With
    `base_command=True` (planar-base robots) a `PlanarBaseCommand` feeds the
    PD and its `twist` input is exported as `twist`. With `action_input=True`
    (and no policy in the scenario) the normalised PD targets come from an
    exported `action` input port, the way an environment drives the diagram.
    """
    settings = scenario.plant
    if settings.controller not in ("implicit", "explicit"):
        raise ValueError(f"controller must be 'implicit' or 'explicit', not {settings.controller!r}")
    explicit = settings.controller == "explicit"
    emb = embodiment or embodiments.load(scenario.embodiment, scenario.hands)
    clip = reference_clip(scenario, emb)
    policy = _load_policy(scenario, emb)
    if action_input and policy is not None:
        raise ValueError("a scenario with a policy has no action input")
    if base_command and (explicit or clip is not None or policy is not None or action_input):
        raise ValueError("the planar base command drives the built-in PD on its own")

    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(settings.plant_config(), builder)
    model = emb.add_to_plant(plant, builtin_pd=not explicit)
    root = plant.GetBodyByName(emb.spec.root.name, model)
    fixed = scenario.fixed_base and emb.floating_base
    if fixed:
        height = emb.standing_root_height + scenario.initial.drop_height
        plant.WeldFrames(plant.world_frame(), root.body_frame(), RigidTransform([0.0, 0.0, height]))
    add_ground(plant)
    if not settings.self_collision:
        disable_self_collision(plant, scene_graph, model)
    objects = _add_objects(plant, scenario)
    cubes = []
    if scenario.perturbations:
        cubes = add_perturbation_cubes(plant, scenario.perturbations)
    plant.Finalize()
    if actuated_joint_order(plant, model) != emb.joint_names:
        raise RuntimeError(f"{emb.name}: actuator order differs from the spec's joint order")

    wiring = _Wiring(builder, plant, scene_graph, model, emb)
    if policy is not None or action_input:
        target_port = _targets_from_actions(wiring, explicit, policy)
    elif clip is not None:
        target_port = _targets_from_reference(wiring, explicit, _reference_source(scenario, emb, clip, fixed))
    elif base_command:
        target_port = _targets_from_base_command(wiring, settings.time_step)
    else:
        standing = (
            emb.standing_pose if explicit else np.concatenate([emb.standing_pose, np.zeros_like(emb.standing_pose)])
        )
        target_port = wiring.add("standing_targets", ConstantVectorSource(standing)).get_output_port()
    _connect_pd(wiring, explicit, target_port)
    if scenario.observation and "observation" not in wiring.systems:
        _add_observation(wiring)
    _add_interaction_graph(wiring, scenario, objects)
    _add_applied_forces(wiring, scenario, objects, cubes)
    systems = wiring.systems

    if meshcat is not None:
        _add_visualization(builder, scene_graph, plant, meshcat, scenario)
    diagram = builder.Build()

    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    if base_command:
        diagram.GetInputPort("twist").FixValue(context, np.zeros(3))
    sampler = None
    if clip is not None and scenario.initial.reference_time >= 0:
        sampler = systems.get("reference") or _reference_source(scenario, emb, clip, fixed)
    set_robot_state(plant, plant_context, model, emb, sampler, drop_height=scenario.initial.drop_height, fixed=fixed)
    place_objects(plant, plant_context, objects, scenario.objects)
    if cubes:
        place_perturbation_cubes(plant, plant_context, cubes, scenario.perturbations)
    simulator.Initialize()
    return Simulation(diagram, plant, model, simulator, emb, meshcat, systems, objects, clip)


def build_standing_simulation(
    embodiment: Embodiment,
    settings: PlantSettings | None = None,
    drop_height: float = 0.1,
    meshcat: Meshcat | None = None,
    base_command: bool = False,
    perturbations: list | None = None,
) -> Simulation:
    """Drop an embodiment from `drop_height` with its PD holding the standing
    pose (optionally throwing `perturbations`, a list of `CubeLaunch`)."""
    scenario = Scenario(
        embodiment=embodiment.name,
        hands=embodiment.hands,
        plant=settings or PlantSettings(),
        initial=InitialCondition(drop_height=drop_height),
        perturbations=list(perturbations or []),
    )
    return build_simulation(scenario, meshcat, embodiment=embodiment, base_command=base_command)


@dataclass
class _Wiring:
    """What the wiring helpers below share while a diagram is built."""

    builder: DiagramBuilder
    plant: MultibodyPlant
    scene_graph: object
    model: object
    embodiment: Embodiment
    systems: dict = field(default_factory=dict)

    def add(self, name: str, system, keep: bool = False):
        """Add a named system (and list it in `systems` if `keep`)."""
        added = self.builder.AddNamedSystem(name, system)
        if keep:
            self.systems[name] = added
        return added


def _add_observation(w: _Wiring) -> ObservationSystem:
    observation = w.add("observation", ObservationSystem(w.plant, w.model, w.embodiment), keep=True)
    w.builder.Connect(w.plant.get_state_output_port(w.model), observation.GetInputPort("state"))
    w.builder.ExportOutput(observation.GetOutputPort("observation"), "observation")
    w.builder.ExportOutput(observation.GetOutputPort("amp_observation"), "amp_observation")
    return observation


def _targets_from_actions(w: _Wiring, explicit: bool, policy):
    """Normalised actions -> PD targets, from the policy or an exported `action` input."""
    observation = _add_observation(w)
    # a -> q* = offset + scale a (and v* = 0): a C++ system, no Python per step.
    scaling = ActionScaling.for_embodiment(w.embodiment)
    n = scaling.scale.size
    rows = n if explicit else 2 * n
    gain, offset = np.zeros((rows, n)), np.zeros(rows)
    gain[:n], offset[:n] = np.diag(scaling.scale), scaling.offset
    targets = w.add("action_to_targets", _static_gain(gain, offset))
    if policy is None:
        w.builder.ExportInput(targets.get_input_port(), "action")
        return targets.get_output_port()
    w.add("policy", policy, keep=True)
    w.builder.Connect(observation.GetOutputPort("observation"), policy.GetInputPort("observation"))
    for port in range(1, policy.num_input_ports()):  # skill latents: zero until skills are composed
        latent = policy.get_input_port(port)
        source = w.add(f"{latent.get_name()}_source", ConstantVectorSource(np.zeros(latent.size())))
        w.builder.Connect(source.get_output_port(), latent)
    w.builder.Connect(policy.GetOutputPort("action"), targets.get_input_port())
    w.builder.ExportOutput(policy.GetOutputPort("action"), "action")
    return targets.get_output_port()


def _targets_from_reference(w: _Wiring, explicit: bool, source: ReferenceMotionSource):
    reference = w.add("reference", source, keep=True)
    w.builder.ExportOutput(reference.GetOutputPort("joint_positions"), "reference_joint_positions")
    if explicit:
        return reference.GetOutputPort("joint_positions")
    n = len(w.embodiment.joint_names)
    desired = w.add("reference_desired_state", Multiplexer([n, n]))
    w.builder.Connect(reference.GetOutputPort("joint_positions"), desired.get_input_port(0))
    w.builder.Connect(reference.GetOutputPort("joint_velocities"), desired.get_input_port(1))
    return desired.get_output_port()


def _targets_from_base_command(w: _Wiring, time_step: float):
    emb = w.embodiment
    base = tuple(emb.joint_names.index(j) for j in emb.base_joints)
    if len(base) != 3:
        raise ValueError(f"{emb.name} has no planar base to command")
    command = w.add("base_command", PlanarBaseCommand(emb.standing_pose, base, time_step), keep=True)
    w.builder.ExportInput(command.get_input_port(), "twist")
    return command.get_output_port()


def _connect_pd(w: _Wiring, explicit: bool, target_port) -> None:
    """Targets into the plant's built-in PD, or through the explicit controller."""
    plant, model = w.plant, w.model
    if not explicit:
        w.builder.Connect(target_port, plant.get_desired_state_input_port(model))
        return
    controller = w.add("pd", SaturatedPdController(plant, model, w.embodiment), keep=True)
    w.builder.Connect(plant.get_state_output_port(model), controller.GetInputPort("state"))
    w.builder.Connect(target_port, controller.GetInputPort("targets"))
    w.builder.Connect(controller.GetOutputPort("torques"), plant.get_actuation_input_port(model))


def _add_interaction_graph(w: _Wiring, scenario: Scenario, objects: dict) -> None:
    """The graph over the hands, the body and the free box or drill, if any."""
    plant, emb = w.plant, w.embodiment
    task = [o for o in scenario.objects if _is_task_object(o)]
    if not task or not {"left_hand", "right_hand", "pelvis"} <= emb.key_bodies.keys():
        return
    bodies = {o.instance_name: object_body(plant, objects, o) for o in task}
    graph = w.add("interaction_graph", InteractionGraphSystem(plant, w.model, emb, bodies), keep=True)
    goals = np.ravel([o.target or o.position for o in task]).astype(float)
    targets = w.add("object_targets", ConstantVectorSource(goals), keep=True)
    w.builder.Connect(plant.get_body_poses_output_port(), graph.GetInputPort("body_poses"))
    w.builder.Connect(plant.get_contact_results_output_port(), graph.GetInputPort("contact_results"))
    w.builder.Connect(targets.get_output_port(), graph.GetInputPort("object_targets"))
    w.builder.ExportOutput(graph.GetOutputPort("interaction"), "interaction")
    w.builder.ExportOutput(graph.GetOutputPort("graph"), "interaction_graph")


def _add_applied_forces(w: _Wiring, scenario: Scenario, objects: dict, cubes: list) -> None:
    """Thrown cubes and held objects push through the plant's applied-force input."""
    plant, builder = w.plant, w.builder
    sources = []
    if scenario.perturbations:
        torso = plant.GetBodyByName(w.embodiment.key_bodies["torso"], w.model)
        time_step = scenario.plant.time_step
        thrower = w.add("perturbation", Perturbation(plant, cubes, scenario.perturbations, torso, time_step), keep=True)
        builder.Connect(plant.get_body_poses_output_port(), thrower.GetInputPort("body_poses"))
        sources.append(thrower.GetOutputPort("spatial_forces"))
    held = [object_body(plant, objects, o) for o in scenario.objects if o.held]
    if held:
        period = 1.0 / scenario.policy.control_rate
        holder = w.add("object_holder", ObjectHolder(plant, w.model, held, period), keep=True)
        builder.Connect(w.scene_graph.get_query_output_port(), holder.GetInputPort("geometry_query"))
        sources.append(holder.GetOutputPort("spatial_forces"))
    if len(sources) == 1:
        builder.Connect(sources[0], plant.get_applied_spatial_force_input_port())
    elif sources:
        mux = w.add("applied_forces", ExternallyAppliedSpatialForceMultiplexer(len(sources)))
        for i, port in enumerate(sources):
            builder.Connect(port, mux.get_input_port(i))
        builder.Connect(mux.get_output_port(), plant.get_applied_spatial_force_input_port())


def _static_gain(gain: np.ndarray, offset: np.ndarray) -> AffineSystem:
    """y = gain u + offset, stateless."""
    inputs = gain.shape[1]
    return AffineSystem(
        A=np.zeros((0, 0)), B=np.zeros((0, inputs)), f0=np.zeros(0), C=np.zeros((gain.shape[0], 0)), D=gain, y0=offset
    )


def _load_policy(scenario: Scenario, emb: Embodiment):
    if not scenario.policy.checkpoint:
        return None
    from hotu_drake.learning.checkpoint import CheckpointError, load_checkpoint
    from hotu_drake.systems.policy import PolicySystem

    path = scenario.resolve(scenario.policy.checkpoint)
    try:
        network, meta = load_checkpoint(path)
    except CheckpointError as error:
        raise UserError(str(error)) from None
    if (meta.get("embodiment"), meta.get("hands")) != (emb.name, emb.hands):
        raise UserError(
            f"{path}: the policy drives {meta.get('embodiment')} hands={meta.get('hands')}, "
            f"not {emb.name} hands={emb.hands}"
        )
    if network.config.action_size != len(emb.joint_names):
        raise UserError(f"{path}: the policy has {network.config.action_size} actions, {emb.name} has its joints")
    return PolicySystem(network, scenario.policy.control_rate)


def _is_task_object(obj) -> bool:
    return obj.kind in ("box", "drill") and not obj.fixed


def object_pose(obj: SceneObject) -> RigidTransform:
    """Where a scene object starts (or is welded): its position, turned by its yaw."""
    return RigidTransform(RollPitchYaw(0.0, 0.0, obj.yaw), np.asarray(obj.position, dtype=float))


def object_body(plant: MultibodyPlant, objects: dict, obj: SceneObject):
    """The body of a scene object (`objects`: instance name -> model instance)."""
    return plant.GetBodyByName(obj.kind, objects[obj.instance_name])


def place_objects(plant: MultibodyPlant, plant_context, objects: dict, scene_objects: list[SceneObject]) -> None:
    """Put every free scene object at its start pose."""
    for obj in scene_objects:
        if not obj.fixed and obj.kind != "target_marker":
            body = object_body(plant, objects, obj)
            plant.SetFreeBodyPose(plant_context, body, object_pose(obj))


def _add_objects(plant: MultibodyPlant, scenario: Scenario) -> dict:
    """Add the scenario's objects (and a marker at each target) before Finalize."""
    objects = {}
    for obj in scenario.objects:
        weld = object_pose(obj) if obj.fixed or obj.kind == "target_marker" else None
        objects[obj.instance_name] = add_object(plant, obj.kind, obj.instance_name, weld=weld)
        if obj.target:
            marker = f"{obj.instance_name}_target"
            objects[marker] = add_object(
                plant, "target_marker", marker, weld=RigidTransform(np.asarray(obj.target, dtype=float))
            )
    return objects


def _reference_source(scenario: Scenario, emb: Embodiment, clip: MotionClip, fixed: bool):
    start = max(scenario.initial.reference_time, 0.0)
    return ReferenceMotionSource(clip, scenario.reference.loop, emb.floating_base and not fixed, start_time=start)


def set_robot_state(
    plant: MultibodyPlant,
    plant_context,
    model,
    emb: Embodiment,
    reference: ReferenceMotionSource | None = None,
    time: float = 0.0,
    drop_height: float = 0.0,
    fixed: bool = False,
    align: bool = False,
) -> None:
    """Put the robot in the standing pose `drop_height` above standing
    height, at rest; or, given a `reference` source, in the reference state
    (pose and velocities) it plays at simulation time `time`. With `align`
    the reference state is moved and turned about z so that the root
    starts over the origin facing +x. A fixed or planar base sets the joints only."""
    positions = plant.GetPositions(plant_context)
    velocities = plant.GetVelocities(plant_context)
    if reference is not None:
        q, v = reference.joints_at(time)
    else:
        q, v = emb.standing_pose, np.zeros(len(emb.joint_names))
    for name, qi, vi in zip(emb.joint_names, q, v):
        joint = plant.GetJointByName(name, model)
        positions[joint.position_start()] = qi
        velocities[joint.velocity_start()] = vi
    plant.SetPositions(plant_context, positions)
    plant.SetVelocities(plant_context, velocities)
    if not emb.floating_base or fixed:
        return
    root = plant.GetBodyByName(emb.spec.root.name, model)
    if reference is not None:
        quaternion, position, omega, linear = reference.root_at(time)
        pose = RigidTransform(Quaternion(quaternion), position)
        if align:
            yaw = heading_rotation(pose.rotation().matrix())
            turn = RigidTransform(RotationMatrix(yaw.T), -yaw.T @ [position[0], position[1], 0.0])
            pose, omega, linear = turn @ pose, yaw.T @ omega, yaw.T @ linear
        plant.SetFreeBodyPose(plant_context, root, pose)
        plant.SetFreeBodySpatialVelocity(plant_context, root, SpatialVelocity(omega, linear))
    else:
        plant.SetFreeBodyPose(plant_context, root, RigidTransform([0.0, 0.0, emb.standing_root_height + drop_height]))


def _add_visualization(builder, scene_graph, plant, meshcat: Meshcat, scenario: Scenario) -> None:
    settings = scenario.visualization
    params = MeshcatVisualizerParams(publish_period=settings.publish_period)
    MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)
    if settings.collision_geometry:
        collision = MeshcatVisualizerParams(
            publish_period=settings.publish_period, role=Role.kProximity, prefix="collision", visible_by_default=False
        )
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, collision)
    if settings.contact_forces:
        from pydrake.multibody.meshcat import ContactVisualizer, ContactVisualizerParams

        ContactVisualizer.AddToBuilder(
            builder, plant, meshcat, ContactVisualizerParams(publish_period=settings.publish_period)
        )
