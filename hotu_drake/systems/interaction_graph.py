"""InteractionGraphSystem: the human(oid)-object interaction graph of a task.

Nodes are aggregated body parts (a hand with its fingers is one node; the
rest of the body another) and the task's objects. Hand nodes carry the
hand-object relative positions, object nodes the object-target relative
position; an edge is on while the two touch (penetrating it, or a hand's key point within `touch_margin`).
The discriminator input is s_I = {d_ho, d_og, e_ho}, its vectors in the
body's heading frame (so the same carry looks the same facing any way).

The same system, evaluated on a context set to a demonstration's frame
(robot pose and object track), gives the demonstrations' s_I: one
computation for the interaction discriminator's two sides.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import QueryObject, SceneGraph, SceneGraphInspector
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.spec import HAND_ROLES
from hotu_drake.rotations import heading_rotation

TOUCH_MARGIN = 0.05  # m: a hand whose key point is this close to an object touches it
GOAL_SIZE = 3 + 6 + 3  # the first object's position and rotation columns, and its target


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
        - geometry_query
        - object_targets
        output_ports:
        - graph
        - interaction
        - goal

    `body_poses` is the plant's, `geometry_query` the scene graph's;
    `object_targets` holds 3 numbers per object (its target position).
    `graph` is an `InteractionGraph` (world frame); `interaction` is s_I:
    d_ho for each hand and object, d_og for each object, then e_ho as 0/1,
    the vectors in the body node's heading frame. `goal` is what a task
    policy sees of the first object (g): its position and the first two
    columns of its rotation, and its target, relative to the body node in
    its heading frame.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        model: ModelInstanceIndex,
        embodiment: Embodiment,
        objects: dict,
        touch_margin: float = TOUCH_MARGIN,
    ):
        """`objects` maps each object's name in the graph to its body."""
        super().__init__()
        self._plant = plant
        self._touch_margin = float(touch_margin)
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
        self._query = self.DeclareAbstractInputPort("geometry_query", Value(QueryObject()))
        self._targets = self.DeclareVectorInputPort("object_targets", 3 * m)
        self._geometry_body: dict = {}  # geometry id -> body index, filled on first use
        self.DeclareAbstractOutputPort("graph", lambda: Value(InteractionGraph()), self._CalcGraph)
        self.DeclareVectorOutputPort("interaction", self.interaction_size, self._CalcInteraction)
        self.DeclareVectorOutputPort("goal", GOAL_SIZE, self._CalcGoal)

    def _touching(self, context: Context, poses) -> set:
        """(node, object body) pairs in touch: a geometry of the node's bodies
        penetrates the object's, or (hands) the hand's key point is within
        `touch_margin` of the object's surface. Point distances rather than
        shape-to-shape ones: Drake's box-box distance aborts on boxes in
        exact touch, which a retargeted demonstration's palm on a box face is."""
        query = self._query.Eval(context)
        if not self._geometry_body:
            self._index_geometries(query.inspector())
        objects = set(self._object_body.values())
        bodies = set()
        for pair in query.ComputePointPairPenetration():
            a, b = self._geometry_body.get(pair.id_A), self._geometry_body.get(pair.id_B)
            if a in objects and b is not None:
                bodies.add((b, a))
            if b in objects and a is not None:
                bodies.add((a, b))
        touching = set()
        for role in HAND_ROLES:
            point = poses[int(self._hand_body[role])].translation()
            for hit in query.ComputeSignedDistanceToPoint(point, self._touch_margin):
                body = self._geometry_body.get(hit.id_G)
                if body in objects:
                    touching.add((role, body))
            touching |= {(role, o) for b, o in bodies if b in self._hand_members[role]}
        touching |= {("body", o) for b, o in bodies if b in self._body_members}
        return touching

    def _index_geometries(self, inspector: SceneGraphInspector) -> None:
        for geometry in inspector.GetAllGeometryIds():
            body = self._plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
            if body is not None:
                self._geometry_body[geometry] = body.index()

    def graph(self, context: Context) -> InteractionGraph:
        poses = self._poses.Eval(context)
        targets = self._targets.Eval(context).reshape(-1, 3)
        touching = self._touching(context, poses)
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
                graph.edges[(role, name)] = (role, index) in touching
            graph.edges[("body", name)] = ("body", index) in touching
        return graph

    def _CalcGraph(self, context: Context, output) -> None:
        output.set_value(self.graph(context))

    def _heading(self, context: Context):
        """The body node's pose and its heading rotation (world -> heading frame)."""
        body = self._poses.Eval(context)[int(self._body_root)]
        return body, heading_rotation(body.rotation().matrix()).T

    def _CalcInteraction(self, context: Context, output: BasicVector) -> None:
        graph = self.graph(context)
        _, to_heading = self._heading(context)
        d_ho = [to_heading @ graph.hand_object[(role, name)] for role in HAND_ROLES for name in self._objects]
        d_og = [to_heading @ graph.object_target[name] for name in self._objects]
        e_ho = [float(graph.edges[(role, name)]) for role in HAND_ROLES for name in self._objects]
        output.SetFromVector(np.concatenate([np.ravel(d_ho), np.ravel(d_og), e_ho]))

    def _CalcGoal(self, context: Context, output: BasicVector) -> None:
        body, to_heading = self._heading(context)
        pose = self._poses.Eval(context)[int(self._object_body[self._objects[0]])]
        target = self._targets.Eval(context)[:3]
        rotation = to_heading @ pose.rotation().matrix()
        origin = body.translation()
        output.SetFromVector(
            np.concatenate(
                [
                    to_heading @ (pose.translation() - origin),
                    rotation[:, 0],
                    rotation[:, 1],
                    to_heading @ (target - origin),
                ]
            )
        )


def AddInteractionGraph(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    model: ModelInstanceIndex,
    embodiment: Embodiment,
    objects: dict,
    targets: np.ndarray,
) -> InteractionGraphSystem:
    """Add an `InteractionGraphSystem` named `interaction_graph` over `objects`
    (name in the graph -> body), wired to the plant and scene graph, with
    the objects' target positions from a constant source named
    `object_targets` (an environment rewrites it per episode)."""
    graph = builder.AddNamedSystem("interaction_graph", InteractionGraphSystem(plant, model, embodiment, objects))
    goals = builder.AddNamedSystem("object_targets", ConstantVectorSource(np.ravel(targets).astype(float)))
    builder.Connect(plant.get_body_poses_output_port(), graph.GetInputPort("body_poses"))
    builder.Connect(scene_graph.get_query_output_port(), graph.GetInputPort("geometry_query"))
    builder.Connect(goals.get_output_port(), graph.GetInputPort("object_targets"))
    return graph
