"""ObjectHolder: keeps free task objects floating until the robot touches them.

The method's box task starts with the box in mid-air in front of the
character. A held object gets a force that cancels its weight; the first
time any body of the robot touches it, it is released (latched in discrete
state) and falls or is carried like any free body.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import QueryObject, SceneGraph
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem


class ObjectHolder(LeafSystem):
    """Holds free objects up until the robot touches them.

    .. pydrake_system::

        name: ObjectHolder
        input_ports:
        - geometry_query
        output_ports:
        - spatial_forces
        - released

    `geometry_query` is the scene graph's query output; `spatial_forces`
    goes to the plant's applied spatial force input; `released` is 1 per
    object once it has been touched (discrete state, checked every
    `check_period`).
    """

    def __init__(self, plant: MultibodyPlant, robot_model, bodies: list, check_period: float = 1.0 / 30.0):
        super().__init__()
        gravity = -float(plant.gravity_field().gravity_vector()[2])
        self._bodies = [b.index() for b in bodies]
        self._weights = [b.default_mass() * gravity for b in bodies]
        self._centres = [np.asarray(b.default_com()) for b in bodies]
        self._object_geometries = [set(plant.GetCollisionGeometriesForBody(b)) for b in bodies]
        self._robot_geometries = {
            g for i in plant.GetBodyIndices(robot_model) for g in plant.GetCollisionGeometriesForBody(plant.get_body(i))
        }
        self._query = self.DeclareAbstractInputPort("geometry_query", Value(QueryObject()))
        self._released = self.DeclareDiscreteState(len(bodies))
        self.DeclarePeriodicDiscreteUpdateEvent(check_period, 0.0, self._Update)
        self.DeclareAbstractOutputPort(
            "spatial_forces",
            lambda: Value[list[ExternallyAppliedSpatialForce]]([]),
            self._CalcForces,
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclareStateOutputPort("released", self._released)

    def _Update(self, context: Context, discrete_state) -> None:
        released = context.get_discrete_state(self._released).get_value().copy()
        if released.all():
            return
        query = self._query.Eval(context)
        robot = self._robot_geometries
        for pair in query.ComputePointPairPenetration():
            a, b = pair.id_A, pair.id_B
            for k, mine in enumerate(self._object_geometries):
                if (a in mine and b in robot) or (b in mine and a in robot):
                    released[k] = 1.0
        discrete_state.set_value(self._released, released)

    def _CalcForces(self, context: Context, output) -> None:
        released = context.get_discrete_state(self._released).get_value()
        forces = []
        for body, weight, centre, done in zip(self._bodies, self._weights, self._centres, released):
            if done:
                continue
            applied = ExternallyAppliedSpatialForce()
            applied.body_index = body
            applied.p_BoBq_B = centre  # at the centre of mass: no torque
            applied.F_Bq_W = SpatialForce(np.zeros(3), np.array([0.0, 0.0, weight]))
            forces.append(applied)
        output.set_value(forces)


def AddObjectHolder(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    robot_model: ModelInstanceIndex,
    bodies: list,
    check_period: float,
) -> ObjectHolder:
    """Add an `ObjectHolder` named `object_holder` for `bodies`, reading the
    scene graph's queries; connect its `spatial_forces` to the plant
    (`plant.connect_applied_forces`)."""
    holder = builder.AddNamedSystem("object_holder", ObjectHolder(plant, robot_model, bodies, check_period))
    builder.Connect(scene_graph.get_query_output_port(), holder.GetInputPort("geometry_query"))
    return holder
