"""SkillPolicySystem: its ports, and latents on their spheres held for k control periods."""

import numpy as np
import pytest
import torch
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, ConstantVectorSource, Sine

from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork
from hotu_drake.systems.skill import AddSkillPolicy, SkillPolicySystem
from tests.systems.ports import assert_inputs_wired, assert_port_contract

OBSERVATION, GOAL, INTERACTION = 7, 12, 11
GROUPS, SIZE = ["lower_body", "left_arm"], 4


def _network() -> PolicyNetwork:
    torch.manual_seed(0)
    network = PolicyNetwork(PolicyConfig(OBSERVATION + GOAL + INTERACTION, len(GROUPS) * SIZE, {}, (16,)))
    with torch.no_grad():
        network.body[-1].weight.mul_(100.0)  # undo the small start: latents that follow the inputs
    return network


def test_port_contract():
    builder = DiagramBuilder()
    sources = {n: builder.AddSystem(ConstantVectorSource(np.zeros(k))) for n, k in
               (("observation", OBSERVATION), ("goal", GOAL), ("interaction", INTERACTION))}  # fmt: skip
    meta = {"llc_groups": GROUPS, "latent_size": SIZE, "hold_steps": 3}
    skill = AddSkillPolicy(builder, _network(), meta, *(s.get_output_port() for s in sources.values()))
    assert_inputs_wired(builder, skill)
    assert_port_contract(
        skill,
        {"observation": OBSERVATION, "goal": GOAL, "interaction": INTERACTION},
        {"latents": 8, "latent_lower_body": SIZE, "latent_left_arm": SIZE},
    )


@pytest.mark.parametrize("hold", [1, 3])
def test_latents_are_held_for_k_control_periods(hold):
    builder = DiagramBuilder()
    system = builder.AddSystem(SkillPolicySystem(_network(), GROUPS, SIZE, hold, OBSERVATION, INTERACTION))
    moving = builder.AddSystem(
        Sine(np.ones(OBSERVATION), np.full(OBSERVATION, 7.0), np.arange(OBSERVATION, dtype=float))
    )
    offset = builder.AddSystem(ConstantVectorSource(np.full(OBSERVATION, 0.1)))
    observation = builder.AddSystem(Adder(2, OBSERVATION))
    builder.Connect(moving.get_output_port(0), observation.get_input_port(0))
    builder.Connect(offset.get_output_port(), observation.get_input_port(1))
    builder.Connect(observation.get_output_port(), system.GetInputPort("observation"))
    for name, size in (("goal", GOAL), ("interaction", INTERACTION)):
        builder.Connect(builder.AddSystem(ConstantVectorSource(np.full(size, 0.3))).get_output_port(),
                        system.GetInputPort(name))  # fmt: skip
    diagram = builder.Build()
    simulator = Simulator(diagram)
    held = []
    for n in range(7):
        simulator.AdvanceTo(n / 30.0 + 1e-6)  # just after the update at the n-th control instant
        held.append(
            system.GetMyContextFromRoot(simulator.get_context()).get_discrete_state_vector().value()[:-1].copy()
        )
    changes = [n for n in range(1, 7) if not np.allclose(held[n], held[n - 1])]
    assert changes == list(range(hold, 7, hold))  # new latents every k periods, and only then
    for z in np.split(held[0], len(GROUPS)):
        assert np.linalg.norm(z) == pytest.approx(1.0, abs=1e-5)
