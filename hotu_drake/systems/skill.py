"""SkillPolicySystem: a skill's high-level policy, choosing the behavior controller's latents.

The network (the high level of a `train skill` run) maps the robot's
observation, the task's goal g and the interaction graph's s_I to one
latent per part group of the frozen behavior controller, each normalised
onto its sphere (`learning.skill_agent.to_latents`, as in training), and
chooses again every `hold_steps` control periods. Its `latent_<group>`
outputs feed the latent inputs of the controller's `PolicySystem`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem, OutputPort

from hotu_drake.embodiment import Embodiment
from hotu_drake.errors import InputError
from hotu_drake.learning import CheckpointError, PolicyNetwork, high_level_input, load_checkpoint, to_latents
from hotu_drake.systems.interaction_graph import GOAL_SIZE
from hotu_drake.systems.observation import observation_size
from hotu_drake.systems.policy import CONTROL_RATE, check_embodiment


def load_skill_policy(path: str | Path, embodiment: Embodiment, reference_size: int = 0) -> tuple[PolicyNetwork, dict]:
    """The high-level network of a skill checkpoint and its `meta`, checked
    against `embodiment` (and, for a fine-tuned transfer layer, the size of
    its reference features); `InputError` naming the file otherwise."""
    try:
        network, data = load_checkpoint(path)
    except CheckpointError as error:
        raise InputError(str(error)) from None
    meta = data.get("meta", {})
    if meta.get("kind") != "skill":
        raise InputError(f"{path}: not a skill checkpoint (train one with `python -m hotu_drake.train skill`)")
    check_embodiment(path, data, embodiment, "skill")
    trained = int(meta.get("reference_size", 0))
    if trained != reference_size:
        what = "a transfer layer: give its reference clip" if trained else "not a transfer layer: it takes no reference"
        raise InputError(f"{path}: {what} (reference features {trained}, given {reference_size})")
    expected = observation_size(embodiment) + GOAL_SIZE + reference_size + int(meta["interaction_size"])
    if network.config.observation_size != expected:
        size = network.config.observation_size
        raise InputError(f"{path}: the skill observes {size} numbers, {embodiment.name}'s task gives {expected}")
    return network, meta


class SkillPolicySystem(LeafSystem):
    """The high level of a skill.

    .. pydrake_system::

        name: SkillPolicySystem
        input_ports:
        - observation
        - goal
        - interaction
        - reference (optional: a fine-tuned transfer layer's)
        output_ports:
        - latents
        - latent_<group> (one per part group of the controller)

    Discrete state: the held latents and the control periods until the next
    choice, updated every control period. When a choice is due, the outputs
    are the network's answer to the current inputs (so the controller acting
    at that instant uses them, as in training); otherwise the held latents.
    `latents` is every group's, in the order of `latent_<group>`.
    """

    def __init__(
        self,
        network: PolicyNetwork,
        groups: list[str],
        latent_size: int,
        hold_steps: int,
        observation_size: int,
        interaction_size: int,
        control_rate: float = CONTROL_RATE,
        reference_size: int = 0,
    ):
        super().__init__()
        if network.config.action_size != len(groups) * latent_size:
            raise ValueError(
                f"the network gives {network.config.action_size} numbers, not {len(groups)} x {latent_size}"
            )
        self._network = network.eval()
        self._groups, self._size, self._hold = list(groups), latent_size, int(hold_steps)
        self._observation = self.DeclareVectorInputPort("observation", observation_size)
        self._goal = self.DeclareVectorInputPort("goal", GOAL_SIZE)
        self._interaction = self.DeclareVectorInputPort("interaction", interaction_size)
        self._reference = self.DeclareVectorInputPort("reference", reference_size) if reference_size else None
        total = len(groups) * latent_size
        self._state = self.DeclareDiscreteState(np.zeros(total + 1))  # latents, periods until the next choice
        self._all = self.DeclareVectorOutputPort(
            "latents", total, self._CalcLatents, prerequisites_of_calc={self.all_sources_ticket()}
        )
        for index, group in enumerate(self._groups):
            part = slice(index * latent_size, (index + 1) * latent_size)
            self.DeclareVectorOutputPort(
                f"latent_{group}",
                latent_size,
                lambda context, output, part=part: output.SetFromVector(self._all.Eval(context)[part]),
                prerequisites_of_calc={self.all_sources_ticket()},
            )
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / control_rate, 0.0, self._Update)

    def _choose(self, context: Context) -> np.ndarray:
        """The network's latents for the current inputs."""
        observed = [self._observation.Eval(context), self._goal.Eval(context)]
        if self._reference is not None:  # a transfer layer sees the reference after the goal, as in training
            observed.append(self._reference.Eval(context))
        inputs = high_level_input(np.concatenate(observed)[None], self._interaction.Eval(context)[None])
        with torch.no_grad():
            raw = self._network.mean(torch.as_tensor(inputs)).numpy()
        latents = to_latents(raw, self._groups, self._size)
        return np.concatenate([latents[g][0] for g in self._groups])

    def _CalcLatents(self, context: Context, output: BasicVector) -> None:
        state = context.get_discrete_state(self._state).get_value()
        output.SetFromVector(self._choose(context) if state[-1] <= 0 else state[:-1])

    def _Update(self, context: Context, discrete_state) -> None:
        state = context.get_discrete_state(self._state).get_value()
        if state[-1] <= 0:
            discrete_state.set_value(self._state, np.concatenate([self._all.Eval(context), [self._hold - 1]]))
        else:
            discrete_state.set_value(self._state, np.concatenate([state[:-1], [state[-1] - 1]]))


def AddSkillPolicy(
    builder: DiagramBuilder,
    network: PolicyNetwork,
    meta: dict,
    observation: OutputPort,
    goal: OutputPort,
    interaction: OutputPort,
    control_rate: float = CONTROL_RATE,
    reference: OutputPort | None = None,
) -> SkillPolicySystem:
    """Add a `SkillPolicySystem` named `skill` for a skill checkpoint's
    network and `meta`, fed by the robot's observation, the task's goal and
    s_I (and a transfer layer's `reference` features); `AddPolicy(...,
    latents=skill)` connects its `latent_<group>` outputs to the controller's inputs."""
    system = SkillPolicySystem(
        network,
        list(meta["llc_groups"]),
        int(meta["latent_size"]),
        int(meta["hold_steps"]),
        observation.size(),
        interaction.size(),
        control_rate,
        reference.size() if reference is not None else 0,
    )
    skill = builder.AddNamedSystem("skill", system)
    builder.Connect(observation, skill.GetInputPort("observation"))
    builder.Connect(goal, skill.GetInputPort("goal"))
    builder.Connect(interaction, skill.GetInputPort("interaction"))
    if reference is not None:
        builder.Connect(reference, skill.GetInputPort("reference"))
    return skill
