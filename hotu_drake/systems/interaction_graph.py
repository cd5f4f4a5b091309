"""InteractionGraphSystem: the human(oid)-object interaction graph of a task.

Nodes are aggregated body parts (a hand with its fingers is one node; the
rest of the body another) and the task's objects. Hand nodes carry the
hand-object relative positions, object nodes the object-target relative
position; an edge is on while the two touch. The discriminator input is
s_I = {d_ho, d_og, e_ho}.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import Value
from pydrake.multibody.plant import ContactResults, MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.spec import HAND_ROLES


@dataclass
class InteractionGraph:
    """One frame of the graph."""

    node_positions: dict[str, np.ndarray] = field(default_factory=dict)
    hand_object: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)  # d_ho, world frame
    object_target: dict[str, np.ndarray] = field(default_factory=dict)  # d_og, world frame
    edges: dict[tuple[str, str], bool] = field(default_factory=dict)  # binary contact


class InteractionGraphSystem(LeafSystem):
    """The interaction graph of a robot's hands and body with task objects.

    .. pydrake_system::

        name: InteractionGraphSystem
        input_ports:
        - body_poses
        - contact_results
        - object_targets
        output_ports:
        - graph
        - interaction

    `body_poses` and `contact_results` are the plant's; `object_targets`
    holds 3 numbers per object (its target position). `graph` is an
    `InteractionGraph`; `interaction` is s_I: d_ho for each hand and
    object, d_og for each object, then e_ho as 0/1.
    """

    def __init__(self, plant: MultibodyPlant, model: ModelInstanceIndex, embodiment: Embodiment, objects: dict):
        """`objects` maps each object's name in the graph to its body."""
        super().__init__()
        self._plant = plant
        self._objects = list(objects)
        self._object_body = {name: body.index() for name, body in objects.items()}
        # A hand node is the hand link and every finger link of that side.
        self._hand_body = {}
        self._hand_members: dict[str, set] = {}
        for role in HAND_ROLES:
            side = role.split("_")[0]
            hand = plant.GetBodyByName(embodiment.key_bodies[role], model)
            members = {hand.index()}
            for joint in embodiment.finger_joints:
                if joint.startswith(f"{side}_"):
                    members.add(plant.GetJointByName(joint, model).child_body().index())
            self._hand_body[role] = hand.index()
            self._hand_members[role] = members
        self._body_members = set(plant.GetBodyIndices(model)) - set().union(*self._hand_members.values())
        self._body_root = plant.GetBodyByName(embodiment.key_bodies["pelvis"], model).index()
        m, h = len(self._objects), len(HAND_ROLES)
        self.interaction_size = 3 * h * m + 3 * m + h * m
        self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self._contacts = self.DeclareAbstractInputPort("contact_results", Value(ContactResults()))
        self._targets = self.DeclareVectorInputPort("object_targets", 3 * m)
        self.DeclareAbstractOutputPort("graph", lambda: Value(InteractionGraph()), self._CalcGraph)
        self.DeclareVectorOutputPort("interaction", self.interaction_size, self._CalcInteraction)

    def graph(self, context: Context) -> InteractionGraph:
        poses = self._poses.Eval(context)
        contacts = self._contacts.Eval(context)
        targets = self._targets.Eval(context).reshape(-1, 3)
        touching = set()
        for i in range(contacts.num_point_pair_contacts()):
            info = contacts.point_pair_contact_info(i)
            touching.add((info.bodyA_index(), info.bodyB_index()))
            touching.add((info.bodyB_index(), info.bodyA_index()))
        graph = InteractionGraph()
        objects = {name: poses[int(index)].translation() for name, index in self._object_body.items()}
        for role in HAND_ROLES:
            graph.node_positions[role] = poses[int(self._hand_body[role])].translation()
        graph.node_positions["body"] = poses[int(self._body_root)].translation()
        for (name, position), target in zip(objects.items(), targets):
            graph.node_positions[name] = position
            graph.object_target[name] = target - position
            index = self._object_body[name]
            for role in HAND_ROLES:
                graph.hand_object[(role, name)] = position - graph.node_positions[role]
                graph.edges[(role, name)] = any((b, index) in touching for b in self._hand_members[role])
            graph.edges[("body", name)] = any((b, index) in touching for b in self._body_members)
        return graph

    def _CalcGraph(self, context: Context, output) -> None:
        output.set_value(self.graph(context))

    def _CalcInteraction(self, context: Context, output: BasicVector) -> None:
        graph = self.graph(context)
        d_ho = [graph.hand_object[(role, name)] for role in HAND_ROLES for name in self._objects]
        d_og = [graph.object_target[name] for name in self._objects]
        e_ho = [float(graph.edges[(role, name)]) for role in HAND_ROLES for name in self._objects]
        output.SetFromVector(np.concatenate([np.ravel(d_ho), np.ravel(d_og), e_ho]))


def AddInteractionGraph(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    model: ModelInstanceIndex,
    embodiment: Embodiment,
    objects: dict,
    targets: np.ndarray,
) -> InteractionGraphSystem:
    """Add an `InteractionGraphSystem` named `interaction_graph` over `objects`
    (name in the graph -> body), wired to the plant, with the objects'
    target positions from a constant source named `object_targets` (an
    environment rewrites it per episode)."""
    graph = builder.AddNamedSystem("interaction_graph", InteractionGraphSystem(plant, model, embodiment, objects))
    goals = builder.AddNamedSystem("object_targets", ConstantVectorSource(np.ravel(targets).astype(float)))
    builder.Connect(plant.get_body_poses_output_port(), graph.GetInputPort("body_poses"))
    builder.Connect(plant.get_contact_results_output_port(), graph.GetInputPort("contact_results"))
    builder.Connect(goals.get_output_port(), graph.GetInputPort("object_targets"))
    return graph
