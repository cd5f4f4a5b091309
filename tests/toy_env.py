"""A tiny pure-Python environment with the `info["amp"]` contract, for the
learning package's tests: no Drake, microseconds a step.

Four velocity-controlled coordinates: two of a "root" and one of each
"shoulder" (columns `left_a` and `right_a`, so the default grouping makes
three part groups of it). The demonstration holds each coordinate near its
own target with a small sway; a new episode starts near zero, so a policy
must learn to move there and stay to look like the demonstration.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from hotu_drake.learning.demonstrations import Demonstrations, MotionData
from hotu_drake.learning.parts import AmpLayout

ENV_ID = "tests/ToyAmp-v0"
CONTROL_RATE = 30.0
SPEED = 1.0  # coordinate units per second at action 1
TARGET = np.array([0.6, -0.5, 0.4, -0.7])
SWAY = 0.05
LAYOUT = AmpLayout(
    {
        "root": ("root:x", "root:y"),
        "shoulder": ("left_a", "right_a"),
    }
)


def amp_frame(position: np.ndarray) -> dict[str, np.ndarray]:
    """Positions only: a window of K frames shows the velocities too."""
    return {"root": position[:2].astype(np.float32), "shoulder": position[2:].astype(np.float32)}


class ToyAmpEnv(gym.Env):
    def __init__(self, history: int = 4, episode_steps: int = 60):
        self.history, self.episode_steps = history, episode_steps
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (8,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)

    def _observation(self) -> np.ndarray:
        return np.concatenate([self.position, self.velocity]).astype(np.float32)

    def _info(self) -> dict:
        return {"amp": {key: np.stack([f[key] for f in self.frames]) for key in LAYOUT.keys}}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.position = self.np_random.uniform(-0.2, 0.2, 4)
        self.velocity = np.zeros(4)
        self.steps = 0
        self.frames = [amp_frame(self.position)] * self.history
        return self._observation(), self._info()

    def step(self, action):
        action = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        self.velocity = SPEED * action
        self.position = np.clip(self.position + self.velocity / CONTROL_RATE, -1.5, 1.5)
        self.steps += 1
        self.frames = [*self.frames[1:], amp_frame(self.position)]
        return self._observation(), 0.0, False, self.steps >= self.episode_steps, self._info()


gym.register(ENV_ID, entry_point=ToyAmpEnv)


def demonstrations(history: int = 4, frames: int = 120) -> Demonstrations:
    """The reference: every coordinate swaying around its target."""
    t = np.arange(frames) / CONTROL_RATE
    phase = np.array([0.0, 1.0, 2.0, 3.0])
    position = TARGET + SWAY * np.sin(2.0 * np.pi * 0.5 * t[:, None] + phase)
    velocity = np.gradient(position, 1.0 / CONTROL_RATE, axis=0)
    amp = {key: np.stack([amp_frame(p)[key] for p in position]) for key in LAYOUT.keys}
    observations = np.concatenate([position, velocity], axis=1).astype(np.float32)
    actions = np.clip(velocity / SPEED, -1.0, 1.0).astype(np.float32)
    return Demonstrations(
        layout=LAYOUT,
        motions={"sway": MotionData(amp, observations, actions, position.astype(np.float32))},
        joint_names=["x", "y", "left_a", "right_a"],
        part_joints={"hip": [0, 1], "shoulder": [2, 3]},
        history=history,
        control_rate=CONTROL_RATE,
    )


def vector_env(num_envs: int = 4, history: int = 4) -> gym.vector.VectorEnv:
    """In-process copies with the trainer's contract (same-step autoreset)."""
    return gym.vector.SyncVectorEnv(
        [lambda: ToyAmpEnv(history) for _ in range(num_envs)],
        autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
    )


TASK_ENV_ID = "tests/ToyTask-v0"
TOUCH = 0.1  # the "hand" touches the "object" this close


class ToyTaskEnv(ToyAmpEnv):
    """The toy with a task: bring the first two coordinates to a goal drawn
    per episode. The observation appends the goal relative to them (2);
    `info["interaction"]` is s_I = (goal - position[:2], touching); the task
    reward is exp(-4 |goal - position[:2]|^2); success is holding within
    `TOUCH` of the goal for 10 steps."""

    def __init__(self, history: int = 4, episode_steps: int = 60):
        super().__init__(history, episode_steps)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (10,), np.float32)

    def _observation(self) -> np.ndarray:
        return np.concatenate([super()._observation(), self.goal - self.position[:2]]).astype(np.float32)

    def _info(self) -> dict:
        offset = self.goal - self.position[:2]
        touching = float(np.linalg.norm(offset) < TOUCH)
        info = super()._info()
        info["interaction"] = np.concatenate([offset, [touching]]).astype(np.float32)
        info["success"] = self.held >= 10
        return info

    def reset(self, *, seed=None, options=None):
        gym.Env.reset(self, seed=seed)
        self.goal = self.np_random.uniform(-1.0, 1.0, 2)
        self.held = 0
        return super().reset(options=options)

    def step(self, action):
        observation, _, terminated, truncated, _ = super().step(action)
        offset = self.goal - self.position[:2]
        self.held = self.held + 1 if np.linalg.norm(offset) < TOUCH else 0
        reward = float(np.exp(-4.0 * offset @ offset))
        return self._observation(), reward, terminated, truncated, self._info()


gym.register(TASK_ENV_ID, entry_point=ToyTaskEnv)


def task_vector_env(num_envs: int = 4, history: int = 4) -> gym.vector.VectorEnv:
    return gym.vector.SyncVectorEnv(
        [lambda: ToyTaskEnv(history) for _ in range(num_envs)],
        autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
    )


def interaction_demonstrations(count: int = 20, frames: int = 40, seed: int = 0) -> list[np.ndarray]:
    """s_I sequences of reaching a goal straight at full speed and holding it."""
    rng = np.random.default_rng(seed)
    sequences = []
    for _ in range(count):
        offset = rng.uniform(-1.0, 1.0, 2)
        rows = []
        for _ in range(frames):
            rows.append([*offset, float(np.linalg.norm(offset) < TOUCH)])
            step = min(np.linalg.norm(offset), SPEED / CONTROL_RATE)
            offset = offset - step * offset / max(np.linalg.norm(offset), 1e-9)
        sequences.append(np.array(rows, dtype=np.float32))
    return sequences


TEACHER_GAIN = 4.0  # the toy teacher's action per unit of distance to the target


class ToyTeacherEnv(ToyAmpEnv):
    """The toy with a teacher, as `Imitation-v0` with `teacher=True` has
    one: `info["teacher_action"]` drives every coordinate to its target
    (a proportional law, saturating at the action's bounds), and the info
    says where the "root" (the first two coordinates) is and where the
    reference's is (the target, reached in `REFERENCE_SECONDS`). The
    reward tracks that reference, as `tracking_reward` does in
    `Imitation-v0`: exp(-4 |reference - position|^2) over all four."""

    REFERENCE_SECONDS = 1.0

    def _reference(self) -> np.ndarray:
        share = min(self.steps / CONTROL_RATE / self.REFERENCE_SECONDS, 1.0)
        return (1.0 - share) * self.start + share * TARGET

    def _info(self) -> dict:
        info = super()._info()
        info["time"] = self.steps / CONTROL_RATE
        info["teacher_action"] = np.clip(TEACHER_GAIN * (TARGET - self.position), -1.0, 1.0).astype(np.float32)
        info["root_xy"] = self.position[:2].copy()
        info["reference_root_xy"] = self._reference()[:2]
        return info

    def step(self, action):
        observation, _, terminated, truncated, info = super().step(action)
        offset = self._reference() - self.position
        return observation, float(np.exp(-4.0 * offset @ offset)), terminated, truncated, info

    start = np.zeros(4)

    def reset(self, *, seed=None, options=None):
        observation, _ = super().reset(seed=seed, options=options)
        self.start = self.position.copy()
        return observation, self._info()


def teacher_vector_env(num_envs: int = 4) -> gym.vector.VectorEnv:
    return gym.vector.SyncVectorEnv(
        [lambda: ToyTeacherEnv() for _ in range(num_envs)],
        autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
    )
