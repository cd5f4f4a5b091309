"""ReferenceMotionSource: plays a `MotionClip` as a time signal.

For tracking (PD targets from a retargeted clip), visualisation and
reference-state initialisation. The interpolation (linear between frames,
normalised for the root quaternion; looping or holding the last frame) is
`motion.playback.ClipPlayback`'s.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.primitives import Multiplexer

from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.playback import ClipPlayback


class ReferenceMotionSource(LeafSystem):
    """A clip's joint trajectories and state over simulation time.

    .. pydrake_system::

        name: ReferenceMotionSource
        output_ports:
        - joint_positions
        - joint_velocities
        - state
        - key_body_positions

    `joint_positions` and `joint_velocities` have one entry per joint of the
    clip; `state` is the model's [q; v] (root quaternion w x y z and
    position, joints, then root angular and linear velocity and joint
    velocities, as a floating MultibodyPlant model orders them; joints only
    for a fixed base); `key_body_positions` is 3 per key body.
    """

    def __init__(self, clip: MotionClip, loop: bool = True, floating_base: bool = True, start_time: float = 0.0):
        super().__init__()
        self.playback = ClipPlayback(clip, loop, start_time)
        self._floating = floating_base
        n, k = len(clip.joint_names), len(clip.key_body_names)
        state_size = 2 * n + (13 if floating_base else 0)
        self.DeclareVectorOutputPort("joint_positions", n, self._CalcJointPositions)
        self.DeclareVectorOutputPort("joint_velocities", n, self._CalcJointVelocities)
        self.DeclareVectorOutputPort("state", state_size, self._CalcState)
        self.DeclareVectorOutputPort("key_body_positions", 3 * k, self._CalcKeyBodies)

    def _CalcJointPositions(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.playback.joints_at(context.get_time())[0])

    def _CalcJointVelocities(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.playback.joints_at(context.get_time())[1])

    def _CalcKeyBodies(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.playback.key_bodies_at(context.get_time()).ravel())

    def _CalcState(self, context: Context, output: BasicVector) -> None:
        t = context.get_time()
        q, v = self.playback.joints_at(t)
        if not self._floating:
            output.SetFromVector(np.concatenate([q, v]))
            return
        quaternion, root, omega, linear = self.playback.root_at(t)
        output.SetFromVector(np.concatenate([quaternion, root, q, omega, linear, v]))


def AddReferenceMotion(
    builder: DiagramBuilder, source: ReferenceMotionSource, desired_state: bool = True
) -> tuple[ReferenceMotionSource, OutputPort]:
    """Add `source` as `reference`; returns it and its PD targets: with
    `desired_state` the [q*; v*] the plant's built-in PD takes (through a
    `reference_desired_state` multiplexer), else the joint positions."""
    reference = builder.AddNamedSystem("reference", source)
    positions = reference.GetOutputPort("joint_positions")
    if not desired_state:
        return reference, positions
    n = positions.size()
    mux = builder.AddNamedSystem("reference_desired_state", Multiplexer([n, n]))
    builder.Connect(positions, mux.get_input_port(0))
    builder.Connect(reference.GetOutputPort("joint_velocities"), mux.get_input_port(1))
    return reference, mux.get_output_port()
