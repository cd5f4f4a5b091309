"""The policy checkpoint format and PolicySystem."""

import numpy as np
import pytest
import torch
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from hotu_drake.learning.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork
from hotu_drake.systems.policy import AddPolicy, PolicySystem
from tests.systems.ports import assert_inputs_wired, assert_port_contract


def _network() -> PolicyNetwork:
    torch.manual_seed(0)
    network = PolicyNetwork(
        PolicyConfig(observation_size=7, action_size=3, latent_sizes={"hip": 2, "knee": 4}, hidden=(16,))
    )
    network.normalizer.mean.copy_(torch.linspace(-1, 1, 7))
    network.normalizer.var.copy_(torch.full((7,), 4.0))
    return network


def test_checkpoint_round_trip(tmp_path):
    network = _network()
    path = save_checkpoint(tmp_path / "policy.pt", network, "h1", "none", {"seed": 0})
    loaded, meta = load_checkpoint(path)
    assert meta["embodiment"] == "h1" and meta["hands"] == "none" and meta["meta"] == {"seed": 0}
    assert meta["kind"] == "policy" and meta["latent"]["size"] == 4
    observation = torch.randn(5, 7)
    latents = {"hip": torch.randn(5, 2), "knee": torch.randn(5, 4)}
    assert torch.allclose(loaded(observation, latents), network(observation, latents))
    (tmp_path / "bad.pt").write_text("not a checkpoint")
    with pytest.raises(CheckpointError, match="bad.pt"):
        load_checkpoint(tmp_path / "bad.pt")


def test_policy_system_matches_the_network_and_holds_between_updates(tmp_path):
    network = _network()
    path = save_checkpoint(tmp_path / "policy.pt", network, "h1", "none")
    system = PolicySystem.from_checkpoint(path)
    assert [system.get_input_port(i).get_name() for i in range(3)] == ["observation", "latent_hip", "latent_knee"]
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    rng = np.random.default_rng(0)
    observation, hip, knee = rng.normal(size=7), rng.normal(size=2), rng.normal(size=4)
    system.get_input_port(0).FixValue(context, observation)
    system.get_input_port(1).FixValue(context, hip)
    system.get_input_port(2).FixValue(context, knee)
    simulator.AdvanceTo(0.01)  # the update at t = 0 has run
    expected = (
        network(
            torch.tensor(observation, dtype=torch.float32)[None],
            {
                "hip": torch.tensor(hip, dtype=torch.float32)[None],
                "knee": torch.tensor(knee, dtype=torch.float32)[None],
            },
        )[0]
        .detach()
        .numpy()
    )
    action = system.get_output_port(0).Eval(context)
    assert action == pytest.approx(expected, abs=1e-6)
    system.get_input_port(0).FixValue(context, observation + 1.0)
    simulator.AdvanceTo(0.03)  # before the next 30 Hz update: held
    assert system.get_output_port(0).Eval(context) == pytest.approx(action)
    simulator.AdvanceTo(0.04)  # after it: new action
    assert not np.allclose(system.get_output_port(0).Eval(context), action)


def test_learning_package_is_pydrake_free():
    """The learning side sees the world only through arrays (DESIGN: pydrake-free)."""
    import subprocess
    import sys

    code = (
        "import sys, pkgutil, importlib, hotu_drake.learning as l\n"
        "for m in pkgutil.walk_packages(l.__path__, 'hotu_drake.learning.'): importlib.import_module(m.name)\n"
        "print(any(name.startswith('pydrake') for name in sys.modules))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False"


def test_port_contract():
    builder = DiagramBuilder()
    observation = builder.AddSystem(ConstantVectorSource(np.zeros(7)))
    policy = AddPolicy(builder, _network(), observation.get_output_port(), control_rate=30.0)
    assert_inputs_wired(builder, policy)  # the latents are held at zero by their sources
    assert_port_contract(policy, {"observation": 7, "latent_hip": 2, "latent_knee": 4}, {"action": 3})
    diagram = builder.Build()
    assert diagram.HasSubsystemNamed("latent_hip_source") and diagram.HasSubsystemNamed("latent_knee_source")
