"""PolicySystem: runs a policy network at the control rate.

The network (`learning.networks.PolicyNetwork`, from a checkpoint that
training writes) maps the observation and one latent per functional part
to an action (normalised PD targets), updated every control period (30 Hz
by default) and held in between (zero-order hold).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.primitives import ConstantVectorSource

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.actions import standing_action
from hotu_drake.errors import InputError
from hotu_drake.learning import CheckpointError, PolicyConfig, PolicyNetwork, load_checkpoint
from hotu_drake.systems.motion_reference import EXTRAS, extra_size
from hotu_drake.systems.observation import observation_size

CONTROL_RATE = 30.0  # Hz
LATENT_SIZE = 16  # per functional part


def policy_for(embodiment: Embodiment, latent_size: int = LATENT_SIZE, seed: int = 0) -> PolicyNetwork:
    """A freshly initialised policy shaped for `embodiment`: its observation,
    one action per joint, one latent per functional part. Its mean action
    starts at the standing pose's, so an untrained policy holds the robot
    roughly upright (training starts here)."""
    torch.manual_seed(seed)
    parts = {part: latent_size for part, joints in embodiment.parts.items() if joints}
    offset = tuple(float(a) for a in standing_action(embodiment))
    config = PolicyConfig(observation_size(embodiment), len(embodiment.joint_names), parts, action_offset=offset)
    return PolicyNetwork(config)


def load_policy(path: str | Path, embodiment: Embodiment, goal_size: int = 0) -> tuple[PolicyNetwork, dict]:
    """The network of a checkpoint and its metadata, checked against
    `embodiment` (a network that also observes a task's goal of `goal_size`
    numbers fits too); a file that does not fit raises `InputError` naming it."""
    try:
        network, meta = load_checkpoint(path)
    except CheckpointError as error:
        raise InputError(str(error)) from None
    if meta.get("meta", {}).get("kind") == "skill":
        raise InputError(f"{path}: a skill's high level, not a controller (a scenario runs it with !SkillCheckpoint)")
    check_embodiment(path, meta, embodiment, "policy")
    if network.config.action_size != len(embodiment.joint_names):
        actions, joints = network.config.action_size, len(embodiment.joint_names)
        raise InputError(f"{path}: the policy has {actions} actions, {embodiment.name} has {joints} joints")
    expected = observation_size(embodiment) + sum(extra_size(extra, embodiment) for extra in observation_extras(meta))
    if network.config.observation_size not in {expected, expected + goal_size}:
        size = network.config.observation_size
        raise InputError(f"{path}: the policy observes {size} numbers, {embodiment.name}'s observation has {expected}")
    return network, meta


def observation_extras(meta: dict) -> tuple[str, ...]:
    """What a checkpoint's policy observes after the robot's observation, in
    order: `phase`, `reference`, `pose` (a clone that follows a clip, as
    its environments gave them: `systems.motion_reference`); none for most."""
    environment = meta.get("meta", {}).get("config", {}).get("environment", {})
    return tuple(extra for extra in EXTRAS if environment.get(f"{extra}_observation"))


def check_embodiment(path: str | Path, data: dict, embodiment: Embodiment, what: str) -> None:
    """`InputError` unless the checkpoint `data` was trained on `embodiment` (with its hands)."""
    if (data.get("embodiment"), data.get("hands")) != (embodiment.name, embodiment.hands):
        raise InputError(
            f"{path}: the {what} drives {data.get('embodiment')} hands={data.get('hands')}, "
            f"not {embodiment.name} hands={embodiment.hands}"
        )


class PolicySystem(LeafSystem):
    """A policy network sampled at the control rate.

    .. pydrake_system::

        name: PolicySystem
        input_ports:
        - observation
        - latent_<part> (one per functional part of the network)
        output_ports:
        - action

    Discrete state: the held action and the time of the next update. At an
    update instant `action` is the network's answer to the current inputs,
    so the plant's step at that instant applies it, as the environments do
    (a state output would reach the plant one plant step late); between
    updates it is the held action.
    """

    def __init__(self, network: PolicyNetwork, control_rate: float = CONTROL_RATE):
        super().__init__()
        self._network = network.eval()
        config = network.config
        self._observation = self.DeclareVectorInputPort("observation", config.observation_size)
        self._latent_ports = {
            part: self.DeclareVectorInputPort(f"latent_{part}", size) for part, size in config.latent_sizes.items()
        }
        self._period = 1.0 / control_rate
        self._state = self.DeclareDiscreteState(np.zeros(config.action_size + 1))  # action, next update time
        self._output = self.DeclareVectorOutputPort(
            "action", config.action_size, self._CalcAction, prerequisites_of_calc={self.all_sources_ticket()}
        )
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._Update)

    @staticmethod
    def from_checkpoint(path: str | Path, control_rate: float = CONTROL_RATE) -> PolicySystem:
        network, _ = load_checkpoint(path)
        return PolicySystem(network, control_rate)

    def latent_input_ports(self) -> dict:
        """Functional part -> its latent input port."""
        return dict(self._latent_ports)

    def _act(self, context: Context) -> np.ndarray:
        """The network's action for the current inputs."""
        observation = torch.as_tensor(self._observation.Eval(context), dtype=torch.float32)
        latents = {
            part: torch.as_tensor(port.Eval(context), dtype=torch.float32) for part, port in self._latent_ports.items()
        }
        with torch.no_grad():
            return self._network(observation, latents).numpy().astype(np.float64)

    def _CalcAction(self, context: Context, output: BasicVector) -> None:
        state = context.get_discrete_state(self._state).get_value()
        due = context.get_time() >= state[-1] - 1e-6 * self._period
        output.SetFromVector(self._act(context) if due else state[:-1])

    def _Update(self, context: Context, discrete_state) -> None:
        action = self._output.Eval(context)  # due now: the network's answer, computed once
        discrete_state.set_value(self._state, np.append(action, context.get_time() + self._period))


def AddPolicy(
    builder: DiagramBuilder,
    network: PolicyNetwork,
    observation: OutputPort,
    control_rate: float = CONTROL_RATE,
    latents: LeafSystem | None = None,
) -> PolicySystem:
    """Add a `PolicySystem` named `policy` fed by `observation`; its latents
    come from `latents` (a system with a `latent_<group>` output per group,
    e.g. `LatentSampler`), or are held at zero (`latent_<group>_source`)."""
    policy = builder.AddNamedSystem("policy", PolicySystem(network, control_rate))
    builder.Connect(observation, policy.GetInputPort("observation"))
    for port in policy.latent_input_ports().values():
        if latents is not None:
            builder.Connect(latents.GetOutputPort(port.get_name()), port)
            continue
        source = builder.AddNamedSystem(f"{port.get_name()}_source", ConstantVectorSource(np.zeros(port.size())))
        builder.Connect(source.get_output_port(), port)
    return policy
