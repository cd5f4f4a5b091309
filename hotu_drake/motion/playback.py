"""Playing a `MotionClip` as a function of time.

Positions are interpolated linearly between frames (the root orientation by
normalised linear interpolation of quaternions); the clip loops or holds
its last frame. `systems.reference.ReferenceMotionSource` serves this as a
Drake signal; the plant helpers set a robot's state from it.
"""

from __future__ import annotations

import numpy as np

from hotu_drake.motion.clip import MotionClip


class ClipPlayback:
    """`clip` played from clip time `start_time` at time 0, looping or holding its last frame."""

    def __init__(self, clip: MotionClip, loop: bool = True, start_time: float = 0.0):
        self.clip, self.loop, self.start_time = clip, loop, start_time

    def frame_at(self, time: float) -> tuple[int, int, float]:
        """The two frames around `time` and the weight of the second."""
        clip = self.clip
        position = (time + self.start_time) * clip.fps
        last = clip.num_frames - 1
        if self.loop and last > 0:
            position %= last
        position = min(max(position, 0.0), last)
        first = int(np.floor(position))
        second = min(first + 1, last)
        return first, second, position - first

    def lerp(self, values: np.ndarray, time: float) -> np.ndarray:
        """`values` (one row per frame) at `time`."""
        a, b, w = self.frame_at(time)
        return (1.0 - w) * values[a] + w * values[b]

    def joints_at(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities at `time` (the clip's joint order)."""
        return self.lerp(self.clip.joint_positions, time), self.lerp(self.clip.joint_velocities, time)

    def root_pose_at(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Root quaternion (w x y z) and position (world) at `time`."""
        clip = self.clip
        a, b, w = self.frame_at(time)
        qa, qb = clip.root_quaternion[a], clip.root_quaternion[b]
        quaternion = (1.0 - w) * qa + w * (qb if np.dot(qa, qb) >= 0 else -qb)
        quaternion /= np.linalg.norm(quaternion)
        return quaternion, (1.0 - w) * clip.root_position[a] + w * clip.root_position[b]

    def root_at(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Root quaternion (w x y z), position, angular and linear velocity (world) at `time`."""
        quaternion, position = self.root_pose_at(time)
        omega = self.lerp(self.clip.root_angular_velocity, time)
        linear = self.lerp(self.clip.root_linear_velocity, time)
        return quaternion, position, omega, linear

    def key_bodies_at(self, time: float) -> np.ndarray:
        """Key-body positions (k, 3) at `time`."""
        return self.lerp(self.clip.key_body_positions, time)
