"""Simulation diagrams: a `Scenario` composed from the pipeline's parts.

`AddScenario(builder, scenario)` adds, in order, to a `DiagramBuilder`:

    plant + scene graph      MultibodyPlantConfig           (Drake's AddMultibodyPlant)
    robot, floor             plant.add_robot, add_ground
    task objects             objects.add_scene_objects
    perturbation cubes       systems.perturbation.add_perturbation_cubes
    interaction graph        systems.interaction_graph.AddInteractionGraph
    PD targets (driver)      standing pose | systems.reference | systems.policy
                               (a clip-following clone with systems.motion_reference)
                             | systems.skill (over systems.policy; a transfer layer
                               with systems.transfer_reference)
                             | exported `action` input | systems.base_command
    PD                       systems.pd.AddPdControl (built-in or SaturatedPdController)
    observation              systems.observation.AddObservation
    applied forces           systems.perturbation, systems.object_holder
    Meshcat                  Drake's ApplyVisualizationConfig

Every system is added by name (`pd`, `reference`, `policy`, `observation`,
`interaction_graph`, `perturbation`, `object_holder`, ...), and it returns
them (`ScenarioSystems`) with the useful ports by name: outputs
`observation`, `amp_observation`, `action`, `reference_joint_positions`,
`interaction`, `goal`, `interaction_graph`, ...; inputs `action` and `twist`.
A user adds their own systems to the same builder (a logger, an estimator,
a controller feeding `action`; `ScenarioSystems.hold_inputs_at_rest` feeds
the inputs left over), builds, and starts the scenario with
`ScenarioSystems.set_initial_state(context)`.

`build_simulation(scenario)` is the convenience over it: a fresh builder,
those ports exported from the diagram (the inputs fixed at the standing
action and zero twist until a user sets them), the simulator initialised.
`run_scenario(scenario)` simulates one and measures it (falls, torques,
tracking): the figures `python -m hotu_drake.simulate` prints.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field
from functools import singledispatch

import numpy as np
from pydrake.geometry import Meshcat, SceneGraph
from pydrake.lcm import DrakeLcm
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, InputPort, OutputPort, System
from pydrake.systems.primitives import ConstantVectorSource, Multiplexer, SharedPointerSystem
from pydrake.visualization import ApplyVisualizationConfig

from hotu_drake import embodiment as embodiments
from hotu_drake.control.clip_plan import lead_in_for
from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.actions import standing_action
from hotu_drake.errors import InputError
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.objects import add_scene_objects, object_body, place_objects
from hotu_drake.plant import (
    FallCheck,
    actuated_joint_order,
    add_ground,
    add_robot,
    connect_applied_forces,
    set_robot_state,
)
from hotu_drake.retarget.references import looped_motions, motion_key, reference_clip
from hotu_drake.scenario import (
    LATENT_CHOICES,
    ActionInput,
    BaseTwist,
    InitialCondition,
    PolicyCheckpoint,
    ReferenceTracking,
    Scenario,
    SkillCheckpoint,
    StandingPose,
    WholeBodyTracking,
)
from hotu_drake.systems.base_command import AddPlanarBaseCommand
from hotu_drake.systems.interaction_graph import GOAL_SIZE, AddInteractionGraph, InteractionGraphSystem
from hotu_drake.systems.latents import AddLatentSampler
from hotu_drake.systems.motion_reference import AddMotionReference
from hotu_drake.systems.object_holder import AddObjectHolder
from hotu_drake.systems.observation import AddObservation, ObservationSystem
from hotu_drake.systems.pd import AddActionToTargets, AddPdControl
from hotu_drake.systems.perturbation import AddPerturbation, add_perturbation_cubes, place_perturbation_cubes
from hotu_drake.systems.policy import AddPolicy, load_policy, observation_extras
from hotu_drake.systems.reference import AddReferenceMotion, ReferenceMotionSource
from hotu_drake.systems.skill import AddSkillPolicy, load_skill_policy
from hotu_drake.systems.transfer_reference import AddTransferReference, TransferReference
from hotu_drake.systems.whole_body import AddWholeBodyController

__all__ = [
    "AddScenario",
    "ScenarioSystems",
    "Simulation",
    "build_simulation",
    "build_standing_simulation",
    "run_scenario",
    "state_checksum",
]


@dataclass
class Simulation:
    """A built diagram, its simulator and handles to its parts."""

    diagram: Diagram
    plant: MultibodyPlant
    model: ModelInstanceIndex
    simulator: Simulator
    embodiment: Embodiment
    scenario: Scenario
    meshcat: Meshcat | None = None
    systems: dict = field(default_factory=dict)  # name -> every named system of the diagram
    objects: dict = field(default_factory=dict)  # object name -> model instance
    reference: MotionClip | None = None

    def plant_context(self):
        return self.plant.GetMyContextFromRoot(self.simulator.get_context())

    def pelvis_height(self) -> float:
        body = self.plant.GetBodyByName(self.embodiment.key_bodies["pelvis"], self.model)
        return float(self.plant.EvalBodyPoseInWorld(self.plant_context(), body).translation()[2])

    def fall_check(self) -> FallCheck:
        return FallCheck(self.plant, self.model, self.embodiment, fixed_base=self.scenario.fixed_base)

    def joint_positions(self) -> dict[str, float]:
        context = self.plant_context()
        return {
            name: float(self.plant.GetJointByName(name, self.model).GetOnePosition(context))
            for name in self.embodiment.joint_names
        }

    def output(self, name: str) -> np.ndarray:
        """Evaluate one of the diagram's exported vector outputs (e.g. `observation`)."""
        return self.diagram.GetOutputPort(name).Eval(self.simulator.get_context())


@dataclass
class ScenarioSystems:
    """A scenario's systems in a `DiagramBuilder` (what `AddScenario` returns).

    `outputs` and `inputs` are the ports `build_simulation` exports from its
    diagram, by the same names: connect or export them in your own diagram
    (or `hold_inputs_at_rest`). After `Build`, `set_initial_state` on your
    diagram's context starts the scenario as `build_simulation` does.
    """

    plant: MultibodyPlant
    scene_graph: SceneGraph
    model: ModelInstanceIndex
    embodiment: Embodiment
    scenario: Scenario
    systems: dict[str, System]  # name -> every system the scenario added
    outputs: dict[str, OutputPort]  # observation, amp_observation, action, interaction, ...
    inputs: dict[str, InputPort]  # action (ActionInput), twist (BaseTwist)
    objects: dict = field(default_factory=dict)  # object name -> model instance
    reference: MotionClip | None = None
    cubes: list = field(default_factory=list)  # perturbation cubes' model instances

    def hold_inputs_at_rest(self, builder: DiagramBuilder) -> None:
        """Feed each of `inputs` that is neither connected nor exported yet a
        constant at rest (`<name>_at_rest`: the standing action, zero twist),
        as `build_simulation` holds them. Call it after your own wiring, before `Build`."""
        for name, port in self.inputs.items():
            if not builder.IsConnectedOrExported(port):
                rest = ConstantVectorSource(_rest_value(name, port, self.embodiment))
                builder.Connect(builder.AddNamedSystem(f"{name}_at_rest", rest).get_output_port(), port)

    def set_initial_state(self, context: Context) -> None:
        """Start the scenario in `context`, the root context of the diagram
        holding these systems, as `build_simulation` does: the robot standing
        (dropped) or on its reference clip, objects and cubes placed. Call it
        before `Simulator.Initialize()`, and again to restart."""
        plant, scenario = self.plant, self.scenario
        plant_context = plant.GetMyMutableContextFromRoot(context)
        fixed = scenario.fixed_base and self.embodiment.floating_base
        playback = _initial_playback(scenario, self.reference)
        drop = scenario.initial.drop_height
        set_robot_state(plant, plant_context, self.model, self.embodiment, playback, drop_height=drop, fixed=fixed)
        place_objects(plant, plant_context, self.objects, scenario.objects)
        place_perturbation_cubes(plant, plant_context, self.cubes, scenario.perturbations)


@dataclass
class DiagramParts:
    """What the driver helpers below add systems with."""

    builder: DiagramBuilder
    plant: MultibodyPlant
    scene_graph: SceneGraph
    model: ModelInstanceIndex
    embodiment: Embodiment
    scenario: Scenario
    clip: MotionClip | None
    graph: InteractionGraphSystem | None = None  # with a task object
    objects: dict = field(default_factory=dict)  # object name -> model instance
    outputs: dict = field(default_factory=dict)  # name -> OutputPort, what build_simulation exports
    inputs: dict = field(default_factory=dict)  # name -> InputPort, what build_simulation exports

    @property
    def explicit(self) -> bool:
        return self.scenario.controller == "explicit"

    def observation(self) -> ObservationSystem:
        """The ObservationSystem, added (and its outputs listed) on first use."""
        if not self.builder.HasSubsystemNamed("observation"):
            observation = AddObservation(self.builder, self.plant, self.model, self.embodiment)
            self.outputs["observation"] = observation.GetOutputPort("observation")
            self.outputs["amp_observation"] = observation.GetOutputPort("amp_observation")
        return self.builder.GetSubsystemByName("observation")


def AddScenario(
    builder: DiagramBuilder,
    scenario: Scenario,
    meshcat: Meshcat | None = None,
    embodiment: Embodiment | None = None,
) -> ScenarioSystems:
    """Add the systems a scenario describes to `builder` (plant and scene
    graph included), leaving `Build` to the caller so that their own systems
    can join them. `embodiment` overrides the scenario's (e.g. a resized UDH).
    A scenario that varies (`vary`) is built as the member its `seed` draws."""
    scenario, _ = scenario.drawn()
    emb = embodiment or embodiments.load(scenario.embodiment, scenario.hands)
    clip = _led_in(scenario, emb, _reference_clip(scenario, emb))
    fixed = scenario.fixed_base and emb.floating_base
    before = {system.get_name() for system in builder.GetSystems()}
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    height = emb.standing_root_height + scenario.initial.drop_height if fixed else None
    model = add_robot(
        plant,
        scene_graph,
        emb,
        builtin_pd=scenario.controller == "implicit",
        self_collision=scenario.self_collision,
        fixed_base_height=height,
    )
    add_ground(plant)
    objects = add_scene_objects(plant, scenario.objects)
    cubes = add_perturbation_cubes(plant, scenario.perturbations)
    plant.Finalize()
    if actuated_joint_order(plant, model) != emb.joint_names:
        raise RuntimeError(f"{emb.name}: actuator order differs from the spec's joint order")

    parts = DiagramParts(builder, plant, scene_graph, model, emb, scenario, clip, objects=objects)
    task = [o for o in scenario.objects if o.is_task_object]
    if task and {"left_hand", "right_hand", "pelvis"} <= emb.key_bodies.keys():
        bodies = {o.instance_name: object_body(plant, objects, o) for o in task}
        targets = np.array([o.target or o.position for o in task], dtype=float)
        graph = parts.graph = AddInteractionGraph(builder, plant, scene_graph, model, emb, bodies, targets)
        for name in ("interaction", "goal"):
            parts.outputs[name] = graph.GetOutputPort(name)
        parts.outputs["interaction_graph"] = graph.GetOutputPort("graph")
    AddPdControl(builder, plant, model, emb, add_driver(scenario.driver, parts), explicit=parts.explicit)
    if scenario.observation:
        parts.observation()
    forces = []
    if cubes:
        torso = plant.GetBodyByName(emb.key_bodies["torso"], model)
        thrower = AddPerturbation(builder, plant, cubes, scenario.perturbations, torso, scenario.time_step)
        forces.append(thrower.GetOutputPort("spatial_forces"))
    held = [object_body(plant, objects, o) for o in scenario.objects if o.held]
    if held:
        holder = AddObjectHolder(builder, plant, scene_graph, model, held, 1.0 / scenario.control_rate)
        forces.append(holder.GetOutputPort("spatial_forces"))
    connect_applied_forces(builder, plant, forces)
    if meshcat is not None:
        # Drake's visualizer also publishes over LCM: keep that in memory (no
        # network needed), owned by the diagram.
        lcm = SharedPointerSystem.AddToBuilder(builder, DrakeLcm("memq://"))
        ApplyVisualizationConfig(scenario.visualization, builder, None, plant, scene_graph, meshcat, lcm)
    systems = {system.get_name(): system for system in builder.GetSystems() if system.get_name() not in before}
    return ScenarioSystems(
        plant, scene_graph, model, emb, scenario, systems, parts.outputs, parts.inputs, objects, clip, cubes
    )


def build_simulation(
    scenario: Scenario, meshcat: Meshcat | None = None, embodiment: Embodiment | None = None
) -> Simulation:
    """Build the diagram a scenario describes, its ports exported, and
    initialise its simulator (`AddScenario` on a fresh builder).
    `embodiment` overrides the scenario's (e.g. a resized UDH)."""
    builder = DiagramBuilder()
    parts = AddScenario(builder, scenario, meshcat, embodiment)
    for name, port in parts.outputs.items():
        builder.ExportOutput(port, name)
    for name, port in parts.inputs.items():
        builder.ExportInput(port, name)
    diagram = builder.Build()

    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    _hold_exported_inputs(diagram, context, parts.embodiment)
    parts.set_initial_state(context)
    simulator.Initialize()
    systems = {system.get_name(): system for system in diagram.GetSystems()}
    plant, model, emb = parts.plant, parts.model, parts.embodiment
    return Simulation(
        diagram, plant, model, simulator, emb, parts.scenario, meshcat, systems, parts.objects, parts.reference
    )


def build_standing_simulation(
    embodiment: Embodiment,
    plant_config=None,
    drop_height: float = 0.1,
    meshcat: Meshcat | None = None,
    base_command: bool = False,
    perturbations: list | None = None,
    self_collision: bool = True,
) -> Simulation:
    """Drop an embodiment from `drop_height` with its PD holding the standing
    pose (optionally throwing `perturbations`, a list of `CubeLaunch`; with
    `base_command` a planar base follows the exported `twist` input)."""
    scenario = Scenario(
        embodiment=embodiment.name,
        hands=embodiment.hands,
        self_collision=self_collision,
        initial=InitialCondition(drop_height=drop_height),
        driver=BaseTwist() if base_command else StandingPose(),
        perturbations=list(perturbations or []),
    )
    if plant_config is not None:
        scenario.plant_config = plant_config
    return build_simulation(scenario, meshcat, embodiment=embodiment)


# --- drivers: what sets the PD targets ------------------------------------------------


# -- running a scenario ------------------------------------------------------------


CHUNK = 0.05  # s between checks of falls and torques


def state_checksum(values: np.ndarray) -> str:
    """A short digest of a state, rounded so it is stable on one machine
    (not across machines: a value near a rounding boundary may round the
    other way; compare `run(..., state=True)`'s positions and velocities with a tolerance)."""
    rounded = np.round(np.asarray(values, dtype=float), 6) + 0.0  # no negative zeros
    return hashlib.sha256(rounded.tobytes()).hexdigest()[:16]


def run_scenario(scenario: Scenario, duration: float | None = None, meshcat=None, state: bool = False) -> dict:
    """Simulate a scenario; the figures `python -m hotu_drake.simulate`
    prints: `realtime_factor`, `fell` (a body other than a foot touched the
    floor, or the pelvis dropped below half its standing height),
    `min_pelvis_height`, `max_torque_ratio` (largest |torque| over its
    effort limit), `checksum` (`state_checksum` of the final state) and,
    tracking a reference, `tracking_rms` (rad, joint positions against the
    reference, sampled every 50 ms), `root_travel_m` (the pelvis'
    horizontal displacement over the run) and, following a clip (the
    whole-body controller, or a clone asked for a motion),
    `reference_travel_m` (its clip's over the same time, looping with its
    root motion), under the whole-body controller `catch_steps` (the steps
    it took of its own to catch the robot: time, foot); with `state`, the
    final `positions` and `velocities`."""
    sim = build_simulation(scenario, meshcat=meshcat)
    emb, plant, context = sim.embodiment, sim.plant, sim.plant_context()
    fall = sim.fall_check()
    floating = fall.can_fall
    tracking = sim.diagram.HasOutputPort("reference_joint_positions")
    end = duration if duration is not None else scenario.duration
    pelvis = plant.GetBodyByName(emb.key_bodies["pelvis"], sim.model)
    start_position = plant.EvalBodyPoseInWorld(context, pelvis).translation().copy()
    fell, lowest, torque_ratio, wall, errors = False, np.inf, 0.0, 0.0, []
    if meshcat is not None:
        meshcat.StartRecording(set_visualizations_while_recording=False)
    t = 0.0
    while t < end - 1e-9:
        t = min(end, t + CHUNK)
        start = time.perf_counter()
        sim.simulator.AdvanceTo(t)
        wall += time.perf_counter() - start
        torques = plant.get_net_actuation_output_port(sim.model).Eval(context)
        torque_ratio = max(torque_ratio, float(np.max(np.abs(torques) / emb.effort_limits)))
        if floating:
            lowest = min(lowest, fall.pelvis_height(context))
            fell = fell or fall(context)
        if tracking:
            reference = sim.output("reference_joint_positions")
            errors.append(np.fromiter(sim.joint_positions().values(), float) - reference)
    if meshcat is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
    figures = {
        "scenario": scenario.embodiment,
        "duration": end,
        "realtime_factor": round(end / wall, 2) if wall > 0 else None,
        "fell": bool(fell),
        "min_pelvis_height": round(float(lowest), 4) if floating else None,
        "max_torque_ratio": round(torque_ratio, 4),
        "checksum": state_checksum(plant.GetPositionsAndVelocities(context)),
    }
    if state:
        figures["positions"] = plant.GetPositions(context).tolist()
        figures["velocities"] = plant.GetVelocities(context).tolist()
    if errors:
        figures["tracking_rms"] = round(float(np.sqrt(np.mean(np.square(errors)))), 4)
    moved = plant.EvalBodyPoseInWorld(context, pelvis).translation() - start_position
    figures["root_travel_m"] = round(float(np.linalg.norm(moved[:2])), 4)
    _, drawn = scenario.drawn()
    if drawn:
        figures |= {"seed": scenario.seed, "drawn": drawn}
    if "whole_body_controller" in sim.systems:
        controller = sim.systems["whole_body_controller"]
        figures["reference_travel_m"] = round(controller.reference_travel(end), 4)
        figures["catch_steps"] = controller.catch_steps()
    if "motion_reference" in sim.systems:  # a controller following a clip
        figures["reference_travel_m"] = round(sim.systems["motion_reference"].reference_travel(end), 4)
    return figures


@singledispatch
def add_driver(driver, parts: DiagramParts) -> OutputPort:
    """Add the systems of a scenario's driver; returns the PD targets port
    ([q*; v*] for the built-in PD, q* for the explicit controller)."""
    raise TypeError(f"unknown driver {type(driver).__name__}")


@add_driver.register
def _(driver: StandingPose, parts: DiagramParts) -> OutputPort:
    standing = parts.embodiment.standing_pose
    targets = standing if parts.explicit else np.concatenate([standing, np.zeros_like(standing)])
    return parts.builder.AddNamedSystem("standing_targets", ConstantVectorSource(targets)).get_output_port()


@add_driver.register
def _(driver: ReferenceTracking, parts: DiagramParts) -> OutputPort:
    source = _reference_source(parts.scenario, parts.embodiment, parts.clip, driver.loop)
    reference, targets = AddReferenceMotion(parts.builder, source, desired_state=not parts.explicit)
    parts.outputs["reference_joint_positions"] = reference.GetOutputPort("joint_positions")
    return targets


@add_driver.register
def _(driver: WholeBodyTracking, parts: DiagramParts) -> OutputPort:
    controller = AddWholeBodyController(
        parts.builder,
        parts.plant,
        parts.model,
        parts.embodiment,
        parts.clip,
        1.0 / parts.scenario.control_rate,
        driver.loop,
        start_time=max(parts.scenario.initial.reference_time, 0.0),
        plant_step=parts.scenario.time_step,
    )
    parts.outputs["whole_body_torques"] = controller.GetOutputPort("torques")
    return controller.GetOutputPort("desired_state")


@add_driver.register
def _(driver: PolicyCheckpoint, parts: DiagramParts) -> OutputPort:
    goal = GOAL_SIZE if parts.graph is not None else 0  # a one-level task policy also sees the goal
    path = parts.scenario.resolve(driver.checkpoint)
    network, meta = load_policy(path, parts.embodiment, goal)
    columns = [parts.observation().GetOutputPort("observation")]
    extras = observation_extras(meta)
    if extras:
        columns += _followed_motion(driver, parts, path, meta, extras)
    elif driver.latents not in LATENT_CHOICES:
        raise InputError(
            f"{path}: a motion by name is for a controller that follows a clip (observes its phase, reference "
            f"or pose); give this one {' or '.join(LATENT_CHOICES)}",
            parts.scenario.source or None,
            "driver.latents",
        )
    if network.config.observation_size != sum(column.size() for column in columns):
        columns.append(parts.graph.GetOutputPort("goal"))
    observation = columns[0]
    if len(columns) > 1:
        stacked = parts.builder.AddNamedSystem("policy_observation", Multiplexer([c.size() for c in columns]))
        for index, column in enumerate(columns):
            parts.builder.Connect(column, stacked.get_input_port(index))
        observation = stacked.get_output_port()
    rate = parts.scenario.control_rate
    latents = None
    if network.config.latent_sizes and driver.latents == "prior":
        prior = meta["latent"]
        groups = list(network.config.latent_sizes)
        low, high = int(prior["resample_min"]), int(prior["resample_max"])
        latents = AddLatentSampler(parts.builder, groups, int(prior["size"]), low, high, rate, driver.latent_seed)
    return _policy_targets(parts, network, observation, latents)


def _followed_motion(
    driver: PolicyCheckpoint, parts: DiagramParts, path, meta: dict, extras: tuple[str, ...]
) -> list[OutputPort]:
    """The `extras` (`phase`, `reference`, `pose`) of the motion a
    clip-following controller is asked for (`driver.latents`, one of its
    checkpoint's motions: a library name, or a `.npz` clip, relative to the
    scenario file), from a `MotionReference` placed where the robot starts."""
    scenario, where = parts.scenario, parts.scenario.source or None

    motions = [str(motion) for motion in meta.get("meta", {}).get("motions", [])]
    asked = motion_key(scenario.resolve(driver.latents)) if driver.latents.endswith(".npz") else driver.latents
    keys = [motion_key(motion) for motion in motions]
    if asked not in keys:
        raise InputError(
            f"{path}: the controller follows a clip: give latents one of its motions ({', '.join(motions)}), "
            f"not {driver.latents!r}",
            where,
            "driver.latents",
        )
    rate = meta.get("control_rate")
    if rate and abs(float(rate) - scenario.control_rate) > 1e-9:
        raise InputError(f"{path}: trained at {rate:g} Hz; give the scenario that control_rate", where, "control_rate")
    clip = parts.clip  # the scenario's reference motion: the followed one (`Scenario.followed_motion`)
    setting = meta["meta"]["config"]["environment"].get("loop", False)
    loop = looped_motions(setting, motions, f"{path}: environment.loop")[keys.index(asked)]
    follower = AddMotionReference(
        parts.builder,
        parts.plant,
        parts.model,
        parts.embodiment,
        clip,
        1.0 / scenario.control_rate,
        loop,
        start_time=max(scenario.initial.reference_time, 0.0),
    )
    ports = [follower.GetOutputPort(extra) for extra in extras]
    parts.outputs |= {f"motion_{extra}": port for extra, port in zip(extras, ports)}
    return ports


def _policy_targets(parts: DiagramParts, network, observation: OutputPort, latents) -> OutputPort:
    """A `PolicySystem` of `network` fed by `observation` and `latents`, its
    action exported and turned into PD targets (the policy drivers' common end)."""
    policy = AddPolicy(parts.builder, network, observation, parts.scenario.control_rate, latents)
    targets = AddActionToTargets(parts.builder, parts.embodiment, parts.explicit)
    parts.builder.Connect(policy.GetOutputPort("action"), targets.get_input_port())
    parts.outputs["action"] = policy.GetOutputPort("action")
    return targets.get_output_port()


@add_driver.register
def _(driver: SkillCheckpoint, parts: DiagramParts) -> OutputPort:
    scenario, emb, builder = parts.scenario, parts.embodiment, parts.builder
    if parts.graph is None:
        raise InputError(
            "!SkillCheckpoint needs a task object (a free box or drill)", scenario.source or None, "objects"
        )
    reference = _transfer_reference(driver, parts)
    size = reference.size if reference is not None else 0
    skill, meta = load_skill_policy(scenario.resolve(driver.skill), emb, reference_size=size)
    llc_path = scenario.resolve(driver.llc)
    network, _ = load_policy(llc_path, emb)
    groups = dict.fromkeys(meta["llc_groups"], int(meta["latent_size"]))
    if network.config.latent_sizes != groups:
        raise InputError(
            f"{llc_path}: its latents {network.config.latent_sizes} are not those the skill was trained over {groups}",
            scenario.source or None,
            "driver.llc",
        )
    observation = parts.observation().GetOutputPort("observation")
    rate = scenario.control_rate
    graph = parts.graph
    reference_port = None
    if reference is not None:
        task = next(o for o in scenario.objects if o.is_task_object)
        body = object_body(parts.plant, parts.objects, task)
        tracker = AddTransferReference(
            builder, parts.plant, parts.model, parts.observation(), reference, emb.spec.root.name, body
        )
        reference_port = tracker.GetOutputPort("reference")
        parts.outputs["transfer_reference"] = reference_port
    goal, interaction = graph.GetOutputPort("goal"), graph.GetOutputPort("interaction")
    latents = AddSkillPolicy(builder, skill, meta, observation, goal, interaction, rate, reference_port)
    parts.outputs["latents"] = latents.GetOutputPort("latents")
    return _policy_targets(parts, network, observation, latents)


def _transfer_reference(driver: SkillCheckpoint, parts: DiagramParts) -> TransferReference | None:
    """The reference clip a fine-tuned transfer layer tracks, checked against the robot and the task."""
    if not driver.reference:
        return None
    scenario = parts.scenario
    path = scenario.resolve(driver.reference)
    try:
        clip = MotionClip.load(path)
    except (ClipFormatError, OSError) as error:
        raise InputError(f"{path}: {error}", scenario.source or None, "driver.reference") from None
    if list(clip.joint_names) != list(parts.embodiment.joint_names):
        raise InputError(f"{path}: a clip of {clip.embodiment}, not of this robot", scenario.source or None)
    task = next(o for o in scenario.objects if o.is_task_object)
    return TransferReference(clip, task.kind, 1.0 / scenario.control_rate)


@add_driver.register
def _(driver: ActionInput, parts: DiagramParts) -> OutputPort:
    parts.observation()
    targets = AddActionToTargets(parts.builder, parts.embodiment, parts.explicit)
    parts.inputs["action"] = targets.get_input_port()
    return targets.get_output_port()


@add_driver.register
def _(driver: BaseTwist, parts: DiagramParts) -> OutputPort:
    command = AddPlanarBaseCommand(parts.builder, parts.embodiment, parts.scenario.time_step)
    parts.inputs["twist"] = command.GetInputPort("twist")
    return command.GetOutputPort("desired_state")


def _reference_clip(scenario: Scenario, emb: Embodiment) -> MotionClip | None:
    """The clip the scenario tracks or starts from, checked against its start time."""
    if not scenario.reference_motion:
        return None
    clip = reference_clip(scenario.reference_motion, emb, scenario.base_dir or None)
    if scenario.vary.reference_time and scenario.vary.reference_time[1] > clip.duration:
        raise InputError(
            f"vary.reference_time reaches {scenario.vary.reference_time[1]:g} s, beyond the {clip.duration:.2f} s "
            f"of {scenario.reference_motion}",
            scenario.source or None,
            "vary.reference_time",
        )
    if scenario.initial.reference_time > clip.duration:
        raise InputError(
            f"{scenario.initial.reference_time:g} s is beyond the {clip.duration:.2f} s of {scenario.reference_motion}",
            scenario.source or None,
            "initial.reference_time",
        )
    return clip


def _led_in(scenario: Scenario, emb: Embodiment, clip: MotionClip | None) -> MotionClip | None:
    """The clip a `!WholeBodyTracking` run performs: one that does not loop,
    started from its first frame, held there first (`WholeBodyTracking.lead_in`)."""
    driver = scenario.driver
    if clip is None or not isinstance(driver, WholeBodyTracking) or driver.loop:
        return clip
    if scenario.initial.reference_time != 0.0:  # a run started partway through moves at once
        return clip
    return clip.held_first(driver.lead_in if driver.lead_in >= 0.0 else lead_in_for(clip, emb))


def _reference_source(scenario: Scenario, emb: Embodiment, clip: MotionClip, loop: bool) -> ReferenceMotionSource:
    floating = emb.floating_base and not scenario.fixed_base
    return ReferenceMotionSource(clip, loop, floating, start_time=max(scenario.initial.reference_time, 0.0))


def _initial_playback(scenario: Scenario, clip: MotionClip | None) -> ClipPlayback | None:
    """The reference the robot starts in (reference state initialisation), if any."""
    if clip is None or scenario.initial.reference_time < 0:
        return None
    loop = scenario.driver.loop if isinstance(scenario.driver, ReferenceTracking | WholeBodyTracking) else True
    return ClipPlayback(clip, loop, start_time=scenario.initial.reference_time)


def _hold_exported_inputs(diagram: Diagram, context, emb: Embodiment) -> None:
    """Exported inputs start at rest: the standing action, zero twist."""
    for index in range(diagram.num_input_ports()):
        port = diagram.get_input_port(index)
        port.FixValue(context, _rest_value(port.get_name(), port, emb))


def _rest_value(name: str, port, emb: Embodiment) -> np.ndarray:
    """What a scenario input holds until a user sets it: the standing action, zero twist."""
    return standing_action(emb) if name == "action" else np.zeros(port.size())
