"""What a scenario can put in the diagram: reference tracking and reference
state initialisation, a policy, task objects held in the air, the
interaction graph, and clear errors for bad references and checkpoints."""

import numpy as np
import pytest
import torch

from hotu_drake import embodiment
from hotu_drake.diagrams import build_simulation
from hotu_drake.embodiment.actions import ActionScaling
from hotu_drake.errors import InputError
from hotu_drake.learning.checkpoint import save_checkpoint
from hotu_drake.objects import SceneObject
from hotu_drake.retarget.pipeline import library_clip
from hotu_drake.scenario import InitialCondition, PolicyCheckpoint, ReferenceTracking, Scenario, load_scenario
from hotu_drake.systems.policy import policy_for


def test_reference_state_initialisation_starts_on_the_clip():
    clip = library_clip("walk", "h1", "none")
    t0 = 1.0
    scenario = Scenario(
        embodiment="h1",
        initial=InitialCondition(reference_time=t0),
        driver=ReferenceTracking(motion="walk"),
    )
    sim = build_simulation(scenario)
    frame = int(round(t0 * clip.fps))
    q = np.fromiter(sim.joint_positions().values(), float)
    np.testing.assert_allclose(q, clip.joint_positions[frame], atol=1e-9)
    root = sim.plant.GetBodyByName(sim.embodiment.spec.root.name, sim.model)
    pose = sim.plant.EvalBodyPoseInWorld(sim.plant_context(), root)
    np.testing.assert_allclose(pose.translation(), clip.root_position[frame], atol=1e-9)
    # The reference plays on from t0: at t = 0 it outputs the clip's frame at t0.
    np.testing.assert_allclose(sim.output("reference_joint_positions"), clip.joint_positions[frame], atol=1e-9)


def test_fixed_base_tracking_scenario_follows_the_walk():
    from hotu_drake.diagrams import run_scenario as run

    figures = run(load_scenario("track_walk_udh"), duration=1.0)
    assert figures["tracking_rms"] < 0.05  # rad
    assert figures["max_torque_ratio"] <= 1.0 + 1e-9


def test_policy_drives_the_pd_targets_through_the_action_scaling(tmp_path):
    h1 = embodiment.load("h1", "none")
    network = policy_for(h1, seed=3)
    path = save_checkpoint(tmp_path / "policy.pt", network, "h1", "none")
    driver = PolicyCheckpoint(str(path), latents="zero")
    scenario = Scenario(embodiment="h1", initial=InitialCondition(drop_height=0.0), driver=driver, control_rate=20.0)
    sim = build_simulation(scenario)
    latents = {part: torch.zeros(1, size) for part, size in network.config.latent_sizes.items()}

    def network_action() -> np.ndarray:
        with torch.no_grad():
            observation = torch.as_tensor(sim.output("observation"), dtype=torch.float32)[None]
            return network(observation, latents)[0].numpy()

    # The policy updates at 0.1 s together with a plant step; it sees the
    # state before or after that step (Drake 1.51: after), never another.
    sim.simulator.AdvanceTo(0.1)
    before = network_action()
    sim.simulator.AdvanceTo(0.102)
    action, after = sim.output("action"), network_action()
    assert np.allclose(action, after, atol=1e-6) or np.allclose(action, before, atol=1e-6)
    sim.simulator.AdvanceTo(0.149)  # held until the next update
    np.testing.assert_array_equal(sim.output("action"), action)
    targets = sim.diagram.GetSubsystemByName("action_to_targets")
    desired = targets.get_output_port().Eval(targets.GetMyContextFromRoot(sim.simulator.get_context()))
    n = len(h1.joint_names)
    np.testing.assert_allclose(desired[:n], ActionScaling.for_embodiment(h1).to_targets(action), atol=1e-12)
    np.testing.assert_array_equal(desired[n:], np.zeros(n))


def test_policy_diagram_replays_the_environments_episode(tmp_path):
    """The plant applies each new action at the instant it is chosen, as in
    the environment a policy was trained in: a one-step delay in the
    diagram made trained policies fall in replays that stood in training."""
    import dataclasses

    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401

    env = gym.make("hotu_drake/Imitation-v0", robot="h1", hands="none", motions=["walk"], drop_height=0.0)
    unwrapped = env.unwrapped
    network = policy_for(unwrapped.embodiment, seed=3)
    path = save_checkpoint(tmp_path / "policy.pt", network, "h1", "none")
    latents = {part: torch.zeros(1, size) for part, size in network.config.latent_sizes.items()}
    observation, _ = env.reset(seed=0, options={"init": "default"})
    env_observations = []
    for _ in range(10):
        with torch.no_grad():
            action = network(torch.as_tensor(observation, dtype=torch.float32)[None], latents)[0].numpy()
        observation, *_ = env.step(action)
        env_observations.append(observation)
    scenario = dataclasses.replace(
        unwrapped.sim.scenario, driver=PolicyCheckpoint(str(path), latents="zero"), objects=[]
    )
    sim = build_simulation(scenario)
    for step, expected in enumerate(env_observations, start=1):
        sim.simulator.AdvanceTo(step * unwrapped.control_period)
        np.testing.assert_allclose(sim.output("observation"), expected, atol=1e-4, err_msg=f"step {step}")


def test_a_checkpoint_for_another_robot_is_refused(tmp_path):
    path = save_checkpoint(tmp_path / "udh.pt", policy_for(embodiment.load("udh", "none")), "udh", "none")
    with pytest.raises(InputError, match="udh.pt.*drives udh"):
        build_simulation(Scenario(embodiment="h1", driver=PolicyCheckpoint(str(path))))


def test_a_reference_that_is_not_a_motion_or_clip_is_refused(tmp_path):
    with pytest.raises(InputError, match="moonwalk"):
        build_simulation(Scenario(embodiment="h1", driver=ReferenceTracking(motion=str(tmp_path / "moonwalk"))))
    clip_path = library_clip("squat", "udh", "none").save(tmp_path / "udh_squat.npz")
    with pytest.raises(InputError, match="for 'udh', not h1"):
        build_simulation(Scenario(embodiment="h1", driver=ReferenceTracking(motion=str(clip_path))))


def _hand_position(name: str, hands: str, side: str = "right") -> np.ndarray:
    sim = build_simulation(Scenario(embodiment=name, hands=hands, initial=InitialCondition(drop_height=0.0)))
    hand = sim.plant.GetBodyByName(sim.embodiment.key_bodies[f"{side}_hand"], sim.model)
    return sim.plant.EvalBodyPoseInWorld(sim.plant_context(), hand).translation()


def test_held_box_floats_until_the_robot_touches_it_then_falls():
    hand = _hand_position("udh", "none")
    touching = (hand + [0.0, 0.0, -0.17]).tolist()  # top face just inside the hand
    away = [1.0, -1.0, 1.0]
    scenario = Scenario(
        embodiment="udh",
        initial=InitialCondition(drop_height=0.0),
        objects=[
            SceneObject(kind="box", name="touched", position=touching, held=True),
            SceneObject(kind="box", name="untouched", position=away, held=True, target=[2.0, 0.0, 1.0]),
        ],
    )
    sim = build_simulation(scenario)
    sim.simulator.AdvanceTo(1.0)
    context = sim.plant_context()

    def height(name):
        body = sim.plant.GetBodyByName("box", sim.objects[name])
        return sim.plant.EvalBodyPoseInWorld(context, body).translation()[2]

    holder = sim.systems["object_holder"]
    released = holder.GetOutputPort("released").Eval(holder.GetMyContextFromRoot(sim.simulator.get_context()))
    np.testing.assert_array_equal(released, [1.0, 0.0])
    assert height("untouched") == pytest.approx(away[2], abs=1e-3)
    assert height("touched") < touching[2] - 0.3  # fell toward the floor
    # The interaction graph sees both boxes; the untouched one's d_og is target - position.
    s_i = sim.output("interaction")
    d_og = s_i[3 * 2 * 2 : 3 * 2 * 2 + 6].reshape(2, 3)
    np.testing.assert_allclose(d_og[1], np.array([2.0, 0.0, 1.0]) - np.array(away), atol=1e-3)


def test_box_scenario_holds_its_box_and_reports_the_interaction():
    scenario = load_scenario("box_udh")
    sim = build_simulation(scenario)
    sim.simulator.AdvanceTo(0.5)
    box = scenario.objects[0]
    body = sim.plant.GetBodyByName("box", sim.objects["box"])
    position = sim.plant.EvalBodyPoseInWorld(sim.plant_context(), body).translation()
    np.testing.assert_allclose(position, box.position, atol=1e-3)
    s_i = sim.output("interaction")
    assert s_i.shape == (3 * 2 + 3 + 2,)
    np.testing.assert_allclose(s_i[6:9], np.array(box.target) - position, atol=1e-9)
    np.testing.assert_array_equal(s_i[9:], [0.0, 0.0])  # no hand touches it
    assert sim.output("amp_observation").size > 0


def test_bad_scenario_fields_name_the_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("embodiment: udh\nobjects:\n  - kind: piano\n")
    with pytest.raises(InputError, match=rf"{bad}: objects\[0\].kind: 'piano' is not one of box"):
        load_scenario(bad)
    bad.write_text("embodiment: udh\ndriver: !PolicyCheckpoint\n  checkpoint: missing.pt\n")
    with pytest.raises(InputError, match="checkpoint 'missing.pt' not found"):
        load_scenario(bad)
    bad.write_text("embodiment: udh\npolicy:\n  checkpoint: missing.pt\n")  # the 0.1 layout
    with pytest.raises(InputError, match="checkpoint 'missing.pt' not found"):
        load_scenario(bad)
    bad.write_text("embodiment: udh\ninitial:\n  reference_time: 0.5\n")
    with pytest.raises(InputError, match="needs a reference motion"):
        load_scenario(bad)


def test_a_scenario_that_varies_runs_the_member_its_seed_draws(tmp_path):
    """`vary` makes a scenario a family: `simulate --seed N` runs the member
    seed N draws (the same seed, the same member; another seed, another),
    the figures say what was drawn, and a task object's instance comes from
    its task's own distribution."""
    import json
    import subprocess
    import sys

    from hotu_drake.motion.library.object_tasks import BOX_CARRY_RANGES

    path = tmp_path / "family.yaml"
    path.write_text("embodiment: h1\nduration: 0.2\nvary:\n  drop_height: [0.0, 0.2]\n")
    runs = []
    for seed in (1, 1, 2):
        command = [sys.executable, "-m", "hotu_drake.simulate", str(path), "--seed", str(seed), "--json"]
        result = subprocess.run(command, capture_output=True, text=True, timeout=300)
        assert result.returncode == 0, result.stderr
        runs.append(json.loads(result.stdout))
    heights = [run["drawn"]["initial.drop_height"] for run in runs]
    assert heights[0] == heights[1] != heights[2] and all(0.0 <= h <= 0.2 for h in heights)
    assert [run["seed"] for run in runs] == [1, 1, 2]
    command = [sys.executable, "-m", "hotu_drake.simulate", str(path), "--seed", "1", "--seeds", "2", "--json"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    both = json.loads(result.stdout)  # members 1 and 2, as run one by one, and their summary
    assert [run["drawn"] for run in both["runs"]] == [runs[0]["drawn"], runs[2]["drawn"]]
    fell = sum(run["fell"] for run in both["runs"])
    assert both["seeds"] == [1, 2] and both["summary"]["runs"] == 2 and both["summary"]["falls"] == fell
    travel = np.mean([run["root_travel_m"] for run in both["runs"]])
    assert both["summary"]["mean_root_travel_m"] == pytest.approx(travel, abs=1e-4)
    box = load_scenario("box_udh")
    box.vary.task, box.seed = True, 5
    member, drawn = box.drawn()
    start, target = np.array(member.objects[0].position), np.array(member.objects[0].target)
    low, high = BOX_CARRY_RANGES["start_distance"]
    assert low <= np.hypot(*start[:2]) <= high and drawn["box.target"] == list(np.round(target, 4))
    written, drawn = load_scenario("box_udh").drawn()  # nothing varies: as written
    assert drawn == {} and written.to_yaml() == load_scenario("box_udh").to_yaml()


def _clip_following_checkpoint(tmp_path, network, inner, motions=("walk",), loop=True) -> str:
    """A checkpoint of `network` recorded as a DAgger clone of `inner`'s
    walk (or `motions`) that observes its phase, reference and pose,
    trained at its rate."""
    environment = {"phase_observation": True, "reference_observation": True, "pose_observation": True, "loop": loop}
    meta = {"algo": "dagger", "motions": list(motions), "config": {"environment": environment}}
    path = save_checkpoint(tmp_path / "clone.pt", network, "h1", "none", meta, control_rate=1.0 / inner.control_period)
    return str(path)


def test_a_clip_following_clone_replays_its_environments_episode(tmp_path):
    """A clone that observes its clip's phase, reference and pose is asked for
    its motion by name (`latents: walk`): the diagram's policy observes
    what the environment gave it (`systems.motion_reference`), step by
    step from the same reference start, and the run reports the clip's
    travel."""
    import dataclasses

    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401
    from hotu_drake.diagrams import run_scenario
    from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork

    env = gym.make(
        "hotu_drake/Imitation-v0",
        robot="h1",
        hands="none",
        motions=["walk"],
        control_rate=60.0,
        loop=True,
        teacher=True,
        phase_observation=True,
        reference_observation=True,
        pose_observation=True,
    )
    inner = env.unwrapped
    torch.manual_seed(3)
    size, actions = env.observation_space.shape[0], env.action_space.shape[0]
    offset = tuple(float(a) for a in inner.standing_action())
    network = PolicyNetwork(PolicyConfig(size, actions, {}, (64,), action_offset=offset))
    path = _clip_following_checkpoint(tmp_path, network, inner)
    observation, _ = env.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.0})
    env_observations = [observation]
    for _ in range(10):
        with torch.no_grad():
            action = network(torch.as_tensor(observation, dtype=torch.float32)[None], {})[0].numpy()
        observation, *_ = env.step(action)
        env_observations.append(observation)
    initial = InitialCondition(drop_height=0.0, reference_time=0.0)  # on the motion the clone follows
    driver = PolicyCheckpoint(path, latents="walk")
    scenario = dataclasses.replace(inner.sim.scenario, driver=driver, initial=initial, objects=[])
    sim = build_simulation(scenario)
    stacked = sim.diagram.GetSubsystemByName("policy_observation")
    for step, expected in enumerate(env_observations):
        if step:
            sim.simulator.AdvanceTo(step * inner.control_period)
        given = stacked.get_output_port().Eval(stacked.GetMyContextFromRoot(sim.simulator.get_context()))
        np.testing.assert_allclose(given, expected, atol=1e-4, err_msg=f"step {step}")
    figures = run_scenario(dataclasses.replace(scenario, duration=1.0))
    assert figures["reference_travel_m"] > 0.2  # the walk's pelvis over its first second
    env.close()


def test_a_clone_of_several_motions_repeats_those_it_was_trained_to_repeat(tmp_path):
    """A clone trained with `loop: [walk]` over the walk and the squat
    follows its walk looped and its squat once, as its environments did."""
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401
    from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork

    extras = {"phase_observation": True, "reference_observation": True, "pose_observation": True}
    env = gym.make(
        "hotu_drake/Imitation-v0",
        robot="h1",
        hands="none",
        motions=["walk", "squat"],
        control_rate=60.0,
        teacher=True,
        loop=["walk"],
        **extras,
    )
    assert env.unwrapped.loops == (True, False)
    size, actions = env.observation_space.shape[0], env.action_space.shape[0]
    network = PolicyNetwork(PolicyConfig(size, actions, {}))
    path = _clip_following_checkpoint(tmp_path, network, env.unwrapped, ("walk", "squat"), ["walk"])
    env.close()
    for motion, looped in (("walk", True), ("squat", False)):
        scenario = Scenario(embodiment="h1", driver=PolicyCheckpoint(path, latents=motion), control_rate=60.0)
        scenario.initial = InitialCondition(drop_height=0.0)
        scenario.validate()
        sim = build_simulation(scenario)
        assert sim.diagram.GetSubsystemByName("motion_reference").loop is looped, motion


def test_a_clip_following_clone_needs_one_of_its_motions_at_its_rate(tmp_path):
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401
    from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork

    options = {"robot": "h1", "hands": "none", "motions": ["walk"], "control_rate": 60.0, "teacher": True}
    extras = {"phase_observation": True, "reference_observation": True, "pose_observation": True}
    env = gym.make("hotu_drake/Imitation-v0", **extras, **options)
    size, actions = env.observation_space.shape[0], env.action_space.shape[0]
    path = _clip_following_checkpoint(tmp_path, PolicyNetwork(PolicyConfig(size, actions, {})), env.unwrapped)
    env.close()
    scenario = Scenario(embodiment="h1", driver=PolicyCheckpoint(path, latents="prior"), control_rate=60.0)
    with pytest.raises(InputError, match="driver.latents.*one of its motions \\(walk\\)"):
        build_simulation(scenario)
    scenario.driver.latents = "squat"
    with pytest.raises(InputError, match="not 'squat'"):
        build_simulation(scenario)
    scenario.driver.latents, scenario.control_rate = "walk", 30.0
    with pytest.raises(InputError, match="trained at 60 Hz"):
        build_simulation(scenario)
    scenario.control_rate = 60.0
    scenario.initial = InitialCondition(reference_time=0.0, motion="squat")
    with pytest.raises(InputError, match="initial.motion: starts on 'squat' but its driver follows 'walk'"):
        scenario.validate()
    with pytest.raises(InputError, match="moonwalk.*nor a library motion"):
        Scenario(embodiment="h1", driver=PolicyCheckpoint(path, latents="moonwalk")).validate()
    other = save_checkpoint(tmp_path / "plain.pt", policy_for(embodiment.load("h1", "none")), "h1", "none")
    with pytest.raises(InputError, match="a motion by name is for a controller that follows a clip"):
        build_simulation(Scenario(embodiment="h1", driver=PolicyCheckpoint(str(other), latents="walk")))
