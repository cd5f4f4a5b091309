"""Environment throughput: Imitation-v0 steps per second, and a MuJoCo peer.

Every run drives the environment with the same workload: episodes start
from the standing pose (no reference-state starts, so both engines run the
same motion), the actions are the standing pose's plus Gaussian noise
(0.01, seeded), and an episode resets when it ends. Three measurements:

- in process, one core: steps per second and the per-step split (physics =
  `AdvanceTo`; observation; AMP observation; the rest of `step` is Python
  overhead), at the default plant and at hotu_drake 0.2's (1/180 s, SAP
  near-rigid threshold 1.0), in the same run;
- 1 and `N` worker processes (`make_vector_env`, local or Ray): steps per
  second summed over the workers, including the inter-process traffic;
- with a peer, the same embodiment's MJCF under MuJoCo at its own stable
  step (the largest of `MUJOCO_STEPS` at which it stands the workload for
  3 s within the fidelity bound of its own fine step), on a floor plane:
  position actuators with the same gains and effort limits, `mj_step`
  over the control period, then the same kind of
  observation read (joint state, root pose and velocity, key bodies).

Each engine's speed comes with its fidelity figure: the RMS distance of
the pelvis and key bodies, over 3 s of the same workload, between its step
and a fine one (1/1440 s), so the ratio compares like with like.
"""

import resource
import time

import gymnasium as gym
import numpy as np

from hotu_drake import embodiment as embodiments
from hotu_drake.bench.fidelity import ERROR_BOUND_MM
from hotu_drake.embodiment.actions import ActionScaling, standing_action
from hotu_drake.embodiment.spec import FOOT_ROLES, HAND_ROLES
from hotu_drake.envs import EnvSpec, make_vector_env
from hotu_drake.scenario import Scenario, default_plant_config

NOISE = 0.01
TRACKED = ("pelvis", *HAND_ROLES, *FOOT_ROLES)
FINE_STEP = 1.0 / 1440.0
FIDELITY_SECONDS = 3.0
MUJOCO_STEPS = (1 / 60, 1 / 120, 1 / 240, 1 / 480, 1 / 960)  # candidates for MuJoCo's own stable step


def _actions(emb, seed: int, batch: tuple[int, ...] = ()):
    """The benchmark's policy: the standing action plus noise, for one
    environment or, with `batch=(n,)`, for n at once as a policy acts on a batch."""
    rng = np.random.default_rng(seed)
    standing = standing_action(emb).astype(np.float32)
    while True:
        noise = rng.standard_normal((*batch, standing.size), dtype=np.float32)
        yield np.clip(standing + NOISE * noise, -1.0, 1.0)


def peak_memory_mb() -> dict:
    """Peak resident memory of this process and of its (waited-for) children."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return {"this_process": round(own, 1), "largest_worker": round(children, 1)}


def _scenario(robot: str, hands: str, plant: tuple[float, float] | None) -> Scenario:
    """The environment's scenario, at `plant` = (time step, near-rigid threshold) if given."""
    scenario = Scenario(embodiment=robot, hands=hands)
    if plant is not None:
        scenario.plant_config.time_step, scenario.plant_config.sap_near_rigid_threshold = plant
    return scenario


def plant_settings(plant: tuple[float, float] | None) -> dict:
    config = default_plant_config()
    step, threshold = plant if plant is not None else (config.time_step, config.sap_near_rigid_threshold)
    return {"time_step": step, "near_rigid_threshold": threshold}


def in_process(
    robot: str, hands: str, seconds: float, motions: list[str], seed: int = 0, plant: tuple[float, float] | None = None
) -> dict:
    """One environment in this process: steps per second and the per-step split."""
    scenario = _scenario(robot, hands, plant)
    env = gym.make("hotu_drake/Imitation-v0", scenario=scenario, motions=motions, reference_init_probability=0.0)
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
        "plant": plant_settings(plant),
        "env_steps_per_second": round(steps / wall, 1),
        "sim_seconds_per_wall_second": round(steps * inner.control_period / wall, 2),
        "ms_per_step": split,
        "physics_share": round(split["physics"] / split["total"], 3),
        "episodes_ended": episodes,
    }


def vectorised(
    robot: str, hands: str, seconds: float, motions: list[str], num_envs: int, seed: int = 0, backend: str = "local"
) -> dict:
    """`num_envs` workers (processes, or Ray actors) stepping together."""
    options = {"robot": robot, "hands": hands, "motions": motions, "reference_init_probability": 0.0}
    spec = EnvSpec("hotu_drake/Imitation-v0", options)
    envs = make_vector_env(spec, num_envs, backend=backend)
    try:
        envs.reset(seed=seed)
        emb = embodiments.load(robot, hands)
        actions = _actions(emb, seed, (num_envs,))
        for _ in range(10):
            envs.step(next(actions))
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            envs.step(next(actions))
            steps += num_envs
        wall = time.perf_counter() - start
    finally:
        envs.close()
    return {
        "workers": num_envs,
        "backend": backend,
        "env_steps_per_second": round(steps / wall, 1),
        "sim_seconds_per_wall_second": round(steps / 30.0 / wall, 2),
    }


def drake_fidelity(robot: str, hands: str, plant: tuple[float, float] | None = None, seconds: float = 3.0) -> float:
    """RMS distance (mm) of the pelvis and key bodies between the environment at
    `plant` and at the fine step, under the benchmark's workload for `seconds`."""

    def track(setting):
        env = gym.make("hotu_drake/Imitation-v0", scenario=_scenario(robot, hands, setting), motions=["walk"])
        inner = env.unwrapped
        env.reset(seed=0, options={"init": "default"})
        inner._set_default_state(0.0)  # the same start for both runs
        inner.sim.simulator.Initialize()
        plant_, context = inner.sim.plant, inner._plant_context
        bodies = [plant_.GetBodyByName(inner.embodiment.key_bodies[r], inner.sim.model) for r in TRACKED]
        actions, out = _actions(inner.embodiment, 0), []
        for _ in range(int(round(seconds * 30))):
            env.step(next(actions))
            out.append([plant_.EvalBodyPoseInWorld(context, b).translation() for b in bodies])
        env.close()
        return np.array(out)

    setting = plant if plant is not None else tuple(plant_settings(None).values())
    fine = (FINE_STEP, setting[1])
    return round(1000 * float(np.sqrt(np.mean(np.sum((track(setting) - track(fine)) ** 2, axis=-1)))), 2)


class _MujocoRobot:
    """The embodiment's MJCF on a floor plane, driven like the environment."""

    def __init__(self, robot: str, hands: str, time_step: float, control_rate: float = 30.0):
        try:
            import mujoco
        except ImportError:
            raise RuntimeError("--peer mujoco needs MuJoCo: pip install 'hotu-drake[mujoco]'") from None
        from hotu_drake.resources import model_path

        self.mujoco, self.emb = mujoco, embodiments.load(robot, hands)
        spec = mujoco.MjSpec.from_file(str(model_path(robot, hands, "mjcf")))
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1])  # the floor, as in Drake
        self.model = spec.compile()
        self.model.opt.timestep = time_step
        self.data = mujoco.MjData(self.model)
        emb = self.emb
        self.joints = [self.model.joint(name).qposadr[0] for name in emb.joint_names]
        self.actuators = [self.model.actuator(name).id for name in emb.joint_names]
        self.keys = [self.model.body(emb.key_bodies[r]).id for r in TRACKED if r in emb.key_bodies]
        self.scaling = ActionScaling.for_embodiment(emb)
        self.time_step, self.period = time_step, 1.0 / control_rate
        self.reset()

    def reset(self) -> None:
        mujoco, data, emb = self.mujoco, self.data, self.emb
        mujoco.mj_resetData(self.model, data)
        if emb.floating_base:
            data.qpos[:7] = [0.0, 0.0, emb.standing_root_height, 1.0, 0.0, 0.0, 0.0]
        data.qpos[self.joints] = emb.standing_pose
        mujoco.mj_forward(self.model, data)
        self.steps = 0

    def step(self, action) -> np.ndarray:
        """One control period; the observation read (joint state, root, key bodies)."""
        data = self.data
        data.ctrl[self.actuators] = self.scaling.to_targets(action)
        self.steps += 1
        substeps = max(1, int(round((self.steps * self.period - data.time) / self.time_step)))
        self.mujoco.mj_step(self.model, data, nstep=substeps)
        return np.concatenate([data.qpos, data.qvel, data.cvel[1], data.xpos[self.keys].ravel()])

    def fell(self) -> bool:
        if not np.all(np.isfinite(self.data.qpos)):
            return True
        return self.emb.floating_base and self.data.qpos[2] < 0.5 * self.emb.standing_root_height

    def track(self, seconds: float) -> np.ndarray | None:
        """Key-body positions under the workload for `seconds`; None if it falls."""
        actions, out = _actions(self.emb, 0), []
        for _ in range(int(round(seconds * 30))):
            self.step(next(actions))
            if self.fell():
                return None
            out.append(self.data.xpos[self.keys].copy())
        return np.array(out)


def mujoco_peer(robot: str, hands: str, seconds: float, control_rate: float = 30.0) -> dict:
    """The same loop under MuJoCo (the `mujoco` extra), at its own stable step
    (the largest of `MUJOCO_STEPS` at which it stands the workload within the
    fidelity harness's bound of its own fine step), with that fidelity figure."""
    fine = _MujocoRobot(robot, hands, FINE_STEP, control_rate).track(FIDELITY_SECONDS)
    time_step, error = MUJOCO_STEPS[-1], None
    for step in MUJOCO_STEPS:  # the largest step that stands the workload within the fidelity bound
        track = _MujocoRobot(robot, hands, step, control_rate).track(FIDELITY_SECONDS)
        if track is None:
            continue
        error = None if fine is None else round(1000 * float(np.sqrt(np.mean(np.sum((track - fine) ** 2, axis=-1)))), 2)
        if error is not None and error <= ERROR_BOUND_MM:
            time_step = step
            break
    sim = _MujocoRobot(robot, hands, time_step, control_rate)
    actions = _actions(sim.emb, 0)
    steps, episodes = 0, 0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds:
        sim.step(next(actions))
        steps += 1
        if sim.fell():
            episodes += 1
            sim.reset()
    wall = time.perf_counter() - start
    return {
        "engine": f"mujoco {sim.mujoco.__version__}",
        "time_step": time_step,
        "env_steps_per_second": round(steps / wall, 1),
        "substeps_per_control_step": round(sim.period / time_step, 3),
        "episodes_ended": episodes,
        "trajectory_error_mm": error,
    }
