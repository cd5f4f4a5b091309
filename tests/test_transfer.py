"""Skill transfer's Drake side: a recorded UDH episode with its target,
retargeted to a robot with its tracks scaled, and the transfer environment
that tracks such a reference."""

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import hotu_drake.envs  # noqa: F401
from hotu_drake.envs.recording import record_episode
from hotu_drake.envs.transfer import TARGET_TRACK, retarget_episode, tracking_reward, with_target
from hotu_drake.errors import InputError
from hotu_drake.objects import BOX_SIZE


def _standing_episode(robot: str, seed: int, steps: int):
    """A standing episode of BoxCarry-v0 on `robot` as a clip with its target track."""
    env = gym.make("hotu_drake/BoxCarry-v0", robot=robot, hands="none").unwrapped
    try:
        standing = env.standing_action()
        clip = record_episode(env, lambda o, i: standing, seed, steps, f"{robot}_stand", options={"init": "default"})
        return with_target(clip, env.target), env.start_pose.translation().copy(), env.target.copy()
    finally:
        env.close()


@pytest.fixture(scope="module")
def h1_reference(tmp_path_factory):
    """H1 standing for 2 s on a box-carry instance, as a reference clip on disk."""
    clip, start, target = _standing_episode("h1", seed=5, steps=60)
    path = tmp_path_factory.mktemp("transfer") / "h1_stand.npz"
    clip.save(path)
    return path, clip, start, target


def test_a_udh_episode_reaches_a_robot_with_its_tracks_scaled():
    udh, start, target = _standing_episode("udh", seed=2, steps=15)
    assert udh.object_names == ["box", TARGET_TRACK]
    np.testing.assert_allclose(udh.object_poses[:, 1, :3], np.tile(target, (udh.num_frames, 1)))
    np.testing.assert_allclose(udh.object_poses[0, 0, :3], start, atol=1e-6)
    bruce = retarget_episode(udh, "bruce")
    assert bruce.embodiment == "bruce" and bruce.num_frames == udh.num_frames
    assert bruce.object_names == udh.object_names
    ratio = np.linalg.norm(bruce.object_poses[0, :, :2], axis=1) / np.linalg.norm(udh.object_poses[0, :, :2], axis=1)
    assert 0.4 < ratio[0] < 0.6 and ratio[1] == pytest.approx(ratio[0])  # box and target scaled alike
    rest = BOX_SIZE / 2  # heights scale above the box's resting height
    for k in range(2):
        expected = rest + (udh.object_poses[0, k, 2] - rest) * ratio[0]
        assert bruce.object_poses[0, k, 2] == pytest.approx(expected)


def test_the_transfer_environment_takes_the_references_task_and_rewards_tracking(h1_reference):
    path, clip, start, target = h1_reference
    env = gym.make("hotu_drake/BoxCarryTransfer-v0", robot="h1", hands="none", references=[str(path)])
    inner = env.unwrapped
    try:
        observation, info = env.reset(seed=11)
        base = gym.make("hotu_drake/BoxCarry-v0", robot="h1", hands="none").unwrapped
        assert observation.shape == (base.observation_space.shape[0] + inner.reference_size,)
        base.close()
        np.testing.assert_allclose(info["goal"]["start_position"], start, atol=1e-9)
        np.testing.assert_allclose(info["goal"]["target"], target, atol=1e-9)
        standing = inner.standing_action()
        terms = []
        for _ in range(30):  # the robot does what the reference did: tracking is near perfect
            observation, reward, terminated, truncated, info = env.step(standing)
            terms.append(info["tracking"])
            assert 0.0 <= info["task_reward"] <= 1.0 and not terminated
        assert min(t["joints"] for t in terms[5:]) > 0.95 and min(t["object"] for t in terms) > 0.99
        assert reward == pytest.approx(tracking_reward(*inner._reference_errors()[:3])["total"], abs=0.05)
        # The reference's offsets are in the observation; the phase is the last column.
        assert observation[-1] == pytest.approx(31 / 30 / clip.duration, abs=1e-6)
    finally:
        env.close()


def test_tracking_falls_with_the_distance_from_the_reference(h1_reference, tmp_path):
    path, clip, _, _ = h1_reference
    moved = dataclasses.replace(clip, joint_positions=clip.joint_positions + 0.3)
    moved.save(tmp_path / "moved.npz")
    env = gym.make("hotu_drake/BoxCarryTransfer-v0", robot="h1", hands="none", references=[str(tmp_path / "moved.npz")])
    try:
        env.reset(seed=11)
        _, _, _, _, info = env.step(env.unwrapped.standing_action())
        assert info["tracking"]["joints"] == pytest.approx(np.exp(-5 * 0.09), abs=0.05)
    finally:
        env.close()


def test_a_reference_without_the_tasks_tracks_is_refused(h1_reference, tmp_path):
    _, clip, _, _ = h1_reference
    bare = dataclasses.replace(clip, object_names=["box"], object_poses=clip.object_poses[:, :1])
    bare.save(tmp_path / "bare.npz")
    with pytest.raises(InputError, match="no target_marker track"):
        gym.make("hotu_drake/BoxCarryTransfer-v0", robot="h1", hands="none", references=[str(tmp_path / "bare.npz")])
    with pytest.raises(InputError, match="at least one reference"):
        gym.make("hotu_drake/BoxCarryTransfer-v0", robot="h1", hands="none", references=[])
