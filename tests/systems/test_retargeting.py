"""RetargetingSystem: its ports; it streams as the batch stream does; its
stream lives in the Context, so two contexts retarget independently."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from hotu_drake import embodiment
from hotu_drake.motion.udh_skeleton import udh_landmarks
from hotu_drake.retarget.retargeter import Retargeter, RetargetStream
from hotu_drake.systems.retargeting import RetargetingSystem
from tests.clips import udh_test_clip
from tests.systems.ports import assert_port_contract


@pytest.fixture(scope="module")
def walk():
    truth = udh_test_clip("none", frames=10)
    points = udh_landmarks(embodiment.load("udh", "none"), truth)
    return truth, points


def _frame(points, names, k):
    return np.concatenate([points[n][k] for n in names])


def test_port_contract(walk):
    truth, points = walk
    h1 = embodiment.load("h1", "none")
    system = RetargetingSystem(h1, list(points), fps=truth.fps)
    assert_port_contract(system, {"human_pose": 3 * len(points)}, {"positions": 7 + len(h1.joint_names)})


def test_streams_like_the_stream(walk):
    truth, points = walk
    names = list(points)
    h1 = embodiment.load("h1", "none")
    system = RetargetingSystem(h1, names, fps=truth.fps)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    system.GetInputPort("human_pose").FixValue(context, _frame(points, names, 0))
    simulator.AdvanceTo(0.5 / truth.fps)
    stream = RetargetStream(Retargeter(h1, set(names)), truth.fps, {n: points[n][:1] for n in names})
    q, _, _ = stream.push({n: points[n][:1] for n in names})
    assert system.GetOutputPort("positions").Eval(context)[7:] == pytest.approx(q)


def test_two_contexts_retarget_independently(walk):
    """The stream (warm start, body-size ratio) is abstract state: a second
    context starts fresh instead of continuing the first one's stream."""
    truth, points = walk
    names = list(points)
    system = RetargetingSystem(embodiment.load("bruce", "none"), names, fps=truth.fps)
    first, second = system.CreateDefaultContext(), system.CreateDefaultContext()
    for context, frames in ((first, range(5)), (second, [0])):
        simulator = Simulator(system, context)
        for k in frames:
            system.GetInputPort("human_pose").FixValue(context, _frame(points, names, k))
            simulator.AdvanceTo(k / truth.fps + 0.5 / truth.fps)
    fresh = system.CreateDefaultContext()
    simulator = Simulator(system, fresh)
    system.GetInputPort("human_pose").FixValue(fresh, _frame(points, names, 0))
    simulator.AdvanceTo(0.5 / truth.fps)
    positions = system.GetOutputPort("positions")
    np.testing.assert_array_equal(positions.Eval(second), positions.Eval(fresh))
    assert first.get_abstract_state(0).get_value().count == 5
    assert second.get_abstract_state(0).get_value().count == 1
