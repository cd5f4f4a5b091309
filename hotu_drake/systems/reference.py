"""ReferenceMotionSource: plays a `MotionClip` as a time signal.

For tracking (PD targets from a retargeted clip), visualisation and
reference-state initialisation. Positions are interpolated linearly
between frames (the root orientation by normalised linear interpolation of
quaternions); the clip loops or holds its last frame.
"""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from hotu_drake.motion.clip import MotionClip


class ReferenceMotionSource(LeafSystem):
    """Output ports `joint_positions` (n), `joint_velocities` (n), `state`
    (the model's [q; v]: root quaternion w x y z and position, joints, then
    root angular and linear velocity and joint velocities, as a floating
    MultibodyPlant model orders them; joints only for a fixed base) and
    `key_body_positions` (3k)."""

    def __init__(self, clip: MotionClip, loop: bool = True, floating_base: bool = True, start_time: float = 0.0):
        super().__init__()
        self._clip, self._loop, self._floating = clip, loop, floating_base
        self._start = start_time  # clip time at simulation time 0
        n, k = len(clip.joint_names), len(clip.key_body_names)
        state_size = 2 * n + (13 if floating_base else 0)
        self.DeclareVectorOutputPort("joint_positions", n, self._CalcJointPositions)
        self.DeclareVectorOutputPort("joint_velocities", n, self._CalcJointVelocities)
        self.DeclareVectorOutputPort("state", state_size, self._CalcState)
        self.DeclareVectorOutputPort("key_body_positions", 3 * k, self._CalcKeyBodies)

    def frame_at(self, time: float) -> tuple[int, int, float]:
        """The two frames around `time` and the weight of the second."""
        clip = self._clip
        position = (time + self._start) * clip.fps
        last = clip.num_frames - 1
        if self._loop and last > 0:
            position %= last
        position = min(max(position, 0.0), last)
        first = int(np.floor(position))
        second = min(first + 1, last)
        return first, second, position - first

    def _lerp(self, values: np.ndarray, time: float) -> np.ndarray:
        a, b, w = self.frame_at(time)
        return (1.0 - w) * values[a] + w * values[b]

    def _CalcJointPositions(self, context, output: BasicVector) -> None:
        output.SetFromVector(self._lerp(self._clip.joint_positions, context.get_time()))

    def _CalcJointVelocities(self, context, output: BasicVector) -> None:
        output.SetFromVector(self._lerp(self._clip.joint_velocities, context.get_time()))

    def _CalcKeyBodies(self, context, output: BasicVector) -> None:
        output.SetFromVector(self._lerp(self._clip.key_body_positions, context.get_time()).ravel())

    def root_at(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Root quaternion (w x y z), position, angular and linear velocity (world) at `time`."""
        clip = self._clip
        a, b, w = self.frame_at(time)
        qa, qb = clip.root_quaternion[a], clip.root_quaternion[b]
        quaternion = (1.0 - w) * qa + w * (qb if np.dot(qa, qb) >= 0 else -qb)
        quaternion /= np.linalg.norm(quaternion)
        position = self._lerp(clip.root_position, time)
        omega = self._lerp(clip.root_angular_velocity, time)
        linear = self._lerp(clip.root_linear_velocity, time)
        return quaternion, position, omega, linear

    def joints_at(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities at `time` (the clip's joint order)."""
        return self._lerp(self._clip.joint_positions, time), self._lerp(self._clip.joint_velocities, time)

    def _CalcState(self, context, output: BasicVector) -> None:
        t = context.get_time()
        q, v = self.joints_at(t)
        if not self._floating:
            output.SetFromVector(np.concatenate([q, v]))
            return
        quaternion, root, omega, linear = self.root_at(t)
        output.SetFromVector(np.concatenate([quaternion, root, q, omega, linear, v]))
