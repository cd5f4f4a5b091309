"""An environment's episode recorded as a clip: the one clip format, with its
object track, so a UDH rollout can be retargeted and tracked."""

import gymnasium as gym
import numpy as np
import pytest

import hotu_drake.envs  # noqa: F401
from hotu_drake.envs.recording import EpisodeRecorder, record_episode
from hotu_drake.motion.clip import MotionClip


@pytest.fixture(scope="module")
def box_env():
    env = gym.make("hotu_drake/BoxCarry-v0", robot="udh", hands="none", drop_height=0.3)
    yield env.unwrapped
    env.close()


def test_a_recorded_rollout_round_trips_through_the_clip_format(box_env, tmp_path):
    standing = box_env._standing_action
    clip = record_episode(
        box_env, lambda observation, info: standing, seed=3, max_steps=12, source="udh_box", options={"init": "default"}
    )
    assert clip.num_frames == 13 and clip.fps == pytest.approx(30.0) and clip.embodiment == "udh"
    assert clip.object_names == ["box"] and clip.object_poses.shape == (13, 1, 7)
    # The box floats at its start until touched: its track is the episode's start pose.
    start = box_env.start_pose
    np.testing.assert_allclose(clip.object_poses[:, 0, :3], np.tile(start.translation(), (13, 1)), atol=1e-3)
    # Dropped from up to 30 cm, then standing.
    assert clip.contact_names == ["left_foot", "right_foot"]
    assert not clip.contacts[0].any() and clip.contacts[-1].all()
    assert 0.8 < clip.root_position[-1, 2] < 1.0
    # The recorded velocities agree with the positions (central differences, after the landing).
    dt = 1.0 / clip.fps
    difference = (clip.joint_positions[-1] - clip.joint_positions[-3]) / (2 * dt)
    np.testing.assert_allclose(clip.joint_velocities[-2], difference, atol=0.05)
    root_difference = (clip.root_position[2:] - clip.root_position[:-2]) / (2 * dt)
    np.testing.assert_allclose(clip.root_linear_velocity[-4:-1], root_difference[-3:], atol=0.05)
    loaded = MotionClip.load(clip.save(tmp_path / "rollout.npz"))
    np.testing.assert_array_equal(loaded.object_poses, clip.object_poses)
    np.testing.assert_array_equal(loaded.joint_positions, clip.joint_positions)
    np.testing.assert_array_equal(loaded.contacts, clip.contacts)
    assert loaded.key_body_names == clip.key_body_names and loaded.part_index == clip.part_index


def test_a_clip_needs_two_frames(box_env):
    recorder = EpisodeRecorder(box_env)
    box_env.reset(seed=0)
    recorder.capture()
    with pytest.raises(ValueError, match="two or more frames"):
        recorder.clip("one_frame")
