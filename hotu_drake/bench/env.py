"""Environment throughput: Imitation-v0 steps per second, and a MuJoCo peer.

Every run drives the environment with the same workload: episodes start
from the standing pose (no reference-state starts, so both engines run the
same motion), the actions are the standing pose's plus Gaussian noise
(0.01, seeded), and an episode resets when it ends. Three measurements:

- in process, one core: steps per second and the per-step split (physics =
  `AdvanceTo`; observation; AMP observation; the rest of `step` is Python
  overhead);
- `N` worker processes (`make_vector_env`): steps per second summed over
  the workers, including the inter-process traffic;
- with a peer, the same embodiment's MJCF under MuJoCo at the same time
  step and control rate, on a floor plane: position actuators with the same gains and
  effort limits, `mj_step` over the control period, then the same kind of
  observation read (joint state, root pose and velocity, key bodies).
"""

import resource
import time

import gymnasium as gym
import numpy as np

from hotu_drake import embodiment as embodiments
from hotu_drake.embodiment.actions import ActionScaling, standing_action
from hotu_drake.embodiment.spec import FOOT_ROLES, HAND_ROLES
from hotu_drake.envs import EnvSpec, make_vector_env

NOISE = 0.01
KEY_BODY_ROLES = (*HAND_ROLES, *FOOT_ROLES)


def _actions(emb, seed: int):
    rng = np.random.default_rng(seed)
    standing = standing_action(emb)
    while True:
        yield np.clip(standing + NOISE * rng.standard_normal(standing.size), -1.0, 1.0).astype(np.float32)


def peak_memory_mb() -> dict:
    """Peak resident memory of this process and of its (waited-for) children."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return {"this_process": round(own, 1), "largest_worker": round(children, 1)}


def in_process(robot: str, hands: str, seconds: float, motions: list[str], seed: int = 0) -> dict:
    """One environment in this process: steps per second and the per-step split."""
    env = gym.make("hotu_drake/Imitation-v0", robot=robot, hands=hands, motions=motions, reference_init_probability=0.0)
    inner = env.unwrapped
    env.reset(seed=seed)
    actions = _actions(inner.embodiment, seed)
    for _ in range(30):  # warm up: first Eval allocations, caches
        _, _, term, trunc, _ = env.step(next(actions))
        if term or trunc:
            env.reset()
    inner.timings = type(inner.timings)()
    steps, episodes, start = 0, 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        _, _, term, trunc, _ = env.step(next(actions))
        steps += 1
        if term or trunc:
            episodes += 1
            env.reset()
    wall = time.perf_counter() - start
    split = inner.timings.per_step_ms()
    env.close()
    return {
        "env_steps_per_second": round(steps / wall, 1),
        "sim_seconds_per_wall_second": round(steps * inner.control_period / wall, 2),
        "ms_per_step": split,
        "physics_share": round(split["physics"] / split["total"], 3),
        "episodes_ended": episodes,
    }


def vectorised(robot: str, hands: str, seconds: float, motions: list[str], num_envs: int, seed: int = 0) -> dict:
    """`num_envs` worker processes stepping together."""
    options = {"robot": robot, "hands": hands, "motions": motions, "reference_init_probability": 0.0}
    spec = EnvSpec("hotu_drake/Imitation-v0", options)
    envs = make_vector_env(spec, num_envs)
    try:
        envs.reset(seed=seed)
        emb = embodiments.load(robot, hands)
        streams = [_actions(emb, seed + i) for i in range(num_envs)]

        def batch():
            return np.stack([next(s) for s in streams])

        for _ in range(10):
            envs.step(batch())
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            envs.step(batch())
            steps += num_envs
        wall = time.perf_counter() - start
    finally:
        envs.close()
    return {
        "workers": num_envs,
        "env_steps_per_second": round(steps / wall, 1),
        "sim_seconds_per_wall_second": round(steps / 30.0 / wall, 2),
    }


def mujoco_peer(
    robot: str, hands: str, seconds: float, time_step: float = 1.0 / 180.0, control_rate: float = 30.0
) -> dict:
    """The same loop under MuJoCo (the `mujoco` extra)."""
    try:
        import mujoco
    except ImportError:
        raise RuntimeError("--peer mujoco needs MuJoCo: pip install 'hotu-drake[mujoco]'") from None
    from hotu_drake.resources import model_path

    emb = embodiments.load(robot, hands)
    spec = mujoco.MjSpec.from_file(str(model_path(robot, hands, "mjcf")))
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1])  # the floor, as in Drake
    model = spec.compile()
    model.opt.timestep = time_step
    data = mujoco.MjData(model)
    joint_address = [model.joint(name).qposadr[0] for name in emb.joint_names]
    actuator = [model.actuator(name).id for name in emb.joint_names]
    keys = [model.body(emb.key_bodies[r]).id for r in KEY_BODY_ROLES if r in emb.key_bodies]
    scaling = ActionScaling.for_embodiment(emb)
    floating = emb.floating_base

    def reset():
        mujoco.mj_resetData(model, data)
        if floating:
            data.qpos[:7] = [0.0, 0.0, emb.standing_root_height, 1.0, 0.0, 0.0, 0.0]
        data.qpos[joint_address] = emb.standing_pose
        mujoco.mj_forward(model, data)

    reset()
    actions = _actions(emb, 0)
    period, steps, episodes, episode_start = 1.0 / control_rate, 0, 0, 0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds:
        data.ctrl[actuator] = scaling.to_targets(next(actions))
        next_control = (steps - episode_start + 1) * period
        substeps = max(1, int(round((next_control - data.time) / time_step)))
        mujoco.mj_step(model, data, nstep=substeps)
        np.concatenate([data.qpos, data.qvel, data.cvel[1], data.xpos[keys].ravel()])  # the observation read
        steps += 1
        if floating and data.qpos[2] < 0.5 * emb.standing_root_height:
            episodes += 1
            episode_start = steps
            reset()
    wall = time.perf_counter() - start
    return {
        "engine": f"mujoco {mujoco.__version__}",
        "env_steps_per_second": round(steps / wall, 1),
        "substeps_per_control_step": round(period / time_step, 3),
        "episodes_ended": episodes,
    }
