"""ObjectHolder: keeps free task objects floating until the robot touches them.

The method's box task starts with the box in mid-air in front of the
character. A held object gets a force that cancels its weight; the first
time any body of the robot touches it, it is released (latched in discrete
state) and falls or is carried like any free body.
"""

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import QueryObject
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
from pydrake.systems.framework import LeafSystem

GRAVITY = 9.81


class ObjectHolder(LeafSystem):
    """Input port `geometry_query` (the scene graph's query output); output
    ports `spatial_forces` (to the plant's applied spatial force input) and
    `released` (1 per object once it has been touched)."""

    def __init__(self, plant: MultibodyPlant, robot_model, bodies: list, check_period: float = 1.0 / 30.0):
        super().__init__()
        self._bodies = [b.index() for b in bodies]
        self._weights = [b.default_mass() * GRAVITY for b in bodies]
        self._centres = [np.asarray(b.default_com()) for b in bodies]
        self._object_geometries = [set(plant.GetCollisionGeometriesForBody(b)) for b in bodies]
        self._robot_geometries = {
            g for i in plant.GetBodyIndices(robot_model) for g in plant.GetCollisionGeometriesForBody(plant.get_body(i))
        }
        self.DeclareAbstractInputPort("geometry_query", Value(QueryObject()))
        self._released = self.DeclareDiscreteState(len(bodies))
        self.DeclarePeriodicDiscreteUpdateEvent(check_period, 0.0, self._Update)
        self.DeclareAbstractOutputPort(
            "spatial_forces",
            lambda: Value[list[ExternallyAppliedSpatialForce]]([]),
            self._CalcForces,
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclareStateOutputPort("released", self._released)

    def _Update(self, context, discrete_state) -> None:
        released = context.get_discrete_state(self._released).get_value().copy()
        if released.all():
            return
        query = self.get_input_port(0).Eval(context)
        robot = self._robot_geometries
        for pair in query.ComputePointPairPenetration():
            a, b = pair.id_A, pair.id_B
            for k, mine in enumerate(self._object_geometries):
                if (a in mine and b in robot) or (b in mine and a in robot):
                    released[k] = 1.0
        discrete_state.set_value(self._released, released)

    def _CalcForces(self, context, output) -> None:
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
