"""Perturbation: cubes thrown at the robot, as in the method's stability test.

The cubes are real bodies with contact, added to the plant by
`add_perturbation_cubes`. Each waits at its launch point, held against
gravity, until its launch time; during the plant step that starts then, an
impulse gives it the chosen speed toward the robot's target body (aimed at
where that body is at launch). After that it flies freely.
"""

from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import Value
from pydrake.geometry import Box
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import CoulombFriction, ExternallyAppliedSpatialForce, MultibodyPlant
from pydrake.multibody.tree import SpatialInertia, UnitInertia
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem


@dataclass
class CubeLaunch:
    """One throw: when, from where (world), how fast, how heavy, how big, and
    how far above the target body's origin it is aimed."""

    time: float = 1.0
    start: list[float] = field(default_factory=lambda: [1.5, 0.0, 1.0])
    speed: float = 4.0
    mass: float = 1.0
    size: float = 0.1
    aim_height: float = 0.0


def add_perturbation_cubes(plant: MultibodyPlant, launches: list[CubeLaunch]) -> list:
    """Add one free cube per launch (before `Finalize`); returns their bodies."""
    if not launches:
        return []
    bodies = []
    cubes = plant.AddModelInstance("perturbation_cubes")
    for i, launch in enumerate(launches):
        inertia = SpatialInertia(launch.mass, np.zeros(3), UnitInertia.SolidCube(launch.size))
        body = plant.AddRigidBody(f"perturbation_cube_{i}", cubes, inertia)
        shape = Box(launch.size, launch.size, launch.size)
        plant.RegisterCollisionGeometry(body, RigidTransform(), shape, f"cube_{i}", CoulombFriction(0.6, 0.6))
        plant.RegisterVisualGeometry(body, RigidTransform(), shape, f"cube_{i}", np.array([0.9, 0.2, 0.2, 1.0]))
        bodies.append(body)
    return bodies


def place_perturbation_cubes(plant: MultibodyPlant, plant_context, bodies: list, launches: list[CubeLaunch]) -> None:
    """Put every cube at its launch point, at rest (call on the initial context)."""
    for body, launch in zip(bodies, launches):
        plant.SetFreeBodyPose(plant_context, body, RigidTransform(np.asarray(launch.start, dtype=float)))


class Perturbation(LeafSystem):
    """Throws the cubes: holds each up until its launch, then one impulse.

    .. pydrake_system::

        name: Perturbation
        input_ports:
        - body_poses
        output_ports:
        - spatial_forces

    `body_poses` is the plant's; `spatial_forces` goes to the plant's
    applied spatial force input.
    """

    def __init__(self, plant: MultibodyPlant, bodies: list, launches: list[CubeLaunch], target_body, time_step: float):
        super().__init__()
        self._gravity = -float(plant.gravity_field().gravity_vector()[2])
        self._bodies = [b.index() for b in bodies]
        self._launches = launches
        self._target = target_body.index()
        self._dt = time_step
        self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self.DeclareAbstractOutputPort(
            "spatial_forces", lambda: Value[list[ExternallyAppliedSpatialForce]]([]), self._CalcForces
        )

    def _CalcForces(self, context: Context, output) -> None:
        now = context.get_time()
        poses = self._poses.Eval(context)
        forces = []
        for index, launch in zip(self._bodies, self._launches):
            if now < launch.time - 1e-9:  # waiting: hold it up
                force = np.array([0.0, 0.0, launch.mass * self._gravity])
            elif now < launch.time + self._dt - 1e-9:  # this step: the throw
                target = poses[int(self._target)].translation() + [0.0, 0.0, launch.aim_height]
                aim = target - poses[int(index)].translation()
                velocity = launch.speed * aim / max(np.linalg.norm(aim), 1e-9)
                force = launch.mass * velocity / self._dt + np.array([0.0, 0.0, launch.mass * self._gravity])
            else:
                continue
            applied = ExternallyAppliedSpatialForce()
            applied.body_index = index
            applied.p_BoBq_B = np.zeros(3)
            applied.F_Bq_W = SpatialForce(np.zeros(3), force)
            forces.append(applied)
        output.set_value(forces)


def AddPerturbation(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    cubes: list,
    launches: list[CubeLaunch],
    target_body,
    time_step: float,
) -> Perturbation:
    """Add a `Perturbation` named `perturbation` throwing `cubes` (added by
    `add_perturbation_cubes`) at `target_body`; connect its
    `spatial_forces` to the plant (`plant.connect_applied_forces`)."""
    thrower = builder.AddNamedSystem("perturbation", Perturbation(plant, cubes, launches, target_body, time_step))
    builder.Connect(plant.get_body_poses_output_port(), thrower.GetInputPort("body_poses"))
    return thrower
