"""Task objects of the method (box, drill, table, a target marker) and the grasp set's objects.

The one home of their shapes and sizes: `OBJECT_MODELS` describes each
object (mass, inertia, primitive shapes); `models/objects/*.sdf` are
generated from it (`python -m hotu_drake.models generate`), and the motion
library, the replays and the task environments read the same numbers.

A scenario places objects with `SceneObject`s; `add_scene_objects` adds
them to a plant (welded or free, with a marker at each target) and
`place_objects` puts the free ones at their start poses.
"""

from dataclasses import dataclass, field

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import PlanarJoint

from hotu_drake.embodiment.formats.common import fmt, vec
from hotu_drake.embodiment.formats.sdf import geometry_sdf
from hotu_drake.embodiment.spec import Geometry, box, cylinder, sphere
from hotu_drake.errors import InputError
from hotu_drake.resources import models_dir
from hotu_drake.rotations import heading_yaw


@dataclass(frozen=True)
class Shape:
    """A named primitive of an object (in the object's frame), its colour,
    and whether it collides or is only seen."""

    name: str
    geometry: Geometry
    color: tuple[float, float, float, float] = (0.72, 0.52, 0.30, 1.0)
    collision: bool = True

    @property
    def half_height(self) -> float:
        """Half the shape's extent along z (an upright box or cylinder, or a sphere)."""
        g = self.geometry
        return g.size[0] if g.shape == "sphere" else g.size[-1] / 2

    @property
    def top(self) -> float:
        """Height of the shape's top in the object's frame."""
        return self.geometry.position[2] + self.half_height

    @property
    def bottom(self) -> float:
        """Height of the shape's bottom in the object's frame."""
        return self.geometry.position[2] - self.half_height


@dataclass(frozen=True)
class ObjectModel:
    """One object: what it is, its mass properties and its shapes."""

    name: str
    description: str
    mass: float
    inertia: tuple[float, float, float]  # ixx, iyy, izz about the centre of mass
    shapes: tuple[Shape, ...]
    center_of_mass: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def shape(self, name: str) -> Shape:
        return next(s for s in self.shapes if s.name == name)


_DARK = (0.15, 0.15, 0.15, 1.0)
_UP = (0.0, 0.0, 1.0)
BOX_SIZE = 0.3  # m, edge of the carry task's cube
OBJECT_MODELS: dict[str, ObjectModel] = {
    "box": ObjectModel(
        "box",
        f"The {BOX_SIZE:g} m, 2 kg box of the method's carry task. Pose = centre, axes along the faces.",
        2.0,
        (0.03, 0.03, 0.03),
        (Shape("body", box((BOX_SIZE,) * 3)),),
    ),
    "drill": ObjectModel(
        "drill",
        "A cordless power drill, 1.3 kg, standing on its battery. Pose = centre of the grip; "
        "x along the barrel, z up the handle.",
        1.3,
        (0.004, 0.006, 0.004),
        (
            Shape("grip", cylinder(0.02, 0.12, (0.0, 0.0, 0.0), _UP), _DARK),
            Shape("barrel", box((0.2, 0.05, 0.06), (0.05, 0.0, 0.08)), (0.9, 0.6, 0.1, 1.0)),
            Shape("battery", box((0.11, 0.07, 0.03), (0.02, 0.0, -0.075)), _DARK),
        ),
        center_of_mass=(0.03, 0.0, 0.04),
    ),
    "table": ObjectModel(
        "table",
        "A 0.6 x 0.8 m table, top 0.72 m high, welded where it is placed. Frame at the floor below the top's centre.",
        15.0,
        (1.0, 1.0, 1.0),
        (
            Shape("top", box((0.6, 0.8, 0.04), (0.0, 0.0, 0.70))),
            Shape("leg", box((0.08, 0.08, 0.68), (0.0, 0.0, 0.34)), (0.5, 0.5, 0.5, 1.0), collision=False),
        ),
        center_of_mass=(0.0, 0.0, 0.5),
    ),
    "target_marker": ObjectModel(
        "target_marker",
        "A visual-only marker of an object's target pose (no collision).",
        0.01,
        (1e-5, 1e-5, 1e-5),
        (Shape("body", box((BOX_SIZE,) * 3), (0.1, 0.8, 0.2, 0.3), collision=False),),
    ),
}


def _solid(
    name: str, like: str, mass: float, geometry: Geometry, color: tuple[float, float, float, float]
) -> ObjectModel:
    """A one-shape object of uniform density: its inertia from its shape. Pose = the shape's centre."""
    if geometry.shape == "box":
        a, b, c = geometry.size
        inertia = (mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12, mass * (a * a + b * b) / 12)
    elif geometry.shape == "cylinder":
        r, h = geometry.size
        side = mass * (3 * r * r + h * h) / 12
        inertia = (side, side, mass * r * r / 2)
    else:
        inertia = (0.4 * mass * geometry.size[0] ** 2,) * 3
    return ObjectModel(
        name,
        f"About YCB's {like} (size and mass approximate). Pose = centre.",
        mass,
        inertia,
        (Shape("body", geometry, color),),
    )


# The grasp set's objects (`motion.library.grasps`): boxes, cans and balls at the sizes and masses of common
# YCB items (approximate), each standing on its largest end; the drill is the task's.
_RED, _BLUE, _YELLOW, _GREEN = (
    (0.75, 0.15, 0.1, 1.0),
    (0.2, 0.35, 0.75, 1.0),
    (0.95, 0.8, 0.2, 1.0),
    (0.3, 0.65, 0.2, 1.0),
)
GRASP_OBJECT_MODELS: dict[str, ObjectModel] = {
    model.name: model
    for model in (
        _solid("sugar_box", "004 sugar box", 0.51, box((0.038, 0.089, 0.175)), _YELLOW),
        _solid("gelatin_box", "009 gelatin box", 0.10, box((0.028, 0.085, 0.073)), _RED),
        _solid("potted_meat_can", "010 potted meat can", 0.37, box((0.050, 0.097, 0.082)), _BLUE),
        _solid("mustard_bottle", "006 mustard bottle", 0.60, box((0.058, 0.095, 0.190)), _YELLOW),
        _solid("soup_can", "005 tomato soup can", 0.35, cylinder(0.0335, 0.102, (0.0, 0.0, 0.0), _UP), _RED),
        _solid("tennis_ball", "056 tennis ball", 0.058, sphere(0.0327), _GREEN),
        _solid("baseball", "055 baseball", 0.15, sphere(0.037), (0.95, 0.95, 0.9, 1.0)),
        _solid("orange", "017 orange", 0.14, sphere(0.036), (0.95, 0.55, 0.1, 1.0)),
        _solid("apple", "013 apple", 0.07, sphere(0.0375), _RED),
    )
}
OBJECT_MODELS |= GRASP_OBJECT_MODELS
GRASP_OBJECTS: tuple[str, ...] = (*GRASP_OBJECT_MODELS, "drill")
OBJECTS: tuple[str, ...] = tuple(OBJECT_MODELS)
TABLE_TOP = OBJECT_MODELS["table"].shape("top").top  # m above the floor
DRILL_BASE = -OBJECT_MODELS["drill"].shape("battery").bottom  # m from the grip centre down to the battery's bottom


def object_kind(name: str) -> str | None:
    """The object model a clip's track `name` is of: the model whose name it
    starts with, in any case (`box`, `Box1`, an OptiTrack `box_small`), or None."""
    lowered = name.lower()
    return next((kind for kind in OBJECTS if lowered.startswith(kind)), None)


def resting_height(name: str) -> float:
    """How far an object's pose sits above the surface it rests on (the
    lowest point of its shapes below the frame; 0 for an unknown track)."""
    kind = object_kind(name)
    if kind is None:
        return 0.0
    return max(0.0, -min(s.bottom for s in OBJECT_MODELS[kind].shapes))


def scale_object_poses(names: list[str], poses: np.ndarray, ratio: float) -> np.ndarray:
    """Object tracks (T, K, 7) for a body `ratio` times the size: positions
    scaled about the world origin as the retargeted root is (x, y by
    `ratio`), heights scaled above each object's resting height so that an
    object on the floor stays on it and one at hand height comes to the
    scaled hands; orientations unchanged."""
    scaled = np.array(poses, dtype=float, copy=True)
    rest = np.array([resting_height(n) for n in names])
    scaled[..., :2] *= ratio
    scaled[..., 2] = rest + (scaled[..., 2] - rest) * ratio
    return scaled


def object_sdf(name: str) -> str:
    """The SDF text of object `name` (what `models/objects/<name>.sdf` holds)."""
    model = OBJECT_MODELS[name]
    ixx, iyy, izz = model.inertia
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- {model.description} -->",
        '<sdf version="1.9">',
        f'  <model name="{name}">',
        f'    <link name="{name}">',
        "      <inertial>",
        f"        <pose>{vec(model.center_of_mass)} 0 0 0</pose>",
        f"        <mass>{fmt(model.mass)}</mass>",
        f"        <inertia><ixx>{fmt(ixx)}</ixx><iyy>{fmt(iyy)}</iyy><izz>{fmt(izz)}</izz>"
        "<ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia>",
        "      </inertial>",
    ]
    for kind in ("visual", "collision"):
        for s in model.shapes:
            if kind == "visual" or s.collision:
                g = s.geometry
                lines += [
                    f'      <{kind} name="{s.name}">',
                    f"        <pose>{vec(g.position)} {vec(g.rpy)}</pose>",
                    f"        <geometry>{geometry_sdf(g)}</geometry>",
                ]
                if kind == "visual":
                    lines.append(f"        <material><diffuse>{vec(s.color)}</diffuse></material>")
                lines.append(f"      </{kind}>")
    lines += ["    </link>", "  </model>", "</sdf>", ""]
    return "\n".join(lines)


@dataclass
class SceneObject:
    """A task object (box, drill, table or target_marker) at `position`
    with `yaw` (rad). `fixed` welds it to the world; `held` keeps a free
    object floating at its start until the robot first touches it (the
    method's box task). A table that is not `fixed` stands on the floor on
    a planar joint (x, y, yaw) damped by `TABLE_DAMPING`: it can be moved
    between episodes and hardly moves when leant on (its legs have no
    collision, so it could not stand free). A `target` (3-D) adds a target
    marker there and is the object's goal in the interaction graph."""

    kind: str = "box"
    name: str = ""
    position: list[float] = field(default_factory=lambda: [0.6, 0.0, 0.8])
    yaw: float = 0.0
    fixed: bool = False
    held: bool = False
    target: list[float] = field(default_factory=list)

    @property
    def instance_name(self) -> str:
        return self.name or self.kind

    @property
    def is_task_object(self) -> bool:
        """A free box or drill: what the interaction graph is about."""
        return self.kind in ("box", "drill") and not self.fixed

    @property
    def is_welded(self) -> bool:
        return self.fixed

    def pose(self) -> RigidTransform:
        """Where the object starts (or is welded): its position, turned by its yaw."""
        return RigidTransform(RollPitchYaw(0.0, 0.0, self.yaw), np.asarray(self.position, dtype=float))


def clip_scene_objects(names: list[str], poses: np.ndarray) -> list[SceneObject]:
    """A clip's objects where they are at one frame (`poses` (K, 7), x y z w x
    y z): a table welded to the floor below its top's centre (the clip's
    table pose), every other object free at its pose, turned by its yaw."""
    objects = []
    for name, pose in zip(names, np.asarray(poses, dtype=float)):
        kind = object_kind(name)
        if kind is None:
            raise InputError(f"object track {name!r} is of no known object ({', '.join(OBJECTS)})", field="objects")
        yaw = float(2.0 * np.arctan2(pose[6], pose[3]))  # (objects of a clip turn about the vertical alone)
        if kind == "table":
            objects.append(SceneObject(kind, name, [float(pose[0]), float(pose[1]), 0.0], yaw, fixed=True))
        else:
            objects.append(SceneObject(kind, name, [float(x) for x in pose[:3]], yaw))
    return objects


def add_object(plant: MultibodyPlant, name: str, instance_name: str | None = None, weld: RigidTransform | None = None):
    """Add a task object to a plant (welded at `weld` if given, else free); returns its model instance."""
    if name not in OBJECTS:
        raise InputError(f"unknown object {name!r}; choose from {', '.join(OBJECTS)}", field="kind")
    parser = Parser(plant, instance_name) if instance_name else Parser(plant)
    (model,) = parser.AddModels(str(models_dir() / "objects" / f"{name}.sdf"))
    if weld is not None:
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(name, model), weld)
    return model


TABLE_DAMPING = (1e5, 1e5, 1e4)  # N s/m along x and y, N m s/rad about z: a table that is not fixed


def add_scene_objects(plant: MultibodyPlant, scene_objects: list[SceneObject]) -> dict:
    """Add a scenario's objects (and a marker at each target) before `Finalize`;
    returns instance name -> model instance."""
    objects = {}
    for obj in scene_objects:
        weld = obj.pose() if obj.is_welded else None
        objects[obj.instance_name] = add_object(plant, obj.kind, obj.instance_name, weld=weld)
        if obj.kind == "table" and weld is None:
            top = plant.GetBodyByName("table", objects[obj.instance_name])
            plant.AddJoint(PlanarJoint("planar", plant.world_frame(), top.body_frame(), np.array(TABLE_DAMPING)))
        if obj.kind == "target_marker" and weld is None:
            plant.set_gravity_enabled(objects[obj.instance_name], False)
        if obj.target:
            marker = target_marker_name(obj)
            objects[marker] = add_object(plant, "target_marker", marker)
            plant.set_gravity_enabled(objects[marker], False)  # visual only: it floats where it is put
    return objects


def target_marker_name(obj: SceneObject) -> str:
    """The instance name of the marker at `obj`'s target (a free, weightless body without collision)."""
    return f"{obj.instance_name}_target"


def object_body(plant: MultibodyPlant, objects: dict, obj: SceneObject):
    """The body of a scene object (`objects`: instance name -> model instance)."""
    return plant.GetBodyByName(obj.kind, objects[obj.instance_name])


def place_objects(plant: MultibodyPlant, plant_context, objects: dict, scene_objects: list[SceneObject]) -> None:
    """Put every free scene object at its start pose, and each target marker at its target."""
    for obj in scene_objects:
        if not obj.is_welded:
            set_object_pose(plant, plant_context, object_body(plant, objects, obj), obj.pose())
        if obj.target:
            place_target_marker(plant, plant_context, objects, obj, obj.target)


def set_object_pose(plant: MultibodyPlant, plant_context, body, pose: RigidTransform) -> None:
    """Put an object that is not welded at `pose`, at rest: a free body, or
    a table on its planar joint (its position's x and y, its yaw)."""
    if body.is_floating_base_body():
        plant.SetFreeBodyPose(plant_context, body, pose)
        plant.SetFreeBodySpatialVelocity(plant_context, body, SpatialVelocity.Zero())
        return
    joint = plant.GetJointByName("planar", body.model_instance())
    joint.set_pose(plant_context, pose.translation()[:2], float(heading_yaw(pose.rotation().matrix())))
    joint.set_translational_velocity(plant_context, np.zeros(2))
    joint.set_angular_velocity(plant_context, 0.0)


def place_target_marker(plant: MultibodyPlant, plant_context, objects: dict, obj: SceneObject, target) -> None:
    """Move the marker of `obj`'s target to `target` (3-D)."""
    marker = plant.GetBodyByName("target_marker", objects[target_marker_name(obj)])
    plant.SetFreeBodyPose(plant_context, marker, RigidTransform(np.asarray(target, dtype=float)))
