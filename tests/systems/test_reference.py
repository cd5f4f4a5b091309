"""ReferenceMotionSource: a clip as a time signal, and how it is wired as PD targets."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from hotu_drake.motion.clip import MotionClip
from hotu_drake.systems.reference import AddReferenceMotion, ReferenceMotionSource
from tests.systems.ports import assert_port_contract


def _clip(frames: int = 5, fps: float = 10.0) -> MotionClip:
    t = np.arange(frames) / fps
    q = np.column_stack([t, -t])
    quaternions = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    root = np.column_stack([t, np.zeros(frames), np.ones(frames)])
    keys = np.zeros((frames, 1, 3))
    return MotionClip.from_positions("test", "test", fps, ["a", "b"], q, root, quaternions, ["hand"], keys)


def test_port_contract():
    clip = _clip()
    source = ReferenceMotionSource(clip, loop=False, floating_base=True)
    outputs = {"joint_positions": 2, "joint_velocities": 2, "state": 7 + 2 + 6 + 2, "key_body_positions": 3}
    assert_port_contract(source, {}, outputs)
    fixed = ReferenceMotionSource(clip, floating_base=False)
    assert fixed.GetOutputPort("state").size() == 4


def test_interpolates_and_holds_the_last_frame():
    source = ReferenceMotionSource(_clip(), loop=False, start_time=0.1)
    context = source.CreateDefaultContext()
    context.SetTime(0.15)  # clip time 0.25: halfway between frames 2 and 3
    assert source.GetOutputPort("joint_positions").Eval(context) == pytest.approx([0.25, -0.25])
    context.SetTime(10.0)
    assert source.GetOutputPort("joint_positions").Eval(context) == pytest.approx([0.4, -0.4])


@pytest.mark.parametrize("desired_state", [True, False])
def test_add_reference_motion_gives_the_pd_targets(desired_state):
    builder = DiagramBuilder()
    reference, targets = AddReferenceMotion(builder, ReferenceMotionSource(_clip()), desired_state)
    assert builder.GetSubsystemByName("reference") is reference
    assert targets.size() == (4 if desired_state else 2)
