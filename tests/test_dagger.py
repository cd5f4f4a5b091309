"""The teacher-labelled learner (`learning.dagger`) on the toy with a
teacher (tests/toy_env.py; no Drake): DAgger lowers the label loss on the
states the clone visits, and the clone then does what the teacher does."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hotu_drake.errors import InputError
from hotu_drake.learning.config import config_from_dict, preset
from hotu_drake.learning.dagger import DAggerAgent
from hotu_drake.learning.evaluation import follow_clips, standing_policy, teacher_policy
from hotu_drake.learning.ppo import make_batch
from hotu_drake.retarget.references import looped_motions
from tests import toy_env


def _tiny(**teacher):
    config = preset("dagger")
    config.networks.policy_hidden = (32, 32)
    config.networks.critic_hidden = (16,)
    config.ppo.horizon = 30
    config.teacher.updates = 40
    config.teacher.batch_size = 64
    config.teacher.noise = 0.05
    config.teacher.teacher_iterations = 1
    config.teacher.beta_decay = 0.5
    config.torch_threads = 1
    for key, value in teacher.items():
        setattr(config.teacher, key, value)
    return config


def test_dagger_lowers_the_label_loss_on_the_states_the_clone_visits():
    envs = toy_env.teacher_vector_env(4)
    agent = DAggerAgent(_tiny(), envs, toy_env.demonstrations(), seed=0)
    first = agent.iteration()
    assert first["beta"] == 1.0 and first["labelled"] == 120
    stats = [agent.iteration() for _ in range(15)]
    assert stats[-1]["beta"] < 0.001  # the clone alone acts by now: its own states are what is labelled
    assert stats[-1]["label_loss_visited"] < 0.1 * first["label_loss_visited"], (first, stats[-1])

    def act(observations, info):
        return agent.act(observations, deterministic=True)[0]

    clone = follow_clips(envs, act, episodes=8, seed=5)
    teacher = follow_clips(envs, teacher_policy, episodes=8, seed=5)
    standing = follow_clips(envs, lambda o, info: standing_policy(np.zeros(4))(o), episodes=8, seed=5)
    envs.close()
    assert 0.8 < teacher["travel_ratio"] < 1.25, teacher
    assert abs(clone["travel_ratio"] - teacher["travel_ratio"]) < 0.15, (clone, teacher)
    assert standing["travel_ratio"] < 0.05


def test_every_kept_state_is_paired_with_its_own_label_across_episode_ends():
    """The toy teacher's label is a function of the state it labels, so a
    label one step off (or a new episode's first state paired with the
    last one's label) shows; the first iterations' actions are the labels."""
    envs = toy_env.teacher_vector_env(3)
    agent = DAggerAgent(_tiny(teacher_iterations=2, noise=0.0), envs, toy_env.demonstrations(), seed=1)
    ended = False
    for _ in range(3):  # 90 steps of each environment: every one ends an episode (60 steps) on the way
        agent._visited = []
        rollout = agent.collector.collect(agent, agent.config.ppo.horizon)
        observations = np.concatenate([o for o, _ in agent._visited])
        labels = np.concatenate([a for _, a in agent._visited])
        np.testing.assert_allclose(rollout.actions.reshape(-1, 4), labels, atol=1e-6)  # the teacher acted
        expected = np.clip(toy_env.TEACHER_GAIN * (toy_env.TARGET - observations[:, :4]), -1.0, 1.0)
        np.testing.assert_allclose(labels, expected, atol=1e-5)
        ended = ended or bool(rollout.ended.any())
    assert ended
    envs.close()


def test_the_teacher_acts_at_a_share_of_steps_that_falls_after_its_own_iterations():
    envs = toy_env.teacher_vector_env(4)
    agent = DAggerAgent(_tiny(teacher_iterations=2, noise=0.0), envs, toy_env.demonstrations(), seed=0)
    shares = []
    for _ in range(4):
        shares.append(agent.beta)
        agent.counters["iteration"] += 1
    assert shares == pytest.approx([1.0, 1.0, 0.5, 0.25])
    agent.counters["iteration"] = 3  # the teacher at a quarter of the steps
    agent._visited = []
    rollout = agent.collector.collect(agent, 250)
    labels = np.concatenate([a for _, a in agent._visited]).reshape(rollout.actions.shape)
    teacher = np.all(np.abs(rollout.actions - labels) < 1e-6, axis=-1)
    envs.close()
    assert 0.17 < teacher.mean() < 0.33, teacher.mean()


def test_a_resumed_clone_keeps_its_labels_and_optimiser():
    envs = toy_env.teacher_vector_env(2)
    agent = DAggerAgent(_tiny(), envs, toy_env.demonstrations(), seed=0)
    agent.iteration()
    agent.iteration()
    again = DAggerAgent(_tiny(), toy_env.teacher_vector_env(2), toy_env.demonstrations(), seed=9)
    again.load_state_dict(agent.state_dict())
    assert again.counters == agent.counters and again.labelled.size == agent.labelled.size == 120
    np.testing.assert_array_equal(again.labelled.data[:120], agent.labelled.data[:120])
    for a, b in zip(agent.model.parameters(), again.model.parameters()):
        assert torch.equal(a, b)
    moments = [state["exp_avg"] for state in again.optimizer.state_dict()["state"].values()]
    expected = [state["exp_avg"] for state in agent.optimizer.state_dict()["state"].values()]
    assert len(moments) == len(expected) > 0 and all(torch.equal(a, b) for a, b in zip(moments, expected))
    probe = agent.labelled.data[:50]
    assert again.label_loss(probe[:, :8], probe[:, 8:]) == agent.label_loss(probe[:, :8], probe[:, 8:])
    envs.close()
    again.envs.close()


def test_the_clone_goes_on_with_ppo_its_label_loss_fading_on_schedule():
    """With `teacher.ppo_after`, the critic learns the reward's values
    during DAgger, then PPO trains the clone with the label loss at a
    weight falling linearly to 0; the clone keeps the teacher's reward."""
    envs = toy_env.teacher_vector_env(4)
    config = _tiny(ppo_after=960, label_fade_samples=1200, label_weight=2.0)  # 120 samples an iteration
    config.environment.tracking_reward = True
    config.ppo.learning_rate = 1e-4
    agent = DAggerAgent(config, envs, toy_env.demonstrations(), seed=0)
    cloning = [agent.iteration() for _ in range(8)]
    assert agent.handed_over and agent.counters["samples"] == 960 and "approx_kl" not in cloning[-1]
    assert cloning[-1]["critic_loss"] < 0.5 * cloning[0]["critic_loss"], (cloning[0], cloning[-1])
    weights, tuned = [], []
    for _ in range(12):
        weights.append(agent.label_weight)
        tuned.append(agent.iteration())
    envs.close()
    assert weights == pytest.approx([2.0 * max(0.0, 1.0 - 0.1 * k) for k in range(12)])
    assert all("approx_kl" in s and s["label_weight"] == w for s, w in zip(tuned, weights))
    assert tuned[0]["label_term"] > 0.0 and tuned[-1]["label_term"] == 0.0
    assert np.mean([s["reward"] for s in tuned[-4:]]) > 0.8 * cloning[-1]["reward"], (cloning[-1], tuned[-4:])


def test_after_the_handover_each_sample_of_ppo_keeps_its_own_label():
    envs = toy_env.teacher_vector_env(3)
    config = _tiny(ppo_after=1)
    config.environment.tracking_reward = True
    agent = DAggerAgent(config, envs, toy_env.demonstrations(), seed=2)
    agent.iteration()  # past the handover: the policy samples, the labels are still kept
    assert agent.handed_over
    agent._visited = []
    rollout = agent.collect()
    extras = agent.batch_extras(rollout)
    zeros = np.zeros(rollout.rewards.shape, np.float32)
    batch = make_batch(
        agent.model, rollout.observations, {}, rollout.actions, rollout.log_probs, rollout.values, zeros, False, extras
    )
    envs.close()
    minibatch = batch.take(torch.randperm(len(batch))[:40])
    expected = np.clip(toy_env.TEACHER_GAIN * (toy_env.TARGET - minibatch.observations[:, :4].numpy()), -1.0, 1.0)
    np.testing.assert_allclose(minibatch.extras["teacher_action"].numpy(), expected, atol=1e-5)
    assert not np.allclose(rollout.actions.reshape(-1, 4), extras["teacher_action"].reshape(-1, 4))  # the policy acted


def test_dagger_without_the_teacher_in_its_environments_is_refused():
    with pytest.raises(InputError, match="environment.teacher"):
        config_from_dict({"algo": "dagger", "environment": {"teacher": False}})
    config = preset("dagger")
    assert config.environment.control_rate == 60.0 and config.environment.phase_observation
    with pytest.raises(InputError, match="tracking_reward"):
        config_from_dict({"algo": "dagger", "teacher": {"ppo_after": 1000}})


def test_a_loop_setting_is_a_flag_or_the_motions_that_repeat():
    assert config_from_dict({"algo": "dagger", "environment": {"loop": ["walk"]}}).environment.loop == ["walk"]
    assert config_from_dict({"algo": "dagger", "environment": {"loop": True}}).environment.loop is True
    for bad in (3, "walk", [1], [""]):
        with pytest.raises(InputError, match="environment.loop.*true, false or a list of motion names"):
            config_from_dict({"algo": "dagger", "environment": {"loop": bad}})
    assert looped_motions(["walk"], ["walk", "squat"]) == [True, False]
    assert looped_motions(True, ["walk", "squat"]) == [True, True]
    with pytest.raises(InputError, match="jump: not among the motions \\(walk, squat\\)"):
        looped_motions(["walk", "jump"], ["walk", "squat"])


def test_an_environment_without_labels_is_named():
    envs = toy_env.vector_env(2)
    agent = DAggerAgent(_tiny(), envs, toy_env.demonstrations(), seed=0)
    with pytest.raises(RuntimeError, match="teacher=True"):
        agent.iteration()
    envs.close()


class _ObjectEnvs:
    """Two environments of 4-step episodes whose objects rise by `peaks`
    (the first at its last step, seen only in `final_info`), for
    `follow_clips`' held-object figures."""

    num_envs = 2

    def __init__(self, peaks):
        self.peaks, self.steps = np.asarray(peaks, dtype=float), 0

    def _info(self, rise):
        return {
            "root_xy": np.zeros((2, 2)),
            "reference_root_xy": np.zeros((2, 2)),
            "time": np.zeros(2),
            "object_rise": rise,
        }

    def reset(self, seed=None):
        self.steps = 0
        return np.zeros((2, 3)), self._info(np.zeros(2))

    def step(self, actions):
        self.steps += 1
        ending = self.steps % 4 == 0
        rise = np.where(self.steps % 4 == 3, [0.0, self.peaks[1]], 0.0)
        info = self._info(np.zeros(2) if ending else rise)
        if ending:
            info["final_info"] = self._info(np.array([self.peaks[0], 0.0]))
        return np.zeros((2, 3)), np.zeros(2), np.zeros(2, bool), np.full(2, ending), info


def test_follow_clips_counts_the_objects_held_up_at_any_step_of_an_episode():
    report = follow_clips(_ObjectEnvs([0.06, 0.02]), lambda o, info: np.zeros((2, 1)), episodes=4, seed=0)
    assert report["object_episodes"] == 4 and report["objects_held"] == 2, report  # the first's, twice
    report = follow_clips(_ObjectEnvs([0.04, 0.08]), lambda o, info: np.zeros((2, 1)), episodes=2, seed=0)
    assert report["objects_held"] == 1, report
    assert "object_episodes" not in follow_clips(toy_env.teacher_vector_env(1), teacher_policy, episodes=1, seed=0)
