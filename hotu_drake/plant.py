"""The MultibodyPlant side of a simulation diagram.

Adding a robot (optionally on a fixed base, with or without self-collision)
and the floor; the plant's joint and state orderings; setting a robot's
state (standing, dropped, or a reference clip's state); the applied-force
input shared by several systems; and the fall rule that `simulate`, the
environments and the benchmarks all apply (`FallCheck`).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.geometry import Box, Capsule, CollisionFilterDeclaration, Cylinder, GeometrySet, SceneGraph, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import CoulombFriction, ExternallyAppliedSpatialForceMultiplexer, MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import DiagramBuilder, OutputPort

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.spec import FOOT_ROLES
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.rotations import heading_rotation

GROUND_FRICTION = 1.0
FALL_HEIGHT_FRACTION = 0.5  # of the standing pelvis height


def add_ground(plant: MultibodyPlant, friction: float = GROUND_FRICTION, size: float = 40.0) -> None:
    """A flat floor with its top at z = 0 (a thick box: collision and visual)."""
    slab = Box(size, size, 1.0)
    pose = RigidTransform([0.0, 0.0, -0.5])
    plant.RegisterCollisionGeometry(plant.world_body(), pose, slab, "ground", CoulombFriction(friction, friction))
    plant.RegisterVisualGeometry(plant.world_body(), pose, slab, "ground_visual", np.array([0.85, 0.85, 0.82, 1.0]))


def disable_self_collision(plant: MultibodyPlant, scene_graph: SceneGraph, model: ModelInstanceIndex) -> None:
    """Ignore every collision between two bodies of `model`."""
    geometries = GeometrySet()
    for index in plant.GetBodyIndices(model):
        geometries.Add(plant.GetCollisionGeometriesForBody(plant.get_body(index)))
    scene_graph.collision_filter_manager().Apply(CollisionFilterDeclaration().ExcludeWithin(geometries))


def add_robot(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    embodiment: Embodiment,
    *,
    builtin_pd: bool = True,
    self_collision: bool = True,
    fixed_base_height: float | None = None,
) -> ModelInstanceIndex:
    """Add an embodiment before `Finalize` (with the plant's built-in PD
    unless `builtin_pd=False`); a floating root is welded `fixed_base_height`
    metres above the floor when that is given."""
    model = embodiment.add_to_plant(plant, builtin_pd=builtin_pd)
    if fixed_base_height is not None and embodiment.floating_base:
        root = plant.GetBodyByName(embodiment.spec.root.name, model)
        plant.WeldFrames(plant.world_frame(), root.body_frame(), RigidTransform([0.0, 0.0, fixed_base_height]))
    if not self_collision:
        disable_self_collision(plant, scene_graph, model)
    return model


def actuated_joint_order(plant: MultibodyPlant, model: ModelInstanceIndex) -> list[str]:
    """Joint names in the order of the model's actuation and desired-state ports."""
    return [plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices(model)]


def actuated_state_indices(
    plant: MultibodyPlant, model: ModelInstanceIndex, joint_names: list[str]
) -> tuple[np.ndarray, np.ndarray]:
    """Indices of each joint's position and velocity in the model's state vector [q; v]."""
    positions, velocities = [], []
    for index in plant.GetJointIndices(model):
        joint = plant.get_joint(index)
        positions += range(joint.position_start(), joint.position_start() + joint.num_positions())
        velocities += range(joint.velocity_start(), joint.velocity_start() + joint.num_velocities())
    positions, velocities = sorted(positions), sorted(velocities)
    q_index = [positions.index(plant.GetJointByName(n, model).position_start()) for n in joint_names]
    v_index = [velocities.index(plant.GetJointByName(n, model).velocity_start()) for n in joint_names]
    return np.array(q_index), len(positions) + np.array(v_index)


def connect_applied_forces(builder: DiagramBuilder, plant: MultibodyPlant, sources: list[OutputPort]) -> None:
    """Feed every spatial-force output in `sources` into the plant's applied-force input."""
    if len(sources) == 1:
        builder.Connect(sources[0], plant.get_applied_spatial_force_input_port())
    elif sources:
        mux = builder.AddNamedSystem("applied_forces", ExternallyAppliedSpatialForceMultiplexer(len(sources)))
        for i, port in enumerate(sources):
            builder.Connect(port, mux.get_input_port(i))
        builder.Connect(mux.get_output_port(), plant.get_applied_spatial_force_input_port())


def set_robot_state(
    plant: MultibodyPlant,
    plant_context,
    model: ModelInstanceIndex,
    embodiment: Embodiment,
    reference: ClipPlayback | None = None,
    time: float = 0.0,
    drop_height: float = 0.0,
    fixed: bool = False,
    align: bool = False,
) -> None:
    """Put the robot in the standing pose `drop_height` above standing
    height, at rest; or, given a `reference` playback, in the reference
    state (pose and velocities) it plays at `time`. With `align` the
    reference state is moved and turned about z so that the root starts
    over the origin facing +x. A fixed or planar base sets the joints only."""
    positions = plant.GetPositions(plant_context)
    velocities = plant.GetVelocities(plant_context)
    if reference is not None:
        q, v = reference.joints_at(time)
    else:
        q, v = embodiment.standing_pose, np.zeros(len(embodiment.joint_names))
    for name, qi, vi in zip(embodiment.joint_names, q, v):
        joint = plant.GetJointByName(name, model)
        positions[joint.position_start()] = qi
        velocities[joint.velocity_start()] = vi
    plant.SetPositions(plant_context, positions)
    plant.SetVelocities(plant_context, velocities)
    if not embodiment.floating_base or fixed:
        return
    root = plant.GetBodyByName(embodiment.spec.root.name, model)
    if reference is None:
        height = embodiment.standing_root_height + drop_height
        plant.SetFreeBodyPose(plant_context, root, RigidTransform([0.0, 0.0, height]))
        return
    quaternion, position, omega, linear = reference.root_at(time)
    pose = RigidTransform(Quaternion(quaternion), position)
    if align:
        turn = alignment(reference, time)
        yaw = turn.rotation().matrix()
        pose, omega, linear = turn @ pose, yaw @ omega, yaw @ linear
    plant.SetFreeBodyPose(plant_context, root, pose)
    plant.SetFreeBodySpatialVelocity(plant_context, root, SpatialVelocity(omega, linear))


def alignment(reference: ClipPlayback, time: float) -> RigidTransform:
    """The turn about z and the shift that bring a clip's root at `time` over
    the origin facing +x (how a reference start is aligned): the world of
    an aligned start is this transform of the clip's."""
    quaternion, position, _, _ = reference.root_at(time)
    yaw = heading_rotation(RotationMatrix(Quaternion(quaternion)).matrix())
    return RigidTransform(RotationMatrix(yaw.T), -yaw.T @ [position[0], position[1], 0.0])


def placed_under(root: RigidTransform, start: RigidTransform) -> RigidTransform:
    """Where a clip's world goes so that its start, brought over the origin
    facing +x by `start` (`alignment`), lies under the robot's `root` pose
    facing its heading: how a clip is placed for a robot that did not start
    on it (`MotionReference`, the environments' `standing_follow`)."""
    heading = heading_rotation(root.rotation().matrix())
    return RigidTransform(RotationMatrix(heading), [*root.translation()[:2], 0.0]) @ start


def move_free_body(plant: MultibodyPlant, context, body, transform: RigidTransform) -> None:
    """Move a free body's pose and spatial velocity (world) by `transform`:
    a robot's state seen in another frame (a clip's, `alignment`)."""
    pose = plant.GetFreeBodyPose(context, body)
    velocity = plant.EvalBodySpatialVelocityInWorld(context, body)
    turn = transform.rotation().matrix()
    plant.SetFreeBodyPose(context, body, transform @ pose)
    plant.SetFreeBodySpatialVelocity(
        context, body, SpatialVelocity(turn @ velocity.rotational(), turn @ velocity.translational())
    )


def _reach(inspector, geometries) -> float:
    """How far any point of these collision geometries is from their body's origin."""
    far = 0.0
    for geometry in geometries:
        shape = inspector.GetShape(geometry)
        offset = float(np.linalg.norm(inspector.GetPoseInFrame(geometry).translation()))
        if isinstance(shape, Sphere):
            extent = shape.radius()
        elif isinstance(shape, Capsule):
            extent = shape.radius() + 0.5 * shape.length()
        elif isinstance(shape, Cylinder):
            extent = float(np.hypot(shape.radius(), 0.5 * shape.length()))
        elif isinstance(shape, Box):
            extent = 0.5 * float(np.linalg.norm(shape.size()))
        else:  # a mesh or another shape: always ask the query
            return np.inf
        far = max(far, offset + extent)
    return far


class FallCheck:
    """The fall rule: a floating-base robot has fallen when its pelvis is
    below `height_fraction` of its standing height, or a body other than a
    foot touches the floor. The touch is checked on geometry (a floor
    geometry penetrating one of those bodies', the condition for point
    contact), so it costs a collision query, not a contact solve; and the
    query runs only when a body is within reach of the floor (its origin
    lower than the furthest point of its collision shapes), so a robot on
    its feet costs a look at its body poses. A robot on a fixed or planar
    base never falls."""

    def __init__(
        self,
        plant: MultibodyPlant,
        model: ModelInstanceIndex,
        embodiment: Embodiment,
        fixed_base: bool = False,
        height_fraction: float = FALL_HEIGHT_FRACTION,
    ):
        self._plant = plant
        self.can_fall = embodiment.floating_base and not fixed_base
        self.min_pelvis_height = height_fraction * embodiment.standing_pelvis_height
        self._pelvis = plant.GetBodyByName(embodiment.key_bodies["pelvis"], model)
        roles = [r for r in FOOT_ROLES if r in embodiment.key_bodies]
        feet = {plant.GetBodyByName(embodiment.key_bodies[r], model).index() for r in roles}
        self._floor = set(plant.GetCollisionGeometriesForBody(plant.world_body()))
        self._geometries = {
            int(index): plant.GetCollisionGeometriesForBody(plant.get_body(index))
            for index in plant.GetBodyIndices(model)
            if index not in feet and plant.GetCollisionGeometriesForBody(plant.get_body(index))
        }
        self._body = {g for geometries in self._geometries.values() for g in geometries}
        self._pairs = {(f, g) for f in self._floor for g in self._body} | {
            (g, f) for f in self._floor for g in self._body
        }
        self._reach: list[tuple[int, float]] | None = None  # body index, reach (m); from the scene graph on first use

    def pelvis_height(self, plant_context) -> float:
        return float(self._plant.EvalBodyPoseInWorld(plant_context, self._pelvis).translation()[2])

    def touches_floor(self, plant_context) -> bool:
        """Whether a body other than a foot touches the floor."""
        query = self._plant.get_geometry_query_input_port().Eval(plant_context)
        if self._reach is None:
            self._reach = [(index, _reach(query.inspector(), ids)) for index, ids in self._geometries.items()]
        poses = self._plant.get_body_poses_output_port().Eval(plant_context)
        if all(poses[index].translation()[2] > reach for index, reach in self._reach):
            return False  # (the floor's top is at z = 0)
        pairs = self._pairs
        return any((pair.id_A, pair.id_B) in pairs for pair in query.ComputePointPairPenetration())

    def __call__(self, plant_context) -> bool:
        if not self.can_fall:
            return False
        return self.pelvis_height(plant_context) < self.min_pelvis_height or self.touches_floor(plant_context)
