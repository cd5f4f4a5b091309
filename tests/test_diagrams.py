"""A scenario inside a larger diagram: `AddScenario` adds its systems to a
user's builder, the user adds and wires their own, and the run is the one
`build_simulation` makes of the same scenario."""

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem

from hotu_drake import embodiment
from hotu_drake.diagrams import AddScenario, build_simulation
from hotu_drake.embodiment.actions import ActionScaling, standing_action
from hotu_drake.scenario import ActionInput, InitialCondition, Scenario, load_scenario
from hotu_drake.systems.observation import observation_size


class RootHeightMonitor(LeafSystem):
    """A user's monitor: samples the root height (the first entry of the
    `observation` input) every `period`, keeping [latest, lowest, highest]."""

    def __init__(self, size: int, period: float):
        super().__init__()
        self.DeclareVectorInputPort("observation", size)
        heights = self.DeclareDiscreteState(np.array([np.nan, np.inf, -np.inf]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._sample)
        self.DeclareStateOutputPort("heights", heights)

    def _sample(self, context: Context, state) -> None:
        height = self.get_input_port().Eval(context)[0]
        _, lowest, highest = context.get_discrete_state_vector().value()
        state.set_value([height, min(lowest, height), max(highest, height)])


class StepCommand(LeafSystem):
    """A user's controller: the `action` output switches from `before` to `after` at `switch_time`."""

    def __init__(self, before: np.ndarray, after: np.ndarray, switch_time: float):
        super().__init__()
        self._before, self._after, self._switch = before, after, switch_time
        self.DeclareVectorOutputPort("action", len(before), self._action)

    def _action(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._after if context.get_time() >= self._switch else self._before)


def _run(builder: DiagramBuilder, scene, duration: float):
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    scene.set_initial_state(context)
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return diagram, context


def test_a_users_monitor_on_the_observation_sees_the_robot_stand_in_build_simulations_run():
    scenario = load_scenario("stand_h1")
    scenario.observation = True
    builder = DiagramBuilder()
    emb = embodiment.load("h1", "none")
    monitor = RootHeightMonitor(observation_size(emb), scenario.time_step)
    builder.AddNamedSystem("root_height_monitor", monitor)  # the user's systems may come first
    scene = AddScenario(builder, scenario, embodiment=emb)
    assert {"plant", "scene_graph", "standing_targets", "observation"} <= scene.systems.keys()
    assert "root_height_monitor" not in scene.systems
    assert list(scene.outputs) == ["observation", "amp_observation"] and not scene.inputs
    builder.Connect(scene.outputs["observation"], monitor.GetInputPort("observation"))
    builder.ExportOutput(scene.outputs["observation"], "observation")
    diagram, context = _run(builder, scene, 1.0)

    latest, lowest, highest = monitor.GetOutputPort("heights").Eval(monitor.GetMyContextFromRoot(context))
    assert emb.spec.root.name == emb.key_bodies["pelvis"]  # H1's root height is its pelvis height
    # Dropped from 0.1 m above standing height, it lands and stands.
    assert abs(highest - (emb.standing_pelvis_height + scenario.initial.drop_height)) < 1e-9
    assert abs(latest - emb.standing_pelvis_height) < 0.02
    assert lowest > 0.9 * emb.standing_pelvis_height

    sim = build_simulation(scenario)
    sim.simulator.AdvanceTo(1.0)
    state = scene.plant.GetPositionsAndVelocities(scene.plant.GetMyContextFromRoot(context))
    np.testing.assert_array_equal(state, sim.plant.GetPositionsAndVelocities(sim.plant_context()))
    np.testing.assert_array_equal(diagram.GetOutputPort("observation").Eval(context), sim.output("observation"))


def test_a_users_controller_drives_the_action_input_as_build_simulations_exported_input():
    scenario = Scenario(embodiment="h1", initial=InitialCondition(drop_height=0.0), driver=ActionInput())
    builder = DiagramBuilder()
    scene = AddScenario(builder, scenario)
    emb = scene.embodiment
    elbow = emb.joint_names.index("left_elbow_y")
    bent = emb.standing_pose.copy()
    bent[elbow] += 0.4
    rest, bend = standing_action(emb), ActionScaling.for_embodiment(emb).to_action(bent)
    switch = 0.26  # s, between two plant steps
    controller = builder.AddNamedSystem("step_command", StepCommand(rest, bend, switch))
    builder.Connect(controller.GetOutputPort("action"), scene.inputs["action"])
    scene.hold_inputs_at_rest(builder)  # nothing left to hold
    assert not builder.HasSubsystemNamed("action_at_rest")
    _, context = _run(builder, scene, 1.0)
    plant_context = scene.plant.GetMyContextFromRoot(context)
    elbow_joint = scene.plant.GetJointByName("left_elbow_y", scene.model)
    assert abs(elbow_joint.GetOnePosition(plant_context) - bent[elbow]) < 0.05  # from 0 rad

    sim = build_simulation(scenario)
    sim.simulator.AdvanceTo(switch)
    sim.diagram.GetInputPort("action").FixValue(sim.simulator.get_mutable_context(), bend)
    sim.simulator.AdvanceTo(1.0)
    state = scene.plant.GetPositionsAndVelocities(plant_context)
    np.testing.assert_array_equal(state, sim.plant.GetPositionsAndVelocities(sim.plant_context()))


def test_inputs_left_over_are_held_at_rest_as_in_build_simulation():
    scenario = Scenario(embodiment="h1", initial=InitialCondition(drop_height=0.05), driver=ActionInput())
    builder = DiagramBuilder()
    scene = AddScenario(builder, scenario)
    scene.hold_inputs_at_rest(builder)
    rest = builder.GetSubsystemByName("action_at_rest")
    _, context = _run(builder, scene, 0.5)
    np.testing.assert_array_equal(
        rest.get_output_port().Eval(rest.GetMyContextFromRoot(context)), standing_action(scene.embodiment)
    )
    sim = build_simulation(scenario)
    sim.simulator.AdvanceTo(0.5)
    state = scene.plant.GetPositionsAndVelocities(scene.plant.GetMyContextFromRoot(context))
    np.testing.assert_array_equal(state, sim.plant.GetPositionsAndVelocities(sim.plant_context()))

    # An exported input is the user's to fix: it is not held.
    builder = DiagramBuilder()
    scene = AddScenario(builder, scenario)
    builder.ExportInput(scene.inputs["action"], "action")
    scene.hold_inputs_at_rest(builder)
    assert not builder.HasSubsystemNamed("action_at_rest")
