"""Buffers of the trainer: what a rollout returns, and the discriminators'
replay of past policy windows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Rollout:
    """One iteration's samples, shaped (T, N, ...)."""

    observations: np.ndarray
    latents: dict[str, np.ndarray]  # group -> (T, N, z): the latent each step was taken with
    actions: np.ndarray
    log_probs: np.ndarray
    values: np.ndarray  # the critic's values (reward units)
    next_values: np.ndarray  # the value of the state after each step (reward units)
    terminated: np.ndarray
    ended: np.ndarray  # terminated or truncated
    windows: dict[str, np.ndarray]  # group -> (T, N, K, d): the AMP window after each step
    style_terminated: np.ndarray  # ended by the style-reward rule
    task: np.ndarray | None = None  # (T, N) the environment's own reward (a task's r_g)

    @property
    def num_samples(self) -> int:
        return self.actions.shape[0] * self.actions.shape[1]


class ReplayBuffer:
    """Up to `capacity` windows (K, d); new ones overwrite the oldest."""

    def __init__(self, capacity: int, shape: tuple[int, ...]):
        self.capacity = capacity
        self.data = np.zeros((capacity, *shape), dtype=np.float32)
        self.size = 0
        self.next = 0

    def add(self, windows: np.ndarray) -> None:
        windows = windows[-self.capacity :]
        n = len(windows)
        index = (self.next + np.arange(n)) % self.capacity
        self.data[index] = windows
        self.next = int((self.next + n) % self.capacity)
        self.size = min(self.size + n, self.capacity)

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:
        return self.data[rng.integers(0, self.size, count)]

    def state_dict(self) -> dict:
        return {"data": self.data[: self.size].copy(), "next": self.next, "size": self.size}

    def load_state_dict(self, state: dict) -> None:
        size = int(state["size"])
        self.data[:size] = np.asarray(state["data"])[:size]
        self.size, self.next = size, int(state["next"])
