"""The skill trainer on the toy task (no Drake): D_I, eq. (3), the held
high-level action, and a high level that learns to use its controller."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torch import nn

from hotu_drake.learning.config import preset
from hotu_drake.learning.evaluation import evaluate_task
from hotu_drake.learning.high_level import to_latents
from hotu_drake.learning.interaction import InteractionJudge, transitions
from hotu_drake.learning.low_level import LowLevelController
from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork, StyleNetwork
from hotu_drake.learning.parts import resolve_groups
from hotu_drake.learning.skill_agent import SkillAgent
from hotu_drake.learning.skill_config import SkillConfig, skill_config_from_dict, skill_preset
from tests import toy_env

HISTORY = 4


def _toy_controller() -> LowLevelController:
    """A controller whose action is its latent (one group, four numbers): the
    high level steers the toy's coordinates directly through it."""
    config = preset("ase")
    config.latent.size = 4
    config.environment.amp_history = HISTORY
    config.networks.discriminator_hidden = (16,)
    policy = PolicyNetwork(PolicyConfig(8, 4, {"whole_body": 4}, hidden=()))
    with torch.no_grad():
        weight = torch.zeros(4, 12)
        weight[:, 8:] = torch.eye(4)
        policy.body[-1].weight.copy_(weight)
    groups = resolve_groups(toy_env.LAYOUT, "whole")
    style = nn.ModuleDict({g.name: StyleNetwork(HISTORY * g.frame_size, (16,), 4) for g in groups})
    return LowLevelController.from_parts(policy, style, groups, config, "toy", "none")


def _tiny(algo: str = "ours", hold_steps: int = 2) -> SkillConfig:
    config = skill_config_from_dict(
        {
            "algo": algo,
            "ppo": {"horizon": 16, "epochs": 4, "minibatch_size": 32, "learning_rate": 3e-3},
            "high_level": {"hold_steps": hold_steps, "hidden": [32], "critic_hidden": [32], "std": 0.3},
            "interaction": {"hidden": [32], "batch_size": 64, "learning_rate": 1e-3},
        }
    )
    return config


def _demos() -> np.ndarray:
    return transitions(toy_env.interaction_demonstrations())


def _logits(judge: InteractionJudge, pairs: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        return judge.network.logit(judge.network.normalize(torch.as_tensor(pairs))).numpy()


def test_the_interaction_discriminator_separates_demonstrations_from_random_transitions():
    rng = np.random.default_rng(0)
    demos = _demos()
    config = _tiny().interaction
    config.updates = 4
    judge = InteractionJudge(demos[::2], config, rng)

    def random(count: int) -> np.ndarray:
        pairs = rng.uniform(-1.0, 1.0, (count, 2, 3)).astype(np.float32)
        pairs[..., 2] = rng.integers(0, 2, (count, 2))
        return pairs

    held_out_demo, held_out_random = demos[1::2], random(500)
    before = (_logits(judge, held_out_demo) > 0).mean() + (_logits(judge, held_out_random) < 0).mean()
    for _ in range(200):
        judge.update(random(50))
    after = (_logits(judge, held_out_demo) > 0).mean() + (_logits(judge, held_out_random) < 0).mean()
    assert 0.5 * before < 0.7 and 0.5 * after > 0.85, (before / 2, after / 2)  # held-out accuracy
    assert judge.reward(held_out_demo).mean() > judge.reward(held_out_random).mean() + 0.03


def test_eq3_combines_the_terms_with_the_configured_weights():
    config = _tiny()
    config.reward.task, config.reward.interaction, config.reward.style = 0.5, 0.3, 0.2
    envs = toy_env.task_vector_env(2, HISTORY)
    agent = SkillAgent(config, envs, _toy_controller(), _demos(), seed=0)
    terms = {"task": np.array([1.0, 0.0]), "interaction": np.array([0.0, 1.0]), "style": np.array([1.0, 1.0])}
    np.testing.assert_allclose(agent.combine(terms), [0.7, 0.5])
    terms = agent.rewards(agent.collect())
    np.testing.assert_allclose(
        terms["total"], 0.5 * terms["task"] + 0.3 * terms["interaction"] + 0.2 * terms["style"], rtol=1e-6
    )
    assert terms["interaction"].std() > 0 and terms["style"].std() > 0  # both judges answered
    envs.close()


class _Spy(LowLevelController):
    """Records the latents it is asked to act with."""

    def act(self, observations, latents):
        self.seen.append(latents["whole_body"].copy())
        return super().act(observations, latents)


@pytest.mark.parametrize("hold_steps", [1, 3])
def test_the_high_level_action_is_held_for_k_control_steps(hold_steps):
    base = _toy_controller()
    spy = _Spy(base.policy, base.style, base.groups, base.config, "toy", "none")
    spy.seen = []
    envs = toy_env.task_vector_env(2, HISTORY)
    agent = SkillAgent(_tiny(hold_steps=hold_steps), envs, spy, _demos(), seed=1)
    rollout = agent.collect()
    seen = np.array(spy.seen)  # (T * k, N, 4)
    assert len(seen) == agent.config.ppo.horizon * hold_steps == agent.num_samples(rollout) // 2
    blocks = seen.reshape(agent.config.ppo.horizon, hold_steps, 2, 4)
    np.testing.assert_array_equal(blocks, np.repeat(blocks[:, :1], hold_steps, axis=1))  # held inside a step
    assert not np.allclose(blocks[1:, 0], blocks[:-1, 0])  # and new at each high-level step
    expected = to_latents(rollout.actions, ["whole_body"], 4)["whole_body"]
    np.testing.assert_allclose(blocks[:, 0], expected, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(expected, axis=-1), 1.0, atol=1e-5)
    envs.close()


def test_the_high_level_learns_to_reach_the_goal_through_its_controller():
    config = _tiny("ase")
    config.reward.task, config.reward.style = 1.0, 0.0
    config.ppo.gamma = config.ppo.lam = 0.9  # a high-level step moves the toy 7 cm: short horizons learn fast
    envs = toy_env.task_vector_env(4, HISTORY)
    agent = SkillAgent(config, envs, _toy_controller(), seed=0)
    before = evaluate_task(envs, agent.controller(), episodes=8, seed=3, max_steps=60)
    assert "reward/interaction" not in agent.iteration()  # ase: no D_I, no interaction term
    rewards = [agent.iteration()["reward/task"] for _ in range(59)]
    assert np.mean(rewards[-10:]) > np.mean(rewards[:10]) + 0.15, rewards
    after = evaluate_task(envs, agent.controller(), episodes=8, seed=3, max_steps=60)
    assert after["episodes"] == 8 and after["normalized_return"] > before["normalized_return"] + 0.15
    envs.close()


def test_a_resumed_skill_agent_continues_where_it_stopped():
    envs = toy_env.task_vector_env(2, HISTORY)
    agent = SkillAgent(_tiny(), envs, _toy_controller(), _demos(), seed=2)
    agent.iteration()
    state = agent.state_dict()
    other = SkillAgent(_tiny(), envs, _toy_controller(), _demos(), seed=9)
    other.load_state_dict(state)
    assert other.counters == agent.counters
    for a, b in zip(agent.model.parameters(), other.model.parameters()):
        torch.testing.assert_close(a, b)
    torch.testing.assert_close(agent.judge.network.state_dict(), other.judge.network.state_dict())
    envs.close()


def test_presets_and_bad_configurations():
    assert skill_preset("ase").reward.interaction == 0 and not skill_preset("ase").uses_interaction
    assert skill_preset("ours").uses_interaction and skill_preset("ours").two_level
    assert skill_preset("pmp").one_level.style.combine == "mean" and not skill_preset("amp").two_level
    with pytest.raises(ValueError, match="high_level.hold_steps"):
        skill_config_from_dict({"high_level": {"hold_steps": 0}})
    with pytest.raises(ValueError, match="unknown field"):
        skill_config_from_dict({"reward": {"grip": 1.0}})
    envs = toy_env.task_vector_env(1, HISTORY)
    with pytest.raises(ValueError, match="one-level"):
        SkillAgent(skill_preset("amp"), envs, _toy_controller())
    with pytest.raises(ValueError, match="D_I needs"):
        SkillAgent(_tiny("ours"), envs, _toy_controller())
    envs.close()
