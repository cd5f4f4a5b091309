"""Local rollout workers: environments in worker processes, batches through shared memory.

`SharedMemoryVectorEnv` is a gymnasium `VectorEnv` whose environments each
run in a process of their own. Observations, actions, rewards, the
per-part AMP histories (`info["amp"]`) and, for episodes that end, their
last observation and AMP history go through shared memory; only the small
rest of each `info` is pickled. So the main process does little per step,
which is what lets two workers on two cores approach twice one.

The contract is gymnasium's `AsyncVectorEnv` with same-step autoreset: an
episode resets in the step it ends, its last observation and info are in
`info["final_obs"]` and `info["final_info"]` (with `_final_obs` marking the
environments that ended), and `reset(seed=s)` seeds environment i with
s + i. Any environment works whose `info["amp"]` maps parts to (K, d)
arrays of fixed shape (or that has no `info["amp"]`).
"""

import multiprocessing
import os
import traceback
from multiprocessing import shared_memory
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space


def reset_request(
    num_envs: int, seed: int | list[int | None] | None, options: dict | None
) -> tuple[np.ndarray, list[int | None], dict | None]:
    """A vector reset's `seed` and `options` read as gymnasium's vector envs do:
    the indices to reset (`options["reset_mask"]`, default all), a seed per
    environment (an int seeds environment i with seed + i), and the options
    left for the environments themselves (None if none)."""
    options = dict(options or {})
    mask = np.asarray(options.pop("reset_mask", np.ones(num_envs, bool)), dtype=bool)
    seeds = [None] * num_envs if seed is None else seed
    if isinstance(seeds, int):
        seeds = [seeds + i for i in range(num_envs)]
    return np.flatnonzero(mask), list(seeds), options or None


class _Buffers:
    """Named shared arrays, created by the main process and attached by the workers."""

    def __init__(self, shapes: dict[str, tuple[tuple[int, ...], str]], names: dict[str, str] | None = None):
        self.blocks, self.arrays = {}, {}
        for key, (shape, dtype) in shapes.items():
            size = max(int(np.prod(shape)) * np.dtype(dtype).itemsize, 1)
            if names is None:
                block = shared_memory.SharedMemory(create=True, size=size)
            else:  # attached: the creating process unlinks it
                block = shared_memory.SharedMemory(name=names[key])
            self.blocks[key] = block
            self.arrays[key] = np.ndarray(shape, dtype=dtype, buffer=block.buf)
        self.shapes = shapes

    @property
    def names(self) -> dict[str, str]:
        return {key: block.name for key, block in self.blocks.items()}

    def close(self, unlink: bool = False) -> None:
        self.arrays = {}
        for block in self.blocks.values():
            block.close()
            if unlink:
                block.unlink()


def _amp_frames(info: dict, parts: list[str]) -> np.ndarray | None:
    amp = info.get("amp")
    if not parts or amp is None:
        return None
    return np.concatenate([np.asarray(amp[p], dtype=np.float32) for p in parts], axis=-1)


def _worker(spec, index: int, pipe) -> None:
    """One environment: answer the main process's commands until `close`."""
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    if len(cores) > 1:  # one core per worker: the scheduler would otherwise let workers share one
        os.sched_setaffinity(0, {cores[index % len(cores)]})
    try:
        env = spec.make()
        observation, info = env.reset()
        amp = info.get("amp") or {}
        parts = list(amp)
        amp_shape = (np.shape(amp[parts[0]])[0], sum(np.shape(amp[p])[1] for p in parts)) if parts else (0, 0)
        sizes = [np.shape(amp[p])[1] for p in parts]
        pipe.send(("ready", env.observation_space, env.action_space, parts, sizes, amp_shape))
        kind, shapes, names = pipe.recv()
        buffers = _Buffers(shapes, names)
        a = buffers.arrays

        def publish(obs, info_, to: str = "") -> dict:
            a[f"{to}observations"][index] = obs
            frames = _amp_frames(info_, parts)
            if frames is not None:
                a[f"{to}amp"][index] = frames
            return {k: v for k, v in info_.items() if k != "amp"}

        while True:
            command, argument = pipe.recv()
            if command == "step":
                obs, reward, terminated, truncated, info = env.step(a["actions"][index])
                a["scalars"][index] = (reward, terminated, truncated)
                final = None
                if terminated or truncated:
                    final = publish(obs, info, "final_")
                    obs, info = env.reset()
                pipe.send(("ok", publish(obs, info), final))
            elif command == "reset":
                seed, options = argument
                obs, info = env.reset(seed=seed, options=options)
                pipe.send(("ok", publish(obs, info), None))
            elif command == "close":
                env.close()
                buffers.close()
                pipe.send(("ok", None, None))
                return
    except Exception as error:  # noqa: BLE001 (sent to the main process, which raises it)
        try:
            pipe.send(("error", error, traceback.format_exc()))
        except Exception:  # noqa: BLE001 (an unpicklable error: its text then)
            pipe.send(("error", RuntimeError(repr(error)), traceback.format_exc()))


class SharedMemoryVectorEnv(VectorEnv):
    """`num_envs` copies of `spec`'s environment, each in its own process."""

    def __init__(self, spec, num_envs: int, context: str = "spawn"):
        ctx = multiprocessing.get_context(context)
        self.num_envs = num_envs
        self.metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}
        self._pipes, self._processes, self._buffers = [], [], None
        for i in range(num_envs):
            mine, theirs = ctx.Pipe()
            process = ctx.Process(target=_worker, args=(spec, i, theirs), daemon=True)
            process.start()
            theirs.close()
            self._pipes.append(mine)
            self._processes.append(process)
        first, *_ = self._receive_all()
        _, obs_space, action_space, self._parts, sizes, amp_shape = first
        self.single_observation_space, self.single_action_space = obs_space, action_space
        self.observation_space = batch_space(obs_space, num_envs)
        self.action_space = batch_space(action_space, num_envs)
        edges = np.cumsum([0, *sizes])
        self._slices = {p: slice(int(a), int(b)) for p, a, b in zip(self._parts, edges[:-1], edges[1:])}
        obs_shape, action_shape = (num_envs, *obs_space.shape), (num_envs, *action_space.shape)
        shapes = {
            "observations": (obs_shape, obs_space.dtype.str),
            "final_observations": (obs_shape, obs_space.dtype.str),
            "actions": (action_shape, action_space.dtype.str),
            "scalars": ((num_envs, 3), "<f8"),
            "amp": ((num_envs, *amp_shape), "<f4"),
            "final_amp": ((num_envs, *amp_shape), "<f4"),
        }
        self._buffers = _Buffers(shapes)
        for pipe in self._pipes:
            pipe.send(("buffers", shapes, self._buffers.names))

    def _receive_all(self) -> list:
        """Every worker's answer, in worker order. Waiting on each pipe in turn
        measured faster than taking answers as they come (`connection.wait`),
        whose early wake-ups take a core from a worker still stepping."""
        return [self._receive(i) for i in range(len(self._pipes))]

    def _receive(self, index: int):
        answer = self._pipes[index].recv()
        if answer[0] == "error":
            self.close()
            raise answer[1]
        return answer

    def _amp(self, key: str, rows=slice(None)) -> dict:
        frames = self._buffers.arrays[key][rows].copy()
        return {part: frames[..., s] for part, s in self._slices.items()}

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every environment, or with `options={"reset_mask": mask}` those
        where `mask` is true (the others keep their episodes and observations)."""
        chosen, seeds, options = reset_request(self.num_envs, seed, options)
        for i in chosen:
            self._pipes[i].send(("reset", (seeds[i], options)))
        infos: dict[str, Any] = {}
        for i in chosen:
            _, info, _ = self._receive(i)
            infos = self._add_info(infos, info, i)
        if self._parts:
            infos["amp"] = self._amp("amp")
        return self._buffers.arrays["observations"].copy(), infos

    def step(self, actions):
        self._buffers.arrays["actions"][:] = actions
        for pipe in self._pipes:
            pipe.send(("step", None))
        infos: dict[str, Any] = {}
        ended = []
        for i, (_, info, final) in enumerate(self._receive_all()):
            infos = self._add_info(infos, info, i)
            if final is not None:
                ended.append(i)
                infos = self._add_info(infos, {"final_info": final}, i)
        arrays = self._buffers.arrays
        if self._parts:
            infos["amp"] = self._amp("amp")
        if ended:
            mask = np.zeros(self.num_envs, dtype=bool)
            mask[ended] = True
            final_obs = np.empty(self.num_envs, dtype=object)
            for i in ended:
                final_obs[i] = arrays["final_observations"][i].copy()
            infos["final_obs"], infos["_final_obs"] = final_obs, mask
            if self._parts:
                infos.setdefault("final_info", {})["amp"] = self._amp("final_amp")
        scalars = arrays["scalars"].copy()
        return (
            arrays["observations"].copy(),
            scalars[:, 0],
            scalars[:, 1].astype(bool),
            scalars[:, 2].astype(bool),
            infos,
        )

    def close_extras(self, **kwargs) -> None:
        for pipe, process in zip(self._pipes, self._processes):
            if process.is_alive():
                try:
                    pipe.send(("close", None))
                    pipe.recv()
                except (BrokenPipeError, EOFError, OSError):
                    pass
            process.join(timeout=10)
            if process.is_alive():
                process.kill()
        self._pipes, self._processes = [], []
        if self._buffers is not None:
            self._buffers.close(unlink=True)
            self._buffers = None
