"""The learning package on its own: GAE, normalisers, style rewards, latents,
discriminators, and whole training iterations on a pure-Python environment
(tests/toy_env.py; no Drake)."""

import numpy as np
import pytest
import torch

from hotu_drake.learning.agent import Agent
from hotu_drake.learning.config import preset
from hotu_drake.learning.latents import LatentSchedule, sample_sphere
from hotu_drake.learning.networks import StyleNetwork
from hotu_drake.learning.normalizer import Normalizer
from hotu_drake.learning.parts import resolve_groups
from hotu_drake.learning.ppo import gae
from hotu_drake.learning.style import combine_rewards, discriminator_loss, style_reward
from tests import toy_env

# -- GAE and normalisers -------------------------------------------------------------


def test_gae_matches_hand_computed_values():
    gamma, lam = 0.9, 0.8
    rewards = np.array([[1.0], [2.0], [3.0], [4.0]])
    values = np.array([[0.5], [0.4], [0.3], [0.2]])
    next_values = np.array([[0.4], [0.3], [9.0], [0.1]])  # step 2 fell: its next value is ignored
    terminated = np.array([[0], [0], [1], [0]], bool)
    ended = np.array([[0], [0], [1], [0]], bool)
    d3 = 4.0 + 0.9 * 0.1 - 0.2  # the rollout's end: bootstrapped from the next value
    d2 = 3.0 - 0.3  # a fall: no bootstrap, and the sum stops here
    d1 = 2.0 + 0.9 * 0.3 - 0.4
    d0 = 1.0 + 0.9 * 0.4 - 0.5
    a2 = d2
    a1 = d1 + gamma * lam * a2
    a0 = d0 + gamma * lam * a1
    expected = np.array([[a0], [a1], [a2], [d3]])
    assert np.allclose(gae(rewards, values, next_values, terminated, ended, gamma, lam), expected, atol=1e-6)


def test_gae_bootstraps_a_truncated_episode_but_does_not_run_past_it():
    rewards = np.ones((2, 1))
    values = np.zeros((2, 1))
    next_values = np.array([[5.0], [7.0]])
    ended = np.array([[1], [0]], bool)  # step 0 was truncated (a time limit), not a fall
    advantages = gae(rewards, values, next_values, np.zeros((2, 1), bool), ended, 0.5, 1.0)
    assert np.allclose(advantages[:, 0], [1.0 + 0.5 * 5.0, 1.0 + 0.5 * 7.0])


def test_normaliser_statistics_over_batches_are_those_of_all_the_data():
    rng = np.random.default_rng(0)
    a, b = rng.normal(3.0, 2.0, (50, 3)), rng.normal(-1.0, 0.5, (70, 3))
    normalizer = Normalizer(3)
    normalizer.update(torch.tensor(a, dtype=torch.float32))
    normalizer.update(torch.tensor(b, dtype=torch.float32))
    both = np.concatenate([a, b])
    assert np.allclose(normalizer.mean.numpy(), both.mean(0), atol=1e-4)
    assert np.allclose(normalizer.var.numpy(), both.var(0), rtol=1e-3)
    out = normalizer(torch.tensor(both, dtype=torch.float32)).numpy()
    assert np.allclose(out.mean(0), 0.0, atol=1e-3) and np.allclose(out.std(0), 1.0, atol=1e-2)
    assert normalizer(torch.full((1, 3), 1e6)).max() == normalizer.clip


# -- style rewards and discriminators ---------------------------------------------------


def test_style_rewards_are_bounded_and_follow_the_method():
    logits = torch.tensor([-50.0, -2.0, 0.0, 2.0, 50.0])
    for form in ("amp", "log"):
        r = style_reward(logits, form)
        assert torch.all((r >= 0) & (r <= 1)) and torch.all(r[1:] >= r[:-1])
    d = 2.0 * torch.sigmoid(torch.tensor(2.0)) - 1.0
    assert torch.isclose(style_reward(torch.tensor(2.0)), 1.0 - 0.25 * (d - 1.0) ** 2)
    assert style_reward(torch.tensor(-50.0)) == 0.0 and torch.isclose(style_reward(torch.tensor(50.0)), torch.ones(()))


def test_product_of_bounded_part_rewards():
    rewards = torch.tensor([[0.9, 0.5], [0.8, 1.0], [1.0, 0.2]])  # 3 groups x 2 samples
    product = combine_rewards(rewards, "product")
    assert torch.allclose(product, torch.tensor([0.72, 0.1]))
    assert torch.all(product <= rewards.min(0).values)
    perfect = torch.cat([rewards, torch.ones(1, 2)])  # a part that looks real does not lower the product
    assert torch.allclose(combine_rewards(perfect, "product"), product)
    assert torch.allclose(combine_rewards(rewards, "mean"), rewards.mean(0))
    with pytest.raises(ValueError):
        combine_rewards(rewards, "single")


def test_gradient_penalty_is_non_zero_and_differentiable():
    torch.manual_seed(0)
    network = StyleNetwork(6, (16, 16))
    demo, policy = torch.randn(32, 6), torch.randn(32, 6) + 1.0
    loss, stats = discriminator_loss(network, demo, policy, 5.0, 0.0, 0.0)
    assert stats["grad_penalty"] > 0
    loss.backward()
    with_penalty = [p.grad.clone() for p in network.parameters()]
    network.zero_grad()
    discriminator_loss(network, demo, policy, 0.0, 0.0, 0.0)[0].backward()
    without = [p.grad.clone() for p in network.parameters()]
    # The penalty has its own gradient with respect to the weights (create_graph).
    assert any(not torch.allclose(a, b) for a, b in zip(with_penalty, without))


def _random_policy_windows(history: int, steps: int = 200, seed: int = 0) -> dict[str, np.ndarray]:
    env, rng = toy_env.ToyAmpEnv(history), np.random.default_rng(seed)
    env.reset(seed=seed)
    out: dict[str, list] = {key: [] for key in toy_env.LAYOUT.keys}
    for _ in range(steps):
        *_, truncated, info = env.step(rng.uniform(-1, 1, 4))
        for key in out:
            out[key].append(info["amp"][key])
        if truncated:
            env.reset()
    return {key: np.stack(v) for key, v in out.items()}


def _train_judge(demo: np.ndarray, policy: np.ndarray, updates: int = 100, seed: int = 0) -> StyleNetwork:
    """A discriminator of demonstration windows against policy windows (N, K, d)."""
    torch.manual_seed(seed)
    demo, policy = torch.as_tensor(demo, dtype=torch.float32), torch.as_tensor(policy, dtype=torch.float32)
    network = StyleNetwork(demo[0].numel(), (32, 32))
    network.normalizer.update(torch.cat([demo, policy]).flatten(1))
    optimizer = torch.optim.Adam(network.parameters(), lr=1e-3)
    rng = np.random.default_rng(seed)
    for _ in range(updates):
        d, p = demo[rng.integers(0, len(demo), 64)], policy[rng.integers(0, len(policy), 64)]
        loss, _ = discriminator_loss(network, network.normalize(d), network.normalize(p), 5.0, 0.01, 1e-4)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    return network


def _judged(judge: StyleNetwork, windows: np.ndarray) -> float:
    with torch.no_grad():
        return float(style_reward(judge.logit(judge.normalize(torch.as_tensor(windows, dtype=torch.float32)))).mean())


def test_a_discriminator_separates_demonstrations_from_random_policy_windows():
    demos = toy_env.demonstrations()
    (group,) = resolve_groups(demos.layout, "whole")
    policy = group.gather(_random_policy_windows(demos.history)).astype(np.float32)
    demo = demos.windows(group)
    judge = _train_judge(demo, policy, updates=100)
    with torch.no_grad():
        demo_logit = judge.logit(judge.normalize(torch.as_tensor(demo)))
        policy_logit = judge.logit(judge.normalize(torch.as_tensor(policy)))
    assert (demo_logit > 0).float().mean() > 0.95 and (policy_logit < 0).float().mean() > 0.95
    assert _judged(judge, demo) > 2 * _judged(judge, policy)


# -- latents -------------------------------------------------------------------------


def test_latents_lie_on_the_sphere():
    z = sample_sphere(np.random.default_rng(0), 1000, 8)
    assert np.allclose(np.linalg.norm(z, axis=1), 1.0, atol=1e-6)
    assert np.abs(z.mean(0)).max() < 0.1  # no preferred direction


def test_latents_are_resampled_on_each_groups_own_timer_and_at_episode_ends():
    schedule = LatentSchedule(["a", "b"], 4, 3, 3, 4, np.random.default_rng(0))  # U[3, 4): every 3 steps
    start = schedule.current()
    schedule.step()
    schedule.step()
    assert all(np.array_equal(schedule.current()[g], start[g]) for g in start)
    schedule.step()
    assert all(not np.allclose(schedule.current()[g][i], start[g][i]) for g in start for i in range(3))
    before = schedule.current()
    schedule.step(np.array([False, True, False]))  # environment 1's episode ended
    after = schedule.current()
    assert np.allclose(after["a"][[0, 2]], before["a"][[0, 2]]) and not np.allclose(after["a"][1], before["a"][1])
    wide = LatentSchedule(["a", "b"], 4, 64, 1, 50, np.random.default_rng(1))
    assert not np.array_equal(wide.countdown["a"], wide.countdown["b"])  # independent timers per group


# -- whole iterations on the toy environment -------------------------------------------------------


def _tiny(algo: str = "dail"):
    config = preset(algo)
    config.ppo.horizon = 64
    config.ppo.minibatch_size = 128
    config.ppo.gamma = 0.9
    config.ppo.learning_rate = 1e-3
    config.action.residual_scale = 1.0
    config.action.std = 0.3
    config.action.part_std = {}
    config.networks.policy_hidden = config.networks.critic_hidden = (64, 64)
    config.networks.discriminator_hidden = (32, 32)
    config.style.batch_size = 128
    config.style.learning_rate = 1e-3
    config.style.replay_size = 2000
    config.warm_start.epochs = 0
    config.warm_start.keep_weight = 0.0  # PPO and the style rewards alone (the cloning has its own tests)
    config.torch_threads = 1
    return config


def test_style_reward_of_the_trained_policy_rises_well_above_the_initial_one():
    """Judged by a discriminator trained apart, on demonstrations against the
    initial policy (the trainer's own judges move with the policy)."""
    envs = toy_env.vector_env(4)
    demos = toy_env.demonstrations()
    agent = Agent(_tiny(), envs, demos, seed=0)
    assert [g.name for g in agent.groups] == ["lower_body", "left_arm", "right_arm"]
    (whole,) = resolve_groups(demos.layout, "whole")

    def windows() -> np.ndarray:
        agent.model.eval()
        rollout = agent.collect()
        return whole.gather(rollout.amp).reshape(-1, demos.history, whole.frame_size)

    initial = windows()
    judge = _train_judge(demos.windows(whole), initial, updates=200)
    for _ in range(60):
        agent.iteration()
    trained = windows()
    envs.close()
    before, after = _judged(judge, initial), _judged(judge, trained)
    assert after > before + 0.3, (before, after)
    distance = lambda w: np.abs(w[:, -1] - toy_env.TARGET).mean()  # noqa: E731
    assert distance(trained) < 0.7 * distance(initial), (distance(initial), distance(trained))


@pytest.mark.parametrize("algo", ["amp", "ase", "pmp"])
def test_every_preset_trains_on_the_same_environment(algo):
    envs = toy_env.vector_env(2)
    config = _tiny(algo)
    agent = Agent(config, envs, toy_env.demonstrations(), seed=0)
    expected = {"amp": 1, "ase": 1, "pmp": 3}[algo]
    assert len(agent.groups) == expected and bool(agent.latents.groups) == (algo == "ase")
    stats = agent.iteration()
    envs.close()
    assert stats["samples"] == 128 and np.isfinite(stats["actor_loss"]) and 0 <= stats["style"] <= 1


def test_the_same_seed_gives_the_same_first_iteration():
    def first(seed: int) -> dict:
        envs = toy_env.vector_env(2)
        torch.manual_seed(123)  # the agent seeds torch itself: an earlier state must not matter
        stats = Agent(_tiny(), envs, toy_env.demonstrations(), seed=seed).iteration()
        envs.close()
        timings = ("rollout_seconds", "update_seconds", "learner_share", "samples_per_second")
        return {k: v for k, v in stats.items() if k not in timings}

    a, b, c = first(7), first(7), first(8)
    assert a == b
    assert a != c


def test_a_resumed_agent_continues_with_the_same_counters_and_optimiser_state():
    envs = toy_env.vector_env(2)
    agent = Agent(_tiny(), envs, toy_env.demonstrations(), seed=0)
    agent.iteration()
    state = agent.state_dict()
    again = Agent(_tiny(), toy_env.vector_env(2), toy_env.demonstrations(), seed=99)
    again.load_state_dict(state)
    assert again.counters == agent.counters
    for a, b in zip(agent.model.parameters(), again.model.parameters()):
        assert torch.equal(a, b)
    moments = agent.ppo.actor_optimizer.state_dict()["state"][0]["exp_avg"]
    assert torch.equal(again.ppo.actor_optimizer.state_dict()["state"][0]["exp_avg"], moments)
    assert torch.equal(again.generator.get_state(), agent.generator.get_state())
    again.iteration()
    assert again.counters["iteration"] == 2 and again.counters["samples"] == 256
    envs.close()


def test_a_low_style_reward_ends_episodes_after_the_patience():
    config = _tiny()
    config.environment.style_termination = 0.99  # an untrained judge never gives this much
    config.environment.style_patience = 5
    envs = toy_env.vector_env(2)
    agent = Agent(config, envs, toy_env.demonstrations(), seed=0)
    rollout = agent.collect()
    envs.close()
    assert rollout.cut.sum() > 0
    assert np.all(rollout.terminated[rollout.cut])  # a cut is an end without bootstrap
    assert set(agent.episodes.lengths) == {5}


def test_holding_one_reference_pose_is_near_the_reference_but_covers_little_of_it():
    from hotu_drake.learning.evaluation import similarity

    demos = toy_env.demonstrations()
    reference = np.concatenate([m.joints for m in demos.motions.values()])
    held = np.repeat(reference[:1], 50, axis=0)  # one frame of the clip, held
    moving = reference[::3]  # the clip itself, sampled
    still, follows = similarity(held, np.zeros(50), demos), similarity(moving, np.zeros(len(moving)), demos)
    assert still["joint_distance_deg"]["all"] < 1e-3  # every held frame is a reference frame...
    assert still["coverage_deg"]["all"] > 10 * follows["coverage_deg"]["all"]  # ...but most of the clip is far


def test_part_noise_sets_the_exploration_of_that_parts_joints():
    config = preset("amp")
    config.action.std, config.action.part_std = 0.04, {"shoulder": 0.2}
    agent = Agent(config.validate(), toy_env.vector_env(2), toy_env.demonstrations(), seed=0)
    std = agent.model.log_std.exp().numpy()
    assert np.allclose(std[[2, 3]], 0.2) and np.allclose(std[[0, 1]], 0.04)
    config.action.part_std = {"elbowz": 0.2}
    with pytest.raises(Exception, match="part_std"):
        config.validate()


def test_the_still_ends_of_a_clip_are_left_out_of_the_demonstrations():
    from hotu_drake.learning.demonstrations import Demonstrations, MotionData
    from hotu_drake.learning.parts import AmpLayout

    still, moving = 10, 20
    joints = np.concatenate([np.zeros(still), np.linspace(0.0, 2.0, moving), np.full(still, 2.0)])[:, None]
    n = len(joints)
    demos = Demonstrations(
        layout=AmpLayout.anonymous({"hip": 1}),
        motions={"lift": MotionData({"hip": joints}, joints, np.zeros((n, 1)), joints)},
        joint_names=["hip_y"],
        part_joints={"hip": [0]},
        history=4,
        control_rate=30.0,
    )
    [group] = resolve_groups(demos.layout, "whole")
    assert len(demos.windows(group)) == n
    kept = demos.windows(group, still_speed=0.5)
    # the ramp's first frame repeats the still 0 and its last the still 2: a window of 4 shows motion if it
    # ends at frame 11 or later and begins at frame 28 or earlier (ends 11..31)
    assert len(kept) == 21
    assert all(np.ptp(w) > 0 for w in kept)  # every window kept shows some motion
    assert not demos.moving_windows("lift", 0.5)[: still - 1].any()


def test_jittered_cloning_answers_states_near_the_clips_better():
    demos = toy_env.demonstrations()
    observations, actions = map(torch.as_tensor, demos.behavior_cloning_pairs())
    rng = torch.Generator().manual_seed(0)
    near = observations + 0.5 * observations.std(0) * torch.randn(observations.shape, generator=rng)

    def error(noise: float) -> float:
        config = _tiny("amp")
        config.warm_start.epochs, config.warm_start.observation_noise = 300, noise
        agent = Agent(config, toy_env.vector_env(1), demos, seed=0)
        agent.warm_start()
        with torch.no_grad():
            return float((agent.model.policy.mean(near, {}) - actions).square().mean())

    assert error(0.5) < 0.75 * error(0.0)  # 0.55-0.6 x over seeds 0-2


def test_the_cloning_term_is_kept_during_ppo_and_fades_out():
    config = _tiny("amp")
    config.warm_start.keep_weight, config.warm_start.keep_samples = 5.0, 256
    agent = Agent(config, toy_env.vector_env(2), toy_env.demonstrations(), seed=0)
    agent.warm_start()
    first, second, third = agent.iteration(), agent.iteration(), agent.iteration()
    assert first["cloning_loss"] > 0 and second["cloning_loss"] > 0  # 128 samples per iteration
    assert "cloning_loss" not in third
