"""The gymnasium environments: standard, deterministic, and doing what they say."""

import logging

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import hotu_drake.envs  # noqa: F401  (registers the ids)
from hotu_drake.errors import InputError
from hotu_drake.motion.library import MOTIONS
from hotu_drake.retarget.references import reference_clips
from hotu_drake.systems.motion_reference import REFERENCE_SIZE
from hotu_drake.systems.observation import ROOT_FEATURES

WALK = ["walk"]


@pytest.fixture(scope="module")
def h1_env():
    env = gym.make("hotu_drake/Imitation-v0", robot="h1", hands="none", motions=WALK, amp_history=4)
    yield env
    env.close()


def _standing(env) -> np.ndarray:
    return env.unwrapped.standing_action().astype(np.float32)


def test_imitation_env_passes_the_gymnasium_checker(h1_env):
    check_env(h1_env.unwrapped, skip_render_check=True)
    assert h1_env.spec.max_episode_steps == 300


def test_amp_history_per_part_shifts_one_frame_per_step(h1_env):
    env = h1_env.unwrapped
    _, info = h1_env.reset(seed=1, options={"init": "default"})
    slices = env.part_slices
    assert set(info["amp"]) == set(slices) and "hip" in slices and "root" in slices
    for part, frames in info["amp"].items():
        assert frames.shape == (4, slices[part].stop - slices[part].start)
        np.testing.assert_array_equal(frames[0], frames[-1])  # filled with the first frame
    previous = info["amp"]
    for _ in range(3):
        _, _, _, _, info = h1_env.step(_standing(h1_env))
        for part in slices:
            np.testing.assert_array_equal(info["amp"][part][:-1], previous[part][1:])
        previous = info["amp"]
    assert not np.array_equal(previous["hip"][-1], previous["hip"][0])  # it moved: the drop


def test_reference_state_initialisation_starts_on_the_clip(h1_env):
    env = h1_env.unwrapped
    clip = env.clips[0]
    observation, info = h1_env.reset(seed=0, options={"init": "reference", "clip": 0, "time": 1.0})
    assert info["init"] == "reference"
    n = len(env.embodiment.joint_names)
    frame = int(round(1.0 * clip.fps))
    np.testing.assert_allclose(observation[ROOT_FEATURES : ROOT_FEATURES + n], clip.joint_positions[frame], atol=1e-5)
    assert observation[0] == pytest.approx(clip.root_position[frame, 2], abs=1e-5)  # root height
    # Moved over the origin, facing +x (tasks place their objects from there).
    root = env.sim.plant.EvalBodyPoseInWorld(env._plant_context, env._root)
    np.testing.assert_allclose(root.translation()[:2], [0.0, 0.0], atol=1e-9)
    forward = root.rotation().matrix()[:, 0]
    assert forward[1] == pytest.approx(0.0, abs=1e-9) and forward[0] > 0
    # The AMP history is the clip's own past: frame k is the clip 1/30 s before frame k + 1.
    frames = info["amp"]["hip"]
    hip = env.part_slices["hip"]
    for k, back in enumerate(range(env.amp_history - 1, 0, -1)):
        expected = env.clip_amp_frame(0, 1.0 - back * env.control_period)[hip]
        np.testing.assert_allclose(frames[k], expected, atol=1e-5)
    assert not np.allclose(frames[0], frames[-1])


def test_the_control_period_must_be_whole_steps():
    with pytest.raises(ValueError, match="whole number"):
        gym.make("hotu_drake/Imitation-v0", robot="bruce", motions="walk", time_step=0.005)


def test_same_seed_same_episode():
    def episode(seed):
        env = gym.make("hotu_drake/Imitation-v0", robot="bruce", hands="none", motions=WALK)
        observation, _ = env.reset(seed=seed)
        rng = np.random.default_rng(0)
        trace = [observation]
        for _ in range(15):
            action = np.clip(_standing(env) + 0.1 * rng.standard_normal(env.action_space.shape), -1, 1)
            trace.append(env.step(action.astype(np.float32))[0])
        env.close()
        return np.array(trace)

    first, second, other = episode(7), episode(7), episode(8)
    np.testing.assert_array_equal(first, second)
    assert not np.array_equal(first, other)


def test_falling_terminates_the_episode(h1_env):
    h1_env.reset(seed=0, options={"init": "default"})
    limp = -np.ones(h1_env.action_space.shape, dtype=np.float32)  # every joint to its lower limit
    steps = 0
    terminated = truncated = False
    while not (terminated or truncated) and steps < 90:
        _, _, terminated, truncated, _ = h1_env.step(limp)
        steps += 1
    assert terminated and not truncated
    assert h1_env.unwrapped.pelvis_height() < 0.9 * h1_env.unwrapped.embodiment.standing_pelvis_height


def test_a_simulation_failure_truncates_with_a_warning(h1_env, caplog):
    env = h1_env.unwrapped
    h1_env.reset(seed=0, options={"init": "default"})

    def fail(_time):
        raise RuntimeError("SAP solver failed to converge")

    last, _, _, _, _ = h1_env.step(_standing(h1_env))
    env._advance_to = fail
    try:
        with caplog.at_level(logging.WARNING, logger="hotu_drake.envs"):
            observation, reward, terminated, truncated, info = h1_env.step(_standing(h1_env))
    finally:
        del env._advance_to
    assert truncated and not terminated and reward == 0.0
    assert info["simulation_failure"] == "SAP solver failed to converge"
    assert "simulation failed" in caplog.text
    np.testing.assert_array_equal(observation, last)  # the last good observation, not a broken one

    # A state that diverges without an exception ends the same way.
    h1_env.reset(seed=0, options={"init": "default"})
    env._observe = lambda: np.full(env.observation_space.shape, np.nan, dtype=np.float32)
    try:
        observation, _, terminated, truncated, info = h1_env.step(_standing(h1_env))
    finally:
        del env._observe
    assert truncated and not terminated and np.all(np.isfinite(observation))
    assert "diverged" in info["simulation_failure"]


def test_bad_actions_and_motions_are_refused(h1_env):
    h1_env.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        h1_env.step(np.full(h1_env.action_space.shape, np.nan, dtype=np.float32))
    with pytest.raises(InputError, match="moonwalk"):
        gym.make("hotu_drake/Imitation-v0", robot="h1", motions=["moonwalk"])


def test_default_motions_are_the_whole_library(monkeypatch):
    import hotu_drake.retarget.references as motions
    from hotu_drake import embodiment

    h1 = embodiment.load("h1", "none")
    walk = reference_clips(h1, WALK)[0]
    asked = []  # record the motions asked for instead of retargeting thirteen clips
    monkeypatch.setattr(motions, "library_clip_cached", lambda motion, emb: asked.append(motion) or walk)
    assert len(motions.reference_clips(h1)) == len(MOTIONS)
    assert asked == list(MOTIONS)


def test_box_carry_goal_reward_and_interaction():
    env = gym.make("hotu_drake/BoxCarry-v0", motions=WALK)
    check_env(env.unwrapped, skip_render_check=True)
    inner = env.unwrapped
    assert inner.embodiment.name == "udh"
    observation, info = env.reset(seed=3, options={"init": "default"})
    assert observation.shape == env.observation_space.shape
    goal = info["goal"]
    start = goal["start_position"]
    assert 0.5 <= np.hypot(start[0], start[1]) <= 0.8 and 0.75 <= start[2] <= 1.0
    assert 1.0 <= np.hypot(*goal["target"][:2]) <= 3.0
    assert info["interaction"].shape == (11,)  # d_ho (2 hands x 3), d_og (3), e_ho (2)
    for _ in range(10):
        _, reward, _, _, info = env.step(_standing(env))
    np.testing.assert_allclose(inner.object_position(), start, atol=2e-3)  # held in the air
    heading = _heading(inner)  # s_I is in the pelvis' heading frame
    d_og = heading @ (goal["target"] - inner.object_position())
    np.testing.assert_allclose(info["interaction"][6:9], d_og, atol=1e-5)
    terms = info["reward_terms"]
    distance = np.linalg.norm(inner.object_position() - goal["target"])
    assert terms["delivery"] == pytest.approx(np.exp(-0.5 * distance**2), rel=1e-6)
    assert terms["carrying"] == 0.0 and 0.0 <= reward <= 1.0
    assert reward == pytest.approx(0.2 * terms["approach"] + 0.5 * terms["delivery"], rel=1e-6)
    env.close()


def _heading(env) -> np.ndarray:
    from hotu_drake.rotations import heading_rotation

    plant = env.sim.plant
    pelvis = plant.GetBodyByName(env.embodiment.key_bodies["pelvis"], env.sim.model)
    return heading_rotation(plant.EvalBodyPoseInWorld(env._plant_context, pelvis).rotation().matrix()).T


def test_box_carry_success_needs_the_box_resting_near_the_target_for_a_second():
    from pydrake.math import RigidTransform

    env = gym.make("hotu_drake/BoxCarry-v0", motions=WALK)
    inner = env.unwrapped
    _, info = env.reset(seed=5, options={"init": "default"})
    target = info["goal"]["target"]
    marker = inner.sim.plant.GetBodyByName("target_marker", inner.sim.objects["box_target"])
    np.testing.assert_allclose(inner.sim.plant.EvalBodyPoseInWorld(inner._plant_context, marker).translation(), target)
    box = inner._object_body
    inner.sim.plant.SetFreeBodyPose(inner._plant_context, box, RigidTransform(target + [0.12, 0.0, 0.0]))
    for _ in range(inner.hold_steps + 2):  # 12 cm away, held floating there: not a success
        _, _, _, _, info = env.step(_standing(env))
    assert not info["success"] and info["success_steps"] == 0
    inner.sim.plant.SetFreeBodyPose(inner._plant_context, box, RigidTransform(target + [0.08, 0.0, 0.0]))
    for step in range(1, inner.hold_steps + 1):  # 8 cm away and at rest: success after 1 s (30 steps)
        _, _, _, _, info = env.step(_standing(env))
        assert info["success"] == (step >= inner.hold_steps), step
    inner.sim.plant.SetFreeBodyPose(inner._plant_context, box, RigidTransform(target + [1.0, 0.0, 0.0]))
    _, _, _, _, info = env.step(_standing(env))
    assert info["success"] and info["success_steps"] == 0  # latched for the episode
    _, info = env.reset(seed=6, options={"init": "default"})
    _, _, _, _, info = env.step(_standing(env))
    assert not info["success"] and not np.allclose(info["goal"]["target"], target)  # a new target, a new count
    env.close()


def test_demonstration_interaction_comes_from_the_same_graph(monkeypatch):
    """s_I of the library's box carry (retargeted to the UDH) at its own frames: the hands touch the box
    while it is off the floor and not while the person walks up to it; d_og ends at zero."""
    env = gym.make("hotu_drake/BoxCarry-v0", motions=["walk", "box_carry"])
    inner = env.unwrapped
    assert inner.interaction_clips() == [1]
    clip = inner.clips[1]
    times = np.arange(0.0, clip.duration, 1.0 / 30.0)
    s_i = np.array([inner.clip_interaction(1, t) for t in times])
    assert s_i.shape == (len(times), inner.interaction_size) == (len(times), 11)
    frames = np.minimum(np.round(times * clip.fps).astype(int), clip.num_frames - 1)
    lifted = clip.object_poses[frames, 0, 2] > 0.3
    assert lifted.sum() > 60 and s_i[lifted, -2:].all()  # both hands on the box while it is carried
    assert not s_i[times < 2.0, -2:].any()  # walking up to it
    assert np.linalg.norm(s_i[-1, 6:9]) < 1e-6 < np.linalg.norm(s_i[0, 6:9])
    with pytest.raises(InputError, match="no box track"):
        inner.clip_interaction(0, 0.5)  # the walk has no box
    monkeypatch.setattr(clip, "object_names", ["Box_1"])  # a capture's rigid body, named its own way
    np.testing.assert_array_equal(inner.clip_interaction(1, 5.0), s_i[150])
    env.close()


def test_drill_rests_on_the_table_until_picked_up():
    env = gym.make("hotu_drake/DrillGrasp-v0", motions=WALK)
    check_env(env.unwrapped, skip_render_check=True)
    _, info = env.reset(seed=0, options={"init": "default"})
    start = info["goal"]["start_position"]
    for _ in range(15):
        _, reward, _, _, info = env.step(_standing(env))
    np.testing.assert_allclose(env.unwrapped.object_position(), start, atol=0.01)
    assert info["goal"]["target"][2] > start[2] + 0.1 and 0.0 <= reward <= 1.0
    assert not info["success"]  # not lifted
    env.close()


@pytest.mark.parametrize("robot", ["udh", "naviai", "h1", "bruce", "walker", "curi"])
def test_every_embodiment_makes_an_imitation_env(robot):
    env = gym.make("hotu_drake/Imitation-v0", robot=robot, hands="none", motions=WALK)
    n = len(env.unwrapped.embodiment.joint_names)
    assert env.action_space.shape == (n,)
    for init in ("reference", "default"):
        observation, info = env.reset(seed=0, options={"init": init})
        assert env.observation_space.contains(observation) and info["init"] == init
        for _ in range(3):
            observation, reward, terminated, truncated, _ = env.step(_standing(env))
        assert np.all(np.isfinite(observation)) and not truncated
    env.close()


def test_full_hands_variant_has_finger_parts():
    env = gym.make("hotu_drake/Imitation-v0", robot="h1", hands="full", motions=WALK, reference_init_probability=0.0)
    _, info = env.reset(seed=0)
    assert env.action_space.shape == (83,)
    assert "finger" in info["amp"] and info["amp"]["finger"].shape[1] == 2 * 58
    env.close()


def test_extra_objects_go_back_to_their_start_at_every_reset():
    from hotu_drake.envs.base import DiagramEnv, environment_scenario
    from hotu_drake.objects import SceneObject

    crate = SceneObject(kind="box", name="crate", position=[1.0, 0.5, 0.15])
    env = DiagramEnv(environment_scenario(robot="bruce", objects=[crate]))
    body = env.sim.plant.GetBodyByName("box", env.sim.objects["crate"])

    def position():
        return env.sim.plant.EvalBodyPoseInWorld(env._plant_context, body).translation()

    for seed in (0, 1):
        env.reset(seed=seed)
        np.testing.assert_allclose(position(), [1.0, 0.5, 0.15], atol=1e-12)  # back where it was put
        for _ in range(5):
            env.step(_standing(env))
        np.testing.assert_allclose(position()[:2], [1.0, 0.5], atol=5e-3)  # and resting there


def test_a_reference_start_puts_the_box_in_front_of_the_robot():
    env = gym.make("hotu_drake/BoxCarry-v0", motions=WALK)
    inner = env.unwrapped
    for seed in range(3):
        _, info = env.reset(seed=seed, options={"init": "reference"})
        root = inner.sim.plant.EvalBodyPoseInWorld(inner._plant_context, inner._root)
        ahead = root.rotation().matrix().T @ (inner.object_position() - root.translation())
        assert ahead[0] > 0.4, ahead
    env.close()


def test_the_phase_observation_and_the_looped_reference_say_where_the_clip_is():
    """`phase_observation` ends the observation with the sine and cosine of
    the clip's phase (a looped clip's cycle; the clip's own at that time in
    `clip_observation`); a teacher's environment reports the pelvis' and
    the looped reference's root, the latter going on past the clip's end."""
    options = {"robot": "h1", "hands": "none", "motions": WALK, "control_rate": 60.0, "teacher": True}
    env = gym.make("hotu_drake/Imitation-v0", phase_observation=True, loop=True, reference_start_time=0.0, **options)
    plain = gym.make("hotu_drake/Imitation-v0", **options)
    inner = env.unwrapped
    duration = inner.clips[0].duration
    assert env.observation_space.shape[0] == plain.observation_space.shape[0] + 2
    observation, info = env.reset(seed=0, options={"init": "reference", "clip": 0, "time": duration / 4})
    np.testing.assert_allclose(observation[-2:], [1.0, 0.0], atol=1e-6)  # a quarter of the cycle
    np.testing.assert_allclose(inner.clip_observation(0, duration / 2)[-2:], [0.0, -1.0], atol=1e-6)
    start = info["reference_root_xy"].copy()
    observation, _, _, _, info = env.step(info["teacher_action"])
    angle = 2.0 * np.pi * (0.25 + inner.control_period / duration)
    np.testing.assert_allclose(observation[-2:], [np.sin(angle), np.cos(angle)], atol=1e-6)
    assert np.linalg.norm(info["reference_root_xy"] - start) > 0.005  # the walk's root moves on
    # After a default start the reference start time does not apply: no clip, a zero phase.
    observation, info = env.reset(seed=0, options={"init": "default"})
    np.testing.assert_array_equal(observation[-2:], [0.0, 0.0])
    # A reference start with no time given begins at `reference_start_time`, dropped from up to 5 cm.
    heights = []
    for seed in (3, 4):
        observation, _ = env.reset(seed=seed, options={"init": "reference"})
        np.testing.assert_allclose(observation[-2:], [0.0, 1.0], atol=1e-6)
        heights.append(observation[0] - inner.clips[0].root_position[0, 2])
    assert all(0.0 <= h <= 0.05 for h in heights) and abs(heights[0] - heights[1]) > 1e-4, heights
    # The looped reference a whole cycle on is the first pass moved by the walk's travel.
    plan = inner._teacher().plan
    cycle = plan.root_position(1.25 * duration)[:2] - plan.root_position(0.25 * duration)[:2]
    assert np.linalg.norm(cycle) > 0.5  # the clip walks more than half a metre a cycle
    _, info = plain.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.0})
    assert "reference_root_xy" in info and "root_xy" in info
    env.close()
    plain.close()


def test_the_tracking_reward_scores_the_teacher_above_standing_and_follows_a_looped_clip():
    """`tracking_reward` rewards following the episode's clip (its terms in
    `info["tracking"]`): about 1 at a reference start, higher over a second
    for the whole-body controller than for the standing pose, which the
    walk leaves behind; nothing after a default start (no clip)."""
    options = {"robot": "h1", "hands": "none", "motions": WALK, "control_rate": 60.0, "teacher": True, "loop": True}
    env = gym.make("hotu_drake/Imitation-v0", tracking_reward=True, **options)
    inner = env.unwrapped
    returns = {}
    for who in ("teacher", "standing"):
        _, info = env.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.0})
        rewards = []
        for _ in range(60):
            action = info["teacher_action"] if who == "teacher" else inner.standing_action()
            _, reward, terminated, _, info = env.step(action)
            rewards.append(reward)
            assert not terminated
        assert set(info["tracking"]) == {"joints", "key_bodies", "root_height", "root_velocity"}
        assert 0.0 <= min(rewards) and max(rewards) <= 1.0
        returns[who] = (rewards[0], float(np.mean(rewards)))
    assert returns["teacher"][0] > 0.95 and returns["standing"][0] > 0.9, returns  # both start on the clip
    assert returns["teacher"][1] > 0.85 and returns["standing"][1] < returns["teacher"][1] - 0.15, returns
    env.reset(seed=0, options={"init": "default"})
    assert env.step(inner.standing_action())[1] == 0.0
    plain = gym.make("hotu_drake/Imitation-v0", **options)
    plain.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.0})
    assert plain.step(plain.unwrapped.standing_action())[1] == 0.0  # off by default: the style reward is the trainer's
    env.close()
    plain.close()


def test_the_reference_observation_says_where_the_teachers_reference_is_against_the_robot():
    """`reference_observation` ends the observation with the teacher's
    reference against the robot (heading frame): nothing off at a reference
    start, the clip's own feet; after a second of the standing pose the walk
    has gone on ahead (its root and CoM in front, the same heading within
    a few degrees); it needs the teacher."""
    options = {"robot": "h1", "hands": "none", "motions": WALK, "control_rate": 60.0, "loop": True}
    env = gym.make("hotu_drake/Imitation-v0", teacher=True, reference_observation=True, **options)
    inner = env.unwrapped
    robot_size = inner._observer.observation_size
    assert env.observation_space.shape[0] == robot_size + REFERENCE_SIZE
    observation, _ = env.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.0})
    reference = observation[-REFERENCE_SIZE:]
    np.testing.assert_allclose(reference[:2], 0.0, atol=1e-3)  # the root, horizontally
    np.testing.assert_allclose(reference[3:5], [0.0, 1.0], atol=1e-3)  # no yaw between them
    np.testing.assert_allclose(reference[11:], observation[robot_size - 6 : robot_size], atol=0.02)  # the feet
    np.testing.assert_allclose(inner.clip_observation(0, 0.0)[-REFERENCE_SIZE:][11:], reference[11:], atol=0.02)
    for _ in range(60):
        observation, *_ = env.step(inner.standing_action())
    reference = observation[-REFERENCE_SIZE:]
    assert reference[0] > 0.15 and reference[5] > 0.15, reference  # the root and the CoM ahead
    assert reference[4] > np.cos(np.radians(10.0)), reference
    env.close()
    with pytest.raises(InputError, match="teacher=True"):
        gym.make("hotu_drake/Imitation-v0", reference_observation=True, **options)


def test_the_pose_observation_gives_the_clips_joints_against_the_robots():
    """`pose_observation` ends the observation with the episode's clip's
    joint positions and velocities less the robot's (no teacher needed):
    none at a reference start (the robot on the clip), as behavior
    cloning's observation of the clip's state says (with its phase); the
    walk's swing after a second of the standing pose; a default start has
    no clip."""
    options = {"robot": "h1", "hands": "none", "motions": WALK, "control_rate": 60.0, "loop": True}
    env = gym.make("hotu_drake/Imitation-v0", pose_observation=True, phase_observation=True, **options)
    inner = env.unwrapped
    joints = len(inner.embodiment.joint_names)
    assert env.observation_space.shape[0] == inner._observer.observation_size + 2 + 2 * joints
    observation, _ = env.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.5})
    np.testing.assert_allclose(observation[-2 * joints :], 0.0, atol=1e-6)
    np.testing.assert_allclose(inner.clip_observation(0, 0.5), observation, atol=1e-5)
    observation, _ = env.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.0})
    for _ in range(60):
        observation, *_ = env.step(inner.standing_action())
    assert np.abs(observation[-2 * joints : -joints]).max() > 0.1  # the clip's legs swing; the robot's stand
    observation, _ = env.reset(seed=0, options={"init": "default"})
    np.testing.assert_array_equal(observation[-2 * joints :], 0.0)
    env.close()


def test_a_standing_start_follows_its_clip_placed_under_the_robot():
    """With `standing_follow`, a default start (the standing pose, dropped)
    follows the clip from its start, placed under the robot: the phase at
    the clip's start, the reference's root over the robot's, no yaw between
    them, a tracking reward; without it a default start follows nothing,
    and asking it for a clip is an error. A clip alone asks for a reference
    start."""
    options = {"robot": "h1", "hands": "none", "motions": WALK, "control_rate": 60.0, "loop": True, "teacher": True}
    extras = {"phase_observation": True, "reference_observation": True, "tracking_reward": True}
    env = gym.make("hotu_drake/Imitation-v0", standing_follow=True, **extras, **options)
    observation, info = env.reset(seed=1, options={"init": "default"})
    assert info["init"] == "default"
    reference = observation[-REFERENCE_SIZE:]
    np.testing.assert_allclose(observation[-REFERENCE_SIZE - 2 : -REFERENCE_SIZE], [0.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(reference[:2], 0.0, atol=1e-6)  # the clip's start under the robot's root
    np.testing.assert_allclose(reference[3:5], [0.0, 1.0], atol=1e-6)  # facing its heading
    np.testing.assert_allclose(info["reference_root_xy"], info["root_xy"], atol=0.05)  # pelvis against root
    assert env.step(info["teacher_action"])[1] > 0.0  # the clip is tracked, so rewarded
    plain = gym.make("hotu_drake/Imitation-v0", **extras, **options)
    observation, _ = plain.reset(seed=1, options={"init": "default"})
    np.testing.assert_array_equal(observation[-REFERENCE_SIZE - 2 : -REFERENCE_SIZE], [0.0, 0.0])
    with pytest.raises(InputError, match="standing_follow"):
        plain.reset(seed=1, options={"init": "default", "clip": 0})
    assert plain.reset(seed=1, options={"clip": 0})[1]["init"] == "reference"
    env.close()
    plain.close()


def test_clips_are_drawn_by_their_falls_when_asked():
    """`clip_sampling="falls"`: each environment counts the episodes begun
    on each clip and those that fell, and draws half its clips evenly and
    half by their smoothed fall rates (`clip_weights`)."""
    from hotu_drake.envs.base import clip_weights

    np.testing.assert_allclose(clip_weights(np.zeros(3), np.zeros(3)), 1 / 3)  # nothing tried: evenly
    weights = clip_weights(np.array([9.0, 0.0]), np.array([10.0, 10.0]))
    np.testing.assert_allclose(weights.sum(), 1.0)
    assert weights[0] > 2 * weights[1] and weights[1] > 0.25, weights  # the performed clip keeps a share
    options = {"robot": "h1", "hands": "none", "motions": ["walk", "squat"], "reference_init_probability": 1.0}
    env = gym.make("hotu_drake/Imitation-v0", clip_sampling="falls", **options)
    inner = env.unwrapped
    env.reset(seed=0, options={"clip": 1, "time": 0.0})
    limp = -np.ones(env.action_space.shape, dtype=np.float32)
    for _ in range(90):
        if env.step(limp)[2]:
            break
    np.testing.assert_array_equal(inner.clip_episodes, [0, 1])
    np.testing.assert_array_equal(inner.clip_falls, [0, 1])  # the squat's episode fell
    inner.clip_episodes[:], inner.clip_falls[:] = [50, 50], [0, 50]
    drawn = [inner._draw_clip() for _ in range(400)]
    assert 0.6 < np.mean(drawn) < 0.9, np.mean(drawn)  # the squat about 3/4 of the time (0.74)
    env.close()
    with pytest.raises(InputError, match="clip_sampling"):
        gym.make("hotu_drake/Imitation-v0", clip_sampling="hardest", **options)


def test_the_clips_objects_stand_where_each_episode_s_clip_has_them_and_the_teacher_lifts_one():
    """`clip_objects=True`: a grasp episode starts with its table (on its
    damped planar joint) and its object where the clip has them, taken
    into the world by the episode's frame; a walk's episode parks them;
    the teacher performing the grasp lifts the apple (measured 0.18 m),
    `info["object_rise"]` says so, and the table stays where it was put."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform

    env = gym.make(
        "hotu_drake/Imitation-v0",
        robot="udh",
        hands="full",
        motions=["hand_grasp@0", "walk"],
        control_rate=60.0,
        teacher=True,
        clip_objects=True,
        drop_height=0.0,
    )
    inner = env.unwrapped
    plant, context = inner.sim.plant, inner._plant_context
    assert inner._clip_objects.kinds == ["apple", "table"]
    apple, table = (plant.GetBodyByName(kind) for kind in ("apple", "table"))
    _, info = env.reset(seed=0, options={"clip": 1, "time": 1.0})  # the walk
    assert np.isnan(info["object_rise"])
    for body in (apple, table):
        assert plant.EvalBodyPoseInWorld(context, body).translation()[0] < -40.0
    _, info = env.reset(seed=0, options={"clip": 0, "time": 0.0})
    clip = inner.clips[0]
    pose = clip.object_poses[0, clip.object_names.index("apple")]
    expected = inner._episode_frame @ RigidTransform(Quaternion(pose[3:] / np.linalg.norm(pose[3:])), pose[:3])
    placed = plant.EvalBodyPoseInWorld(context, apple)
    np.testing.assert_allclose(placed.translation(), expected.translation(), atol=1e-9)
    assert info["object_rise"] == 0.0
    table_at = plant.EvalBodyPoseInWorld(context, table).translation().copy()
    rises = []
    for _ in range(250):  # 4.2 s: the clip's lift is done by 4.0 s
        _, _, terminated, _, info = env.step(info["teacher_action"])
        assert not terminated
        rises.append(info["object_rise"])
    assert np.max(rises) > 0.1, np.max(rises)
    assert min(rises[:60]) > -0.02  # the apple stood on the table until the hand came
    moved = plant.EvalBodyPoseInWorld(context, table).translation() - table_at
    assert np.linalg.norm(moved) < 0.01, moved
    env.close()
