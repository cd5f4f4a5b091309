"""An environment's episode as a `MotionClip`, the one clip format.

What a policy did in simulation becomes a demonstration like any other: it
can be replayed, retargeted to another robot (with its object tracks) and
tracked. This is the first step of moving a skill from the UDH to a robot:
run the UDH's skill, record it, retarget the recording.

The recorder reads the plant's state at the control rate: joint positions
and velocities, the root's pose and its world-frame velocities, the key
bodies, the pose of every free task object (box, drill) and whether each
foot touches anything (the plant's point contacts).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hotu_drake.embodiment.spec import FOOT_ROLES
from hotu_drake.envs.base import DiagramEnv
from hotu_drake.motion.clip import MotionClip
from hotu_drake.objects import object_body
from hotu_drake.plant import actuated_state_indices


class EpisodeRecorder:
    """Frames of a `DiagramEnv`'s state, one per `capture()`, as a clip."""

    def __init__(self, env: DiagramEnv):
        self._env = env
        sim, emb = env.sim, env.embodiment
        plant, model = sim.plant, sim.model
        self._q, self._v = actuated_state_indices(plant, model, emb.joint_names)
        self._root = plant.GetBodyByName(emb.spec.root.name, model)
        self._key_names = list(dict.fromkeys(emb.key_bodies.values()))  # body names, as retargeted clips have
        self._key_bodies = [plant.GetBodyByName(name, model) for name in self._key_names]
        self._objects = [o for o in sim.scenario.objects if o.is_task_object]
        self._object_bodies = [object_body(plant, sim.objects, o) for o in self._objects]
        feet = [r for r in FOOT_ROLES if r in emb.key_bodies]
        self._feet = {r: plant.GetBodyByName(emb.key_bodies[r], model).index() for r in feet}
        self._frames: list[dict] = []

    def capture(self) -> None:
        """Add the environment's current state as the next frame."""
        plant, context = self._env.sim.plant, self._env._plant_context
        state = plant.GetPositionsAndVelocities(context, self._env.sim.model)
        root = plant.EvalBodyPoseInWorld(context, self._root)
        twist = plant.EvalBodySpatialVelocityInWorld(context, self._root)
        touching = self._touching_bodies(context)
        self._frames.append(
            {
                "q": state[self._q],
                "v": state[self._v],
                "root_position": root.translation(),
                "root_quaternion": root.rotation().ToQuaternion().wxyz(),
                "root_linear_velocity": twist.translational(),
                "root_angular_velocity": twist.rotational(),
                "key_bodies": [plant.EvalBodyPoseInWorld(context, b).translation() for b in self._key_bodies],
                "objects": [_pose7(plant.EvalBodyPoseInWorld(context, b)) for b in self._object_bodies],
                "contacts": [index in touching for index in self._feet.values()],
            }
        )

    def _touching_bodies(self, context) -> set:
        results = self._env.sim.plant.get_contact_results_output_port().Eval(context)
        touching = set()
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            touching.update((info.bodyA_index(), info.bodyB_index()))
        return touching

    def clip(self, source: str) -> MotionClip:
        """The captured frames as a clip of the environment's embodiment at its control rate."""
        if len(self._frames) < 2:
            raise ValueError(f"{source}: a clip needs two or more frames, {len(self._frames)} captured")
        frames, emb = self._frames, self._env.embodiment

        def stack(key: str) -> np.ndarray:
            return np.array([f[key] for f in frames], dtype=float)

        return MotionClip(
            embodiment=emb.name,
            source=source,
            fps=float(self._env.sim.scenario.control_rate),
            joint_names=list(emb.joint_names),
            joint_positions=stack("q"),
            joint_velocities=stack("v"),
            root_position=stack("root_position"),
            root_quaternion=stack("root_quaternion"),
            root_linear_velocity=stack("root_linear_velocity"),
            root_angular_velocity=stack("root_angular_velocity"),
            key_body_names=list(self._key_names),
            key_body_positions=stack("key_bodies"),
            part_index={part: list(names) for part, names in emb.parts.items()},
            object_names=[o.instance_name for o in self._objects],
            object_poses=stack("objects") if self._objects else None,
            contact_names=list(self._feet),
            contacts=np.array([f["contacts"] for f in frames], dtype=bool),
        )


def _pose7(pose) -> np.ndarray:
    """[x, y, z, qw, qx, qy, qz], the clip's object pose."""
    return np.concatenate([pose.translation(), pose.rotation().ToQuaternion().wxyz()])


def record_episode(
    env: DiagramEnv,
    act: Callable[[np.ndarray, dict], np.ndarray],
    seed: int,
    max_steps: int,
    source: str = "rollout",
    options: dict | None = None,
) -> MotionClip:
    """Reset `env` with `seed` (and its reset `options`), run `act(observation, info)` until the episode
    ends or `max_steps` control steps, and return the frames (the start
    and every step's result) as a clip."""
    recorder = EpisodeRecorder(env)
    observation, info = env.reset(seed=seed, options=options)
    recorder.capture()
    for _ in range(max_steps):
        observation, _, terminated, truncated, info = env.step(act(observation, info))
        recorder.capture()
        if terminated or truncated:
            break
    return recorder.clip(source)
