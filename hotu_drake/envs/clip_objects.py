"""The objects of an environment's clips, in the scene with the robot.

A clip that handles an object (a grasp of the set, the box carry, the
drill grasp) carries its objects' tracks. With `clip_objects`, the
imitation environment's scene has one free instance of every object kind
its clips name (tables included); an episode on such a clip starts with
the clip's objects where the clip has them at the episode's start, taken
into the world as the robot's reference is (the episode's frame), and
every other object parked out of the way. A table stands where its clip
puts it, on its damped planar joint (`objects.SceneObject`: a table
cannot be welded for one episode and moved for the next). Locking the
bodies instead (`RigidBody.Lock`) crashed Drake 1.51's SAP solver in an
episode started with an object in the hand. An episode's objects are what
`rise` measures: how far its first non-table object is above where it
started (the held-object figure of a run's evaluation).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant

from hotu_drake.errors import InputError
from hotu_drake.motion.clip import MotionClip
from hotu_drake.objects import OBJECTS, SceneObject, object_kind, resting_height, set_object_pose

PARKED_AT = (-50.0, 0.0)  # m: where objects out of their episode wait, each a few metres from the last
PARKED_SPACING = 3.0


class ClipObjects:
    """One free instance of each object kind of `clips` (see the module).

    Build the scene with `scene_objects()`, then `bind` the built plant's
    model instances; `place` at each reset, `rise` at each step."""

    def __init__(self, clips: Sequence[MotionClip]):
        self.kinds: list[str] = []
        self._tracks: list[list[tuple[int, str]]] = []  # per clip: (track index, kind)
        for clip in clips:
            tracks = []
            for index, name in enumerate(clip.object_names or []):
                kind = object_kind(name)
                if kind is None:
                    raise InputError(
                        f"{clip.source}: object track {name!r} is of no known object ({', '.join(OBJECTS)})",
                        field="objects",
                    )
                if kind in (k for _, k in tracks):
                    raise InputError(f"{clip.source}: two tracks of one object kind ({kind})", field="objects")
                tracks.append((index, kind))
                if kind not in self.kinds:
                    self.kinds.append(kind)
            self._tracks.append(tracks)
        self._clips = list(clips)
        self._bodies: dict = {}
        self._episode: tuple | None = None  # (body, start height) of the episode's first non-table object

    def scene_objects(self) -> list[SceneObject]:
        """The scene's instances, free and parked (named by their kind)."""
        return [SceneObject(kind, kind, self._parked(i, kind), 0.0) for i, kind in enumerate(self.kinds)]

    def bind(self, plant: MultibodyPlant, instances: dict) -> None:
        """The built plant's bodies of `scene_objects` (`instances`: instance name -> model instance)."""
        self._bodies = {kind: plant.GetBodyByName(kind, instances[kind]) for kind in self.kinds}

    def place(self, plant: MultibodyPlant, context, clip_index: int | None, clip_time: float, frame) -> None:
        """An episode's start: the objects of clip `clip_index` where it has
        them at `clip_time` (its nearest frame), taken into the world by
        `frame` (the clip's world in the world), at rest; every other
        object parked, resting on the floor."""
        placed = {kind: index for index, kind in self._tracks[clip_index]} if clip_index is not None else {}
        self._episode = None
        for i, kind in enumerate(self.kinds):
            body = self._bodies[kind]
            if kind not in placed:
                set_object_pose(plant, context, body, RigidTransform(self._parked(i, kind)))
                continue
            clip = self._clips[clip_index]
            row = min(int(round(clip_time * clip.fps)), clip.num_frames - 1)
            pose = np.asarray(clip.object_poses[row, placed[kind]], dtype=float)
            in_clip = RigidTransform(Quaternion(pose[3:] / np.linalg.norm(pose[3:])), pose[:3])
            if kind == "table":  # its track is its top's centre; the model stands on the floor
                yaw = float(2.0 * np.arctan2(pose[6], pose[3]))
                in_clip = RigidTransform(RotationMatrix.MakeZRotation(yaw), [pose[0], pose[1], 0.0])
            world = frame @ in_clip
            set_object_pose(plant, context, body, world)
            if kind != "table" and self._episode is None:
                self._episode = (body, float(world.translation()[2]))

    def rise(self, plant: MultibodyPlant, context) -> float:
        """How far (m) the episode's first non-table object is above where it started; NaN without one."""
        if self._episode is None:
            return float("nan")
        body, start = self._episode
        return float(plant.EvalBodyPoseInWorld(context, body).translation()[2] - start)

    def _parked(self, index: int, kind: str) -> list[float]:
        return [PARKED_AT[0], PARKED_AT[1] + PARKED_SPACING * index, resting_height(kind)]
