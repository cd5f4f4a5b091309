"""PlanarBaseCommand: its ports, and the twist integrated in the base frame."""

import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.systems.base_command import AddPlanarBaseCommand
from tests.systems.ports import assert_port_contract


def test_port_contract_and_integration():
    curi = embodiment.load("curi", "none")
    builder = DiagramBuilder()
    command = AddPlanarBaseCommand(builder, curi, period=0.01)
    n = len(curi.joint_names)
    assert_port_contract(command, {"twist": 3}, {"desired_state": 2 * n})
    simulator = Simulator(command)
    context = simulator.get_mutable_context()
    command.GetInputPort("twist").FixValue(context, [0.0, 0.0, 0.5])  # turn on the spot
    simulator.AdvanceTo(1.0)
    desired = command.GetOutputPort("desired_state").Eval(context)
    yaw = curi.joint_names.index(curi.base_joints[2])
    assert desired[yaw] == pytest.approx(curi.standing_pose[yaw] + 0.5, abs=0.01)
    assert desired[n + yaw] == pytest.approx(0.5)


def test_only_a_planar_base_takes_a_twist():
    with pytest.raises(ValueError, match="no planar base"):
        AddPlanarBaseCommand(DiagramBuilder(), embodiment.load("h1", "none"), period=0.01)
