"""Buffers of the trainers: the episodes as they end, the discriminators'
replay of past policy windows, and state dicts as tensors."""

from __future__ import annotations

from collections import deque

import numpy as np
import torch


class EpisodeLog:
    """The episodes of a vector environment as they end: each environment's
    steps so far, and the lengths and successes (where the environment
    tells `info["final_info"]["success"]`) of the last `keep` episodes."""

    def __init__(self, num_envs: int, keep: int = 200):
        self.steps = np.zeros(num_envs, dtype=np.int64)
        self.lengths: deque = deque(maxlen=keep)
        self.successes: deque = deque(maxlen=keep)

    def restart(self) -> None:
        """Every environment starts a new episode (after a reset)."""
        self.steps[:] = 0

    def step(self, ended: np.ndarray, info: dict) -> int:
        """One step of every environment; `ended` marks those whose episode
        ended in it. Returns how many of those succeeded."""
        self.steps += 1
        success = info.get("final_info", {}).get("success")
        succeeded = 0
        for i in np.flatnonzero(ended):
            self.lengths.append(int(self.steps[i]))
            if success is not None:  # a task's episodes
                self.successes.append(bool(np.asarray(success)[i]))
                succeeded += int(self.successes[-1])
        self.steps[ended] = 0
        return succeeded

    def stats(self) -> dict[str, float]:
        """`episode_length` (mean of the kept ones) and, for a task, `success_rate`."""
        out = {"episode_length": float(np.mean(self.lengths)) if self.lengths else float("nan")}
        if self.successes:
            out["success_rate"] = float(np.mean(self.successes))
        return out

    def state_dict(self) -> dict:
        return {"episode_lengths": list(self.lengths), "episode_successes": list(self.successes)}

    def load_state_dict(self, state: dict) -> None:
        self.lengths = deque(state["episode_lengths"], maxlen=self.lengths.maxlen)
        self.successes = deque(state.get("episode_successes", []), maxlen=self.successes.maxlen)


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

    def mix(self, fresh: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A discriminator's policy batch as long as `fresh`: the first half of
        `fresh`, the rest drawn from the buffer (all `fresh` while it is empty)."""
        if self.size == 0:
            return fresh
        half = len(fresh) // 2
        return np.concatenate([fresh[:half], self.sample(len(fresh) - half, rng)])

    def keep(self, samples: np.ndarray, share: float, rng: np.random.Generator) -> None:
        """Add a random `share` of `samples`."""
        self.add(samples[rng.random(len(samples)) < share])

    def state_dict(self) -> dict:
        return {"data": self.data[: self.size].copy(), "next": self.next, "size": self.size}

    def load_state_dict(self, state: dict) -> None:
        size = int(state["size"])
        self.data[:size] = np.asarray(state["data"])[:size]
        self.size, self.next = size, int(state["next"])


def to_tensors(tree: dict) -> dict:
    """A nested dict with its arrays as tensors (what `torch.load(weights_only=True)` reads back)."""
    return {k: to_tensors(v) if isinstance(v, dict) else _tensor(v) for k, v in tree.items()}


def to_arrays(tree: dict) -> dict:
    """`to_tensors` undone."""
    return {k: to_arrays(v) if isinstance(v, dict) else _array(v) for k, v in tree.items()}


def _tensor(value):
    return torch.as_tensor(value) if isinstance(value, np.ndarray) else value


def _array(value):
    return value.numpy() if isinstance(value, torch.Tensor) else value
