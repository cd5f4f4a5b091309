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
    assert standing["travel_ratio"] < 0.05 and standing["fall_rate"] == 0.0
    assert clone["mean_episode_seconds"] == pytest.approx(2.0)  # the toy's 60 steps at 30 Hz


def test_the_teacher_acts_at_a_share_of_steps_that_falls_after_its_own_iterations():
    envs = toy_env.teacher_vector_env(2)
    agent = DAggerAgent(_tiny(teacher_iterations=2), envs, toy_env.demonstrations(), seed=0)
    shares = []
    for _ in range(4):
        shares.append(agent.beta)
        agent.counters["iteration"] += 1
    envs.close()
    assert shares == pytest.approx([1.0, 1.0, 0.5, 0.25])


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
    probe = agent.labelled.data[:50]
    assert again.label_loss(probe[:, :8], probe[:, 8:]) == agent.label_loss(probe[:, :8], probe[:, 8:])
    envs.close()
    again.envs.close()


def test_dagger_without_the_teacher_in_its_environments_is_refused():
    with pytest.raises(InputError, match="environment.teacher"):
        config_from_dict({"algo": "dagger", "environment": {"teacher": False}})
    config = preset("dagger")
    assert config.environment.control_rate == 60.0 and config.environment.phase_observation


def test_an_environment_without_labels_is_named():
    envs = toy_env.vector_env(2)
    agent = DAggerAgent(_tiny(), envs, toy_env.demonstrations(), seed=0)
    with pytest.raises(RuntimeError, match="teacher=True"):
        agent.iteration()
    envs.close()
