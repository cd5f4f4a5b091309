"""The procedural demonstration library: every motion is valid, deterministic
and looks like what it is named (feet planted, hands on the box, ...)."""

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.embodiment.kinematics import batch_link_poses
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.library import MOTIONS, generate, generate_library, generate_udh
from hotu_drake.rotations import angular_velocity, finite_difference, quat_to_matrix

FPS = 30.0
SIDES = ("left", "right")


@pytest.fixture(scope="module")
def udh():
    return embodiment.load("udh", hands="full")


@pytest.fixture(scope="module")
def clips(udh):
    """Every motion on the UDH, generated once (its cost: `python -m hotu_drake.bench readers`)."""
    return {name: generate_udh(name, udh=udh) for name in MOTIONS}


@pytest.fixture(scope="module")
def human(clips):
    return {name: generate(name) for name in ("walk", "box_carry", "drill_grasp")}


def sole_heights(udh, clip: MotionClip) -> dict[str, np.ndarray]:
    """Lowest point (T,) of each foot's collision spheres above the floor."""
    poses = batch_link_poses(
        udh.spec, clip.joint_names, clip.joint_positions, quat_to_matrix(clip.root_quaternion), clip.root_position
    )
    out = {}
    for side in SIDES:
        link = udh.spec.link(udh.key_bodies[f"{side}_foot"])
        rot, pos = poses[link.name]
        centres = np.array([g.position for g in link.collisions])
        radii = np.array([g.size[0] for g in link.collisions])
        z = pos[:, None, 2] + np.einsum("tj,kj->tk", rot[:, 2, :], centres) - radii
        out[side] = z.min(axis=1)
    return out


def box_distance(point: np.ndarray, pose: np.ndarray, half: float = 0.15) -> np.ndarray:
    """Signed distance (T,) from points (T, 3) to the surface of a cube at poses (T, 7)."""
    local = np.einsum("tji,tj->ti", quat_to_matrix(pose[:, 3:]), point - pose[:, :3])
    q = np.abs(local) - half
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def intervals(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) frame ranges where `mask` is true."""
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


def test_vocabulary():
    assert MOTIONS == (
        "walk", "jump", "squat", "leg_stretch", "boxing", "finger_motions", "handshake",
        "kungfu", "wave", "slap", "thumbs_up", "box_carry", "drill_grasp",
        "walk_fast", "walk_turn_left", "walk_turn_right", "turn_in_place_left", "turn_in_place_right",
        "sidestep_left", "sidestep_right", "walk_backward", "start_stop", "box_carry_task", "drill_grasp_task",
        "hand_grasp",
    )  # fmt: skip
    with pytest.raises(ValueError, match="unknown motion"):
        generate_udh("moonwalk")


@pytest.mark.parametrize("name", MOTIONS)
def test_clip_is_a_valid_udh_clip(udh, clips, name):
    clip = clips[name]
    assert clip.embodiment == "udh" and clip.source == f"hotu_drake/library/{name}"
    assert clip.joint_names == udh.joint_names and len(clip.joint_names) == 92
    assert clip.key_body_names == list(udh.key_bodies.values())
    assert clip.part_index == {part: list(joints) for part, joints in udh.parts.items()}
    assert clip.fps == FPS and 2.0 <= clip.duration <= 12.0
    q = clip.joint_positions
    assert np.all(q >= udh.position_lower - 1e-9) and np.all(q <= udh.position_upper + 1e-9)
    assert {"left_foot", "right_foot"} <= set(clip.contact_names)


@pytest.mark.parametrize("name", MOTIONS)
def test_velocities_match_positions(clips, name):
    clip = clips[name]
    np.testing.assert_allclose(clip.joint_velocities, finite_difference(clip.joint_positions, FPS), atol=1e-9)
    np.testing.assert_allclose(clip.root_linear_velocity, finite_difference(clip.root_position, FPS), atol=1e-9)
    np.testing.assert_allclose(clip.root_angular_velocity, angular_velocity(clip.root_quaternion, FPS), atol=1e-9)
    # Smooth enough to track: no joint faster than 25 rad/s.
    assert np.abs(clip.joint_velocities).max() < 25.0


@pytest.mark.parametrize("name", MOTIONS)
def test_feet_stay_above_the_floor(udh, clips, name):
    clip = clips[name]
    heights = sole_heights(udh, clip)
    for side in SIDES:
        assert heights[side].min() >= -0.01
        # A foot in contact is on the floor and not sliding.
        contact = clip.contact(f"{side}_foot")
        assert contact.any() and np.all(heights[side][contact] < 0.01)
        speed = np.linalg.norm(finite_difference(clip.key_body(f"{side}_foot")[:, :2], FPS), axis=1)
        assert speed[contact].mean() < 0.05


@pytest.mark.parametrize("name", MOTIONS)
def test_save_load_round_trip(clips, tmp_path, name):
    clip = clips[name]
    loaded = MotionClip.load(clip.save(tmp_path / f"{name}.npz"))
    for key in ("joint_positions", "joint_velocities", "root_position", "root_quaternion", "key_body_positions"):
        np.testing.assert_array_equal(getattr(loaded, key), getattr(clip, key))
    assert loaded.contact_names == clip.contact_names and loaded.object_names == clip.object_names
    np.testing.assert_array_equal(loaded.contacts, clip.contacts)
    if clip.object_names:
        np.testing.assert_array_equal(loaded.object_poses, clip.object_poses)
    assert loaded.part_index == clip.part_index


@pytest.mark.parametrize("name", MOTIONS)
def test_seed_determines_the_motion(udh, clips, name):
    again = generate_udh(name, seed=0, udh=udh)
    np.testing.assert_array_equal(again.joint_positions, clips[name].joint_positions)
    np.testing.assert_array_equal(again.root_position, clips[name].root_position)
    other = generate_udh(name, seed=1, udh=udh)
    assert not np.array_equal(other.joint_positions, clips[name].joint_positions)


def test_duration_stretches_a_motion(udh):
    clip = generate_udh("wave", duration=6.0, fps=50.0, udh=udh)
    assert clip.num_frames == 301 and clip.fps == 50.0
    with pytest.raises(ValueError, match="duration"):
        generate_udh("wave", duration=0.5, udh=udh)


def test_walk_alternates_planted_feet(udh, clips):
    clip = clips["walk"]
    swings = sorted((start, side) for side in SIDES for start, _ in intervals(~clip.contact(f"{side}_foot")))
    order = [side for _, side in swings]
    assert len(order) >= 5 and all(a != b for a, b in zip(order, order[1:]))
    assert min(order.count("left"), order.count("right")) >= 2
    progress = clip.root_position[-1, 0] - clip.root_position[0, 0]
    assert progress > 1.0
    for side in SIDES:
        contact = clip.contact(f"{side}_foot")
        speed = np.linalg.norm(finite_difference(clip.key_body(f"{side}_foot")[:, :2], FPS), axis=1)
        assert speed[contact].max() < 0.05  # planted: no skating at all
    # The pelvis bobs mildly while walking.
    walking = clip.root_position[30:-30, 2]
    assert 0.01 < walking.max() - walking.min() < 0.08
    # Arms swing opposite to the legs: left arm back (positive) when the left foot leads.
    lead = clip.key_body("left_foot")[:, 0] - clip.key_body("right_foot")[:, 0]
    assert np.corrcoef(lead, clip.joint("left_shoulder_y"))[0, 1] > 0.5
    assert np.corrcoef(lead, clip.joint("right_shoulder_y"))[0, 1] < -0.5


def test_jump_leaves_the_ground(udh, clips):
    clip = clips["jump"]
    heights = sole_heights(udh, clip)
    airborne = (heights["left"] > 0.05) & (heights["right"] > 0.05)
    assert airborne.any()
    assert not (clip.contact("left_foot") | clip.contact("right_foot"))[airborne].any()
    assert clip.contact("left_foot")[0] and clip.contact("left_foot")[-1]
    # It crouches before taking off.
    take_off = np.flatnonzero(airborne)[0]
    assert clip.root_position[:take_off, 2].min() < clip.root_position[0, 2] - 0.1


def test_box_is_carried_from_start_to_target(clips, human):
    clip = human["box_carry"]
    box = clip.object_pose("box")
    assert clip.object_names == ["box"]
    assert np.linalg.norm(box[-1, :2] - box[0, :2]) > 1.0
    yaw = 2 * np.arctan2(box[:, 3 + 3], box[:, 3])
    assert abs(yaw[-1] - yaw[0]) > 1.0  # turned to the target's heading
    np.testing.assert_allclose(box[[0, -1], 2], 0.15)  # resting on the floor at both ends
    held = clip.contact("left_hand_box") & clip.contact("right_hand_box")
    assert held.sum() > 3 * FPS
    for side in SIDES:
        touching = clip.contact(f"{side}_hand_box")
        gap = box_distance(clip.key_body(f"{side}_hand"), box)
        assert np.all(np.abs(gap[touching]) < 0.03)
    # Off the floor only while both hands hold it; still whenever not held.
    assert np.all(held[box[:, 2] > 0.152])
    moving = np.linalg.norm(finite_difference(box[:, :3], FPS), axis=1) > 1e-6
    assert not moving[~held].any()
    # Fingers closed on it while carrying (UDH clip).
    udh_clip = clips["box_carry"]
    fingers = [i for i, n in enumerate(udh_clip.joint_names) if "_index_" in n or "_middle_" in n]
    carrying = held & (box[:, 2] > 0.5)
    assert udh_clip.joint_positions[np.ix_(carrying, fingers)].min() > 0.3


def test_drill_is_grasped_and_lifted(human):
    clip = human["drill_grasp"]
    drill = clip.object_pose("drill")
    contact = clip.contact("right_hand_drill")
    assert contact[-1] and not contact[0]
    assert drill[-1, 2] - drill[0, 2] > 0.15
    lifted = drill[:, 2] > drill[0, 2] + 0.01
    assert np.all(contact[lifted])
    gap = np.linalg.norm(clip.key_body("right_hand")[contact] - drill[contact, :3], axis=1)
    assert gap.max() < 0.07
    # The fingers close around the grip (finger tips come near it).
    tip = clip.key_body("right_middle_4")[contact]
    assert np.linalg.norm(tip - drill[contact, :3], axis=1).max() < 0.08


def test_finger_motions_use_the_fingers(udh, clips):
    clip = clips["finger_motions"]
    finger = udh.parts["finger"]
    for name in finger:
        i = clip.joint_names.index(name)
        span = np.ptp(clip.joint_positions[:, i])
        assert span > 0.5 * (udh.position_upper[i] - udh.position_lower[i]), name


def test_human_clips_and_library_files(human, tmp_path):
    clip = human["walk"]
    assert clip.embodiment == "human" and clip.source == "hotu_drake/library/walk"
    assert clip.joint_names == [] and "left_toe" in clip.key_body_names
    assert human["box_carry"].contact_names == ["left_foot", "right_foot", "left_hand_box", "right_hand_box"]
    paths = generate_library(tmp_path, names=("wave", "box_carry"), seed=3)
    assert [p.name for p in paths] == ["wave.npz", "box_carry.npz"]
    loaded = MotionClip.load(paths[1])
    np.testing.assert_array_equal(loaded.key_body_positions, generate("box_carry", seed=3).key_body_positions)


@pytest.mark.parametrize("seed", [0, 3, 7])
def test_a_box_carry_task_demonstration_puts_its_box_where_its_task_says(seed):
    """`box_carry_task@<seed>`: the task drawn as the environment draws it,
    the box floating at its start, gripped, carried and held at the target."""
    from hotu_drake.motion.library.object_tasks import BOX_CARRY_RANGES, sample_box_carry

    task = sample_box_carry(np.random.default_rng(seed))
    for name, value in (("start_distance", np.hypot(*task.start[:2])), ("target_distance", np.hypot(*task.target[:2]))):
        assert BOX_CARRY_RANGES[name][0] <= value <= BOX_CARRY_RANGES[name][1]
    clip = generate(f"box_carry_task@{seed}")
    assert clip.source.endswith(f"box_carry_task@{seed}")
    box = clip.object_poses[:, clip.object_names.index("box"), :3]
    np.testing.assert_allclose(box[0], task.start, atol=1e-9)
    np.testing.assert_allclose(box[-1], task.target, atol=1e-9)
    held = clip.contact("left_hand_box").astype(bool) & clip.contact("right_hand_box").astype(bool)
    assert held[-1] and not held[0] and held.mean() > 0.5  # gripped, and still held at the target
    for side in ("left", "right"):
        reach = np.linalg.norm(clip.key_body(f"{side}_hand") - box, axis=1)[held]
        assert np.median(reach) < 0.2  # the hands on the box's sides (its half-width is 0.15 m)
    moving = np.linalg.norm(np.diff(box, axis=0), axis=1) > 1e-4
    assert not moving[-int(clip.fps) :].any()  # at rest at the target for the task's last second


@pytest.mark.parametrize("seed", [0, 5])
def test_a_drill_grasp_task_demonstration_lifts_its_drill_where_its_task_says(seed):
    from hotu_drake.motion.library.object_tasks import sample_drill_grasp

    task = sample_drill_grasp(np.random.default_rng(seed))
    clip = generate(f"drill_grasp_task@{seed}")
    drill = clip.object_poses[:, clip.object_names.index("drill"), :3]
    np.testing.assert_allclose(drill[0], task.start, atol=1e-9)
    np.testing.assert_allclose(drill[-1], task.target, atol=1e-9)
    held = clip.contact("right_hand_drill").astype(bool)
    assert held[-1] and not held[0]
    assert np.linalg.norm(clip.key_body("right_hand") - drill, axis=1)[held].max() < 0.08  # the hand on the grip


@pytest.mark.parametrize("task", ["box_carry", "drill_grasp"])
def test_the_task_environment_draws_its_tasks_as_the_library_does(task):
    """The environment's goal for a generator state is the library's task for the same state."""
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401
    from hotu_drake.motion.library import object_tasks

    env_id = {"box_carry": "hotu_drake/BoxCarry-v0", "drill_grasp": "hotu_drake/DrillGrasp-v0"}[task]
    sample = {"box_carry": object_tasks.sample_box_carry, "drill_grasp": object_tasks.sample_drill_grasp}[task]
    env = gym.make(env_id, robot="bruce", hands="none", motions=["walk"])
    try:
        inner = env.unwrapped
        inner.np_random, _ = gym.utils.seeding.np_random(11)
        pose, target = inner._sample_goal()
        expected = sample(gym.utils.seeding.np_random(11)[0])
        np.testing.assert_allclose(pose.translation(), expected.start)
        np.testing.assert_allclose(target, expected.target)
    finally:
        env.close()


def test_the_grasp_set_draws_every_object_of_it():
    from hotu_drake.motion.library.grasps import GRASP_RANGES, sample_grasp
    from hotu_drake.objects import GRASP_OBJECTS, OBJECT_MODELS, TABLE_TOP, resting_height

    tasks = [sample_grasp(np.random.default_rng(seed)) for seed in range(300)]
    assert {task.kind for task in tasks} == set(GRASP_OBJECTS)
    assert all(kind in OBJECT_MODELS for kind in GRASP_OBJECTS)
    for task in tasks:  # standing on the table, within the set's ranges
        assert task.position[2] == pytest.approx(TABLE_TOP + resting_height(task.kind), abs=0.005)
        assert GRASP_RANGES["distance"][0] <= task.position[0] <= GRASP_RANGES["distance"][1]
        assert GRASP_RANGES["lift"][0] <= task.lift <= GRASP_RANGES["lift"][1]


# Seeds of each kind of object: a tall box, a ball, a short box, the drill.
@pytest.mark.parametrize("seed", [23, 4, 11, 15])
def test_a_grasp_set_clip_holds_its_object_in_its_closed_hand(udh, seed):
    """`hand_grasp@<seed>`: the hand landmark on the grasp point from the
    fingers' closing to the lowering, the object lifted by its task's lift
    meanwhile and put back at its start, the fingers open before and after
    and closed while it is held, and the body's centre of mass over the feet
    throughout (the hips back as it leans over the table)."""
    from hotu_drake.embodiment.kinematics import batch_center_of_mass
    from hotu_drake.motion.library import grasps
    from hotu_drake.motion.synthesis import Body
    from hotu_drake.rotations import rot_z

    task = grasps.sample_grasp(np.random.default_rng(seed))
    clip = generate_udh(f"hand_grasp@{seed}", udh=udh)
    fps = clip.fps
    obj = clip.object_pose(task.kind)[:, :3]
    np.testing.assert_allclose(obj[0], task.position, atol=1e-9)
    np.testing.assert_allclose(obj[-1], task.position, atol=1e-9)
    held = np.arange(int(grasps.HOLD * fps), int(grasps.LOWER * fps))
    np.testing.assert_allclose(obj[held, 2] - task.position[2], task.lift, atol=1e-3)
    contact = clip.contact(f"right_hand_{task.kind}")
    assert contact[held].all() and not contact[0] and not contact[-1]

    poses = batch_link_poses(
        udh.spec, clip.joint_names, clip.joint_positions, quat_to_matrix(clip.root_quaternion), clip.root_position
    )
    rot, pos = poses[udh.key_bodies["right_hand"]]
    landmark = pos + rot @ Body.of(udh).hand_offset["right"]
    shape = grasps.grasp_shape(task.kind)
    on_object = obj + rot_z(np.full(len(obj), task.yaw)) @ shape.landmark
    closed = np.arange(int(grasps.LIFT * fps), int(grasps.LOWER * fps))
    assert np.linalg.norm(landmark[closed] - on_object[closed], axis=1).max() < 0.003
    index = clip.joint("right_index_2")
    assert index[0] < 0.1 and index[-1] < 0.1 and index[closed].min() > 0.5

    com = batch_center_of_mass(poses, udh.spec)
    feet = np.mean([poses[udh.key_bodies[f"{side}_foot"]][1] for side in SIDES], axis=0)
    lean = np.abs(clip.root_position[:, 0] - clip.root_position[0, 0]).max()
    assert lean > 0.05  # the hips went back ...
    drift = com[:, :2] - com[0, :2]
    assert np.abs(drift).max() < 0.01  # ... and the centre of mass stayed where it stood
    assert np.abs(feet[:, :2] - feet[0, :2]).max() < 1e-6  # on feet that did not move


def test_a_clips_objects_become_a_scene():
    from hotu_drake.errors import InputError
    from hotu_drake.objects import clip_scene_objects

    yaw = 0.3
    poses = np.array([[0.6, 0.1, 0.72, 1.0, 0, 0, 0], [0.4, -0.2, 0.77, np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]])
    table, can = clip_scene_objects(["table", "soup_can"], poses)
    assert table.fixed and table.position == [0.6, 0.1, 0.0]  # welded to the floor below its top
    assert not can.fixed and can.kind == "soup_can" and can.position == pytest.approx([0.4, -0.2, 0.77])
    assert can.yaw == pytest.approx(yaw)
    with pytest.raises(InputError, match="'teapot'"):
        clip_scene_objects(["teapot"], poses[:1])
