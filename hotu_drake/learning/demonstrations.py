"""Demonstrations as arrays: what the discriminators, the warm start and the
evaluation know of the reference clips.

The Drake side (`hotu_drake.envs.runs`) plays each reference
clip through the environment's observation system once, at the control
rate, and hands the learner, per motion:

- `amp`: the AMP frames, key by key (T, d_key), laid out as `info["amp"]`;
- `observations`: the policy observation at each frame (T, obs);
- `actions`: the action whose PD targets are the next frame's joint
  positions (T, actions), for the warm start;
- `joints`: the joint positions (T, joints), for the evaluation.

A discriminator's demonstration sample is a window of the last K frames of
one group's features ending at a frame drawn uniformly over the group's
motions (frames before a clip's start repeat its first, as at a reference
start). Saved as one `.npz` (arrays) with its metadata as JSON inside.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hotu_drake.errors import InputError
from hotu_drake.io import atomic_output
from hotu_drake.learning.parts import AmpLayout, PartGroup

FORMAT_VERSION = 1


@dataclass
class MotionData:
    """One reference clip at the control rate (see the module docstring)."""

    amp: dict[str, np.ndarray]
    observations: np.ndarray
    actions: np.ndarray
    joints: np.ndarray

    @property
    def num_frames(self) -> int:
        return len(self.joints)


@dataclass
class Demonstrations:
    """The reference clips of a run, as arrays, with how to read them."""

    layout: AmpLayout
    motions: dict[str, MotionData]
    joint_names: list[str]
    part_joints: dict[str, list[int]]  # Table I part -> indices into joint_names
    history: int  # K, frames per AMP window
    control_rate: float
    meta: dict = field(default_factory=dict)

    def check_motions(self, names: list[str], where: str = "demonstrations") -> None:
        unknown = [n for n in names if n not in self.motions]
        if unknown:
            raise InputError(f"no demonstration of {', '.join(unknown)} (have: {', '.join(self.motions)})", where)

    def window_indices(self, motion: str) -> np.ndarray:
        """(T, K) frame indices of the window ending at each frame of `motion`."""
        n = self.motions[motion].num_frames
        ends = np.arange(n)[:, None]
        return np.clip(ends - np.arange(self.history - 1, -1, -1)[None, :], 0, n - 1)

    def moving_windows(self, motion: str, still_speed: float) -> np.ndarray:
        """Which windows of `motion` show some of its motion: False for the
        windows that lie wholly in the still pose a clip holds before it
        starts or after it ends (every joint slower than `still_speed`,
        rad/s); all True when `still_speed` is 0."""
        index = self.window_indices(motion)
        if still_speed <= 0:
            return np.ones(len(index), bool)
        joints = self.motions[motion].joints
        speed = np.abs(np.diff(joints, axis=0)).max(1) * self.control_rate  # between frames t and t + 1
        moving = np.flatnonzero(speed >= still_speed)
        if len(moving) == 0:
            return np.ones(len(index), bool)  # a clip that is all pose: keep it
        first, last = moving[0] + 1, moving[-1]  # the first frame to differ from the one before, the last from the next
        return (index.max(1) >= first) & (index.min(1) <= last)

    def windows(self, group: PartGroup, motions: list[str] | None = None, still_speed: float = 0.0) -> np.ndarray:
        """Every window (N, K, d_group) of `group` over `motions` (default
        all), without the still ends' windows if `still_speed` > 0."""
        chosen = motions or list(self.motions)
        out = []
        for name in chosen:
            frames = group.gather(self.motions[name].amp)
            out.append(frames[self.window_indices(name)[self.moving_windows(name, still_speed)]])
        return np.concatenate(out).astype(np.float32)

    def sample_windows(
        self,
        group: PartGroup,
        count: int,
        rng: np.random.Generator,
        motions: list[str] | None = None,
        still_speed: float = 0.0,
    ) -> np.ndarray:
        """`count` windows of `group`, their end frames uniform over `motions`' frames."""
        windows = self._cached_windows(group, tuple(motions or self.motions), still_speed)
        return windows[rng.integers(0, len(windows), count)]

    def _cached_windows(self, group: PartGroup, motions: tuple[str, ...], still_speed: float) -> np.ndarray:
        cache = self.__dict__.setdefault("_window_cache", {})
        key = (group.name, motions, still_speed)
        if key not in cache:
            cache[key] = self.windows(group, list(motions), still_speed)
        return cache[key]

    def behavior_cloning_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """(observations, actions) of every frame but each clip's last."""
        observations = np.concatenate([m.observations[:-1] for m in self.motions.values()])
        actions = np.concatenate([m.actions[:-1] for m in self.motions.values()])
        return observations.astype(np.float32), actions.astype(np.float32)

    # -- files -------------------------------------------------------------------

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        arrays: dict[str, np.ndarray] = {}
        for i, motion in enumerate(self.motions.values()):
            for key, frames in motion.amp.items():
                arrays[f"m{i}/amp/{key}"] = frames
            arrays[f"m{i}/observations"] = motion.observations
            arrays[f"m{i}/actions"] = motion.actions
            arrays[f"m{i}/joints"] = motion.joints
        meta = {
            "format_version": FORMAT_VERSION,
            "motions": list(self.motions),
            "layout": self.layout.to_dict(),
            "joint_names": self.joint_names,
            "part_joints": self.part_joints,
            "history": self.history,
            "control_rate": self.control_rate,
            "meta": self.meta,
        }
        arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
        with atomic_output(path) as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, **arrays)
        return path

    @staticmethod
    def load(path: str | Path) -> Demonstrations:
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(bytes(data["meta"]).decode())
                if meta.get("format_version") != FORMAT_VERSION:
                    raise InputError(
                        f"demonstrations of format {meta.get('format_version')}, not {FORMAT_VERSION}", path
                    )
                layout = AmpLayout.from_dict(meta["layout"])
                motions = {}
                for i, name in enumerate(meta["motions"]):
                    motions[name] = MotionData(
                        amp={key: data[f"m{i}/amp/{key}"] for key in layout.keys},
                        observations=data[f"m{i}/observations"],
                        actions=data[f"m{i}/actions"],
                        joints=data[f"m{i}/joints"],
                    )
        except (OSError, ValueError, KeyError, json.JSONDecodeError) as error:
            if isinstance(error, InputError):
                raise
            raise InputError(f"not a demonstrations file ({type(error).__name__}: {error})", path) from None
        return Demonstrations(
            layout,
            motions,
            list(meta["joint_names"]),
            {k: list(v) for k, v in meta["part_joints"].items()},
            int(meta["history"]),
            float(meta["control_rate"]),
            meta.get("meta", {}),
        )
