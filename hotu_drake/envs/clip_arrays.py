"""The learner's demonstrations, built from an environment's reference clips.

Each clip is played at the environment's control rate through its own
observation system (`DiagramEnv.clip_amp_frame`, `clip_observation`): the
AMP frames the discriminators compare against, the observations and PD
target actions of the warm start, and the joint positions the evaluation
measures against. The result is plain arrays
(`learning.demonstrations.Demonstrations`), cached on disk keyed by the
clips' contents, the environment's layout and the code that made them
(this module, the environment's and the observation system's).
"""

from __future__ import annotations

import hashlib
import json
import logging
import sys
from pathlib import Path

import numpy as np

from hotu_drake.embodiment.actions import ActionScaling
from hotu_drake.envs.base import DiagramEnv
from hotu_drake.errors import InputError
from hotu_drake.learning.demonstrations import Demonstrations, MotionData
from hotu_drake.learning.parts import AmpLayout
from hotu_drake.retarget.references import cache_dir

log = logging.getLogger("hotu_drake.envs")


def motion_names(env: DiagramEnv) -> list[str]:
    """A name per reference clip of `env` (the last part of its source, e.g.
    `wave` for the library's wave; repeated names numbered)."""
    names: list[str] = []
    for clip in env.clips:
        name = Path(clip.source).stem or "clip"
        while name in names:
            name = f"{name}_{len(names)}"
        names.append(name)
    return names


def build_demonstrations(env: DiagramEnv, use_cache: bool = True) -> Demonstrations:
    """The demonstrations of `env`'s reference clips (see the module docstring)."""
    if not env.clips:
        raise InputError("the environment has no reference clips to learn from", field="motions")
    key = _cache_key(env)
    path = cache_dir() / "demonstrations" / f"{env.embodiment.name}_{env.embodiment.hands}_{key}.npz"
    if use_cache and path.is_file():
        try:
            return Demonstrations.load(path)
        except InputError:
            log.warning("%s: damaged demonstrations cache; building it again", path)
    demos = _build(env)
    if use_cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        demos.save(path)
    return demos


def _build(env: DiagramEnv) -> Demonstrations:
    emb = env.embodiment
    scaling = ActionScaling.for_embodiment(emb)
    layout = AmpLayout.from_dict(env.amp_layout())
    period = env.control_period
    motions = {}
    for index, name in enumerate(motion_names(env)):
        times = env.clip_times(index)
        frames = np.array([env.clip_amp_frame(index, t) for t in times], dtype=np.float32)
        observations = np.array([env.clip_observation(index, t) for t in times], dtype=np.float32)
        joints = np.array([env._playbacks[index].joints_at(t)[0] for t in times])
        targets = np.vstack([joints[1:], joints[-1:]])  # the next frame's pose; the last holds
        actions = np.clip(scaling.to_action(targets), -1.0, 1.0).astype(np.float32)
        amp = {key: frames[:, env.part_slices[key]] for key in layout.keys}
        motions[name] = MotionData(amp, observations, actions, joints.astype(np.float32))
    names = emb.joint_names
    part_joints = {part: [names.index(j) for j in joints] for part, joints in emb.parts.items() if joints}
    meta = {"embodiment": emb.name, "hands": emb.hands, "joint_columns": env.joint_position_columns().tolist()}
    return Demonstrations(layout, motions, list(names), part_joints, env.amp_history, 1.0 / period, meta)


def _cache_key(env: DiagramEnv) -> str:
    from hotu_drake.retarget.references import _code_key

    digest = hashlib.sha256()
    digest.update(_code_key().encode())
    from hotu_drake.envs import base
    from hotu_drake.systems import motion_reference, observation

    task = sys.modules[type(env).__module__].__file__  # a task environment's own observation
    sources = (__file__, base.__file__, observation.__file__, motion_reference.__file__, task)
    for source in sources:  # the code that makes the arrays
        with open(source, "rb") as f:
            digest.update(f.read())
    description = {
        "layout": env.amp_layout(),
        "history": env.amp_history,
        "period": env.control_period,
        "phase": [env.phase_observation, list(env.loops)],
        "names": motion_names(env),
        "observation": int(env.observation_space.shape[0]),
    }
    digest.update(json.dumps(description, sort_keys=True).encode())
    for clip in env.clips:
        for array in (clip.joint_positions, clip.root_position, clip.root_quaternion):
            digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()[:16]
