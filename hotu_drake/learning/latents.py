"""Latents: one per part group on the unit sphere, each resampled on its own timer.

Every group of every environment draws its latent independently, and
draws it again after a number of control steps drawn from U[low, high)
(and when its episode ends). The Rofunc HOTU trainer copies one latent to
every part on one timer; independent draws are what lets the parts'
behaviours combine.
"""

from __future__ import annotations

import numpy as np


def sample_sphere(rng: np.random.Generator, count: int, size: int) -> np.ndarray:
    """`count` points uniform on the unit sphere in `size` dimensions."""
    points = rng.standard_normal((count, size))
    norms = np.linalg.norm(points, axis=-1, keepdims=True)
    return (points / np.maximum(norms, 1e-12)).astype(np.float32)


class LatentSchedule:
    """The latents of `num_envs` environments, part group by part group."""

    def __init__(self, groups: list[str], size: int, num_envs: int, low: int, high: int, rng: np.random.Generator):
        self.groups, self.size, self.num_envs = list(groups), size, num_envs
        self.low, self.high, self.rng = low, high, rng
        self.latents = {g: sample_sphere(rng, num_envs, size) for g in self.groups}
        self.countdown = {g: rng.integers(low, high, num_envs) for g in self.groups}

    def step(self, ended: np.ndarray | None = None) -> None:
        """Advance one control step; resample where a timer ran out or an episode `ended`."""
        for g in self.groups:
            self.countdown[g] -= 1
            due = self.countdown[g] <= 0
            if ended is not None:
                due |= ended
            count = int(due.sum())
            if count:
                self.latents[g][due] = sample_sphere(self.rng, count, self.size)
                self.countdown[g][due] = self.rng.integers(self.low, self.high, count)

    def current(self) -> dict[str, np.ndarray]:
        return {g: z.copy() for g, z in self.latents.items()}

    def state_dict(self) -> dict:
        return {"latents": self.current(), "countdown": {g: c.copy() for g, c in self.countdown.items()}}

    def load_state_dict(self, state: dict) -> None:
        """The saved latents and timers; fresh ones if the run resumes with another number of environments."""
        saved = {g: np.asarray(state["latents"][g], dtype=np.float32) for g in self.groups}
        if any(len(z) != self.num_envs for z in saved.values()):
            return
        self.latents = saved
        self.countdown = {g: np.asarray(state["countdown"][g]) for g in self.groups}
