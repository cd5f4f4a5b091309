"""Declarative embodiment specs: links, joints, functional parts, key bodies.

Every link frame is world-aligned at the zero configuration (q = 0), so a
joint is fully described by its position relative to the parent link's
origin and a unit axis expressed in the world frame. That convention, taken
from the facts sheet, makes the exporters (SDF, URDF, MJCF) trivial and the
axes directly comparable across robots.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

Vec3 = tuple[float, float, float]

# The functional parts of the method (Table I), in a fixed order.
FINGER_PART = "finger"
PARTS: tuple[str, ...] = (
    "neck",
    "torso",
    "shoulder",
    "elbow",
    "wrist",
    "finger",
    "hip",
    "knee",
    "ankle",
)
# Joints that move the robot but are not a body part (CURI's holonomic base).
BASE_PART = "base"
SIDES: tuple[str, ...] = ("left", "right")
FINGERS: tuple[str, ...] = ("thumb", "index", "middle", "ring", "little")
HAND_ROLES: tuple[str, ...] = ("left_hand", "right_hand")
FOOT_ROLES: tuple[str, ...] = ("left_foot", "right_foot")
KEY_BODY_ROLES: tuple[str, ...] = (
    "pelvis",
    "torso",
    "head",
    "left_hand",
    "right_hand",
    "left_foot",
    "right_foot",
)


@dataclass(frozen=True)
class Geometry:
    """A primitive shape placed in a link frame.

    Sizes: box = full extents (x, y, z); sphere = (radius,);
    capsule and cylinder = (radius, length) with the axis along local z.
    """

    shape: str
    size: tuple[float, ...]
    position: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        expected = {"box": 3, "sphere": 1, "capsule": 2, "cylinder": 2}
        if self.shape not in expected:
            raise ValueError(f"unknown shape {self.shape!r}")
        if len(self.size) != expected[self.shape] or min(self.size) <= 0:
            raise ValueError(f"bad size {self.size} for a {self.shape}")

    def volume(self) -> float:
        if self.shape == "box":
            x, y, z = self.size
            return x * y * z
        if self.shape == "sphere":
            return 4.0 / 3.0 * math.pi * self.size[0] ** 3
        r, length = self.size
        cylinder = math.pi * r * r * length
        if self.shape == "cylinder":
            return cylinder
        return cylinder + 4.0 / 3.0 * math.pi * r**3

    def unit_inertia_local(self) -> np.ndarray:
        """Rotational inertia per unit mass about the centre, local axes."""
        if self.shape == "box":
            x, y, z = self.size
            return np.diag([y * y + z * z, x * x + z * z, x * x + y * y]) / 12.0
        if self.shape == "sphere":
            return np.eye(3) * 0.4 * self.size[0] ** 2
        r, length = self.size
        if self.shape == "cylinder":
            transverse = (3 * r * r + length * length) / 12.0
            return np.diag([transverse, transverse, 0.5 * r * r])
        # Capsule: cylinder plus two hemispheres, mass split by volume.
        v_cyl = math.pi * r * r * length
        v_sph = 4.0 / 3.0 * math.pi * r**3
        m_cyl, m_sph = v_cyl / (v_cyl + v_sph), v_sph / (v_cyl + v_sph)
        axial = m_cyl * 0.5 * r * r + m_sph * 0.4 * r * r
        transverse = m_cyl * (3 * r * r + length * length) / 12.0 + m_sph * (
            0.4 * r * r + 0.25 * length * length + 0.375 * length * r
        )
        return np.diag([transverse, transverse, axial])

    def rotation(self) -> np.ndarray:
        return rotation_from_rpy(self.rpy)


def rotation_from_rpy(rpy: Vec3) -> np.ndarray:
    """Rotation matrix of fixed-axis roll, pitch, yaw (URDF/SDF convention)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def rpy_aligning_z_to(direction: np.ndarray) -> Vec3:
    """Roll-pitch-yaw of a frame whose z axis points along `direction`."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    pitch = math.atan2(math.hypot(d[0], d[1]), d[2])
    yaw = math.atan2(d[1], d[0]) if math.hypot(d[0], d[1]) > 1e-12 else 0.0
    return (0.0, pitch, yaw)


def box(size: Vec3, center: Vec3 = (0.0, 0.0, 0.0)) -> Geometry:
    return Geometry("box", tuple(size), tuple(center))


def sphere(radius: float, center: Vec3 = (0.0, 0.0, 0.0)) -> Geometry:
    return Geometry("sphere", (radius,), tuple(center))


def capsule(radius: float, start: Vec3, end: Vec3) -> Geometry:
    """A capsule whose segment runs from `start` to `end` (link frame)."""
    a, b = np.asarray(start, float), np.asarray(end, float)
    mid = tuple(float(x) for x in (a + b) / 2)
    return Geometry("capsule", (radius, float(np.linalg.norm(b - a))), mid, rpy_aligning_z_to(b - a))


def cylinder(radius: float, length: float, center: Vec3, axis: Vec3) -> Geometry:
    return Geometry("cylinder", (radius, length), tuple(center), rpy_aligning_z_to(np.asarray(axis)))


@dataclass
class LinkSpec:
    """A rigid body. Mass is spread over `visuals` by volume for the inertia."""

    name: str
    mass: float
    part: str
    side: str = ""
    visuals: list[Geometry] = field(default_factory=list)
    collisions: list[Geometry] = field(default_factory=list)
    origin: Vec3 = (0.0, 0.0, 0.0)  # world position of the link frame at q = 0

    def mass_properties(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre of mass (link frame) and rotational inertia about it."""
        shapes = self.visuals or self.collisions
        if not shapes:
            raise ValueError(f"link {self.name} has no shape to carry its mass")
        volumes = np.array([g.volume() for g in shapes])
        masses = self.mass * volumes / volumes.sum()
        centers = np.array([g.position for g in shapes], dtype=float)
        com = masses @ centers / self.mass
        inertia = np.zeros((3, 3))
        for g, m, c in zip(shapes, masses, centers):
            rot = g.rotation()
            d = c - com
            inertia += m * rot @ g.unit_inertia_local() @ rot.T
            inertia += m * (d @ d * np.eye(3) - np.outer(d, d))
        return com, inertia


@dataclass
class JointSpec:
    """A 1-DoF actuated joint (revolute or prismatic).

    `offset` is the joint's position relative to the parent link's origin;
    the child link's origin sits at the joint. `axis` is a unit vector in
    the world frame at q = 0 (equal to the parent and child frame axes).
    """

    name: str
    kind: str
    parent: str
    child: str
    offset: Vec3
    axis: Vec3
    lower: float
    upper: float
    effort: float
    velocity: float
    kp: float
    kd: float
    part: str
    side: str = ""
    armature: float = 0.0
    damping: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("revolute", "prismatic"):
            raise ValueError(f"joint {self.name}: unknown kind {self.kind!r}")
        if not self.lower < self.upper:
            raise ValueError(f"joint {self.name}: lower limit must be below upper")
        if self.effort <= 0 or self.velocity <= 0:
            raise ValueError(f"joint {self.name}: effort and velocity must be > 0")
        n = float(np.linalg.norm(self.axis))
        self.axis = tuple(float(a) / n for a in self.axis)


@dataclass
class EmbodimentSpec:
    """A whole robot: links (root first), joints, parts and named bodies."""

    name: str
    title: str
    links: list[LinkSpec]
    joints: list[JointSpec]
    key_bodies: dict[str, str]
    standing_pose: dict[str, float]
    floating_base: bool = True
    hands: str = "full"
    notes: str = ""
    # side -> (hand model, 3x3 map from the hand model's frame to the world at
    # q = 0 (mirrored on the left), hand root position in the world at q = 0).
    hand_mounts: dict[str, tuple[str, np.ndarray, np.ndarray]] = field(default_factory=dict)

    @property
    def root(self) -> LinkSpec:
        return self.links[0]

    def link(self, name: str) -> LinkSpec:
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(f"{self.name}: no link named {name!r}")

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    def parts(self) -> dict[str, list[str]]:
        """Functional part -> joint names, in joint order (base excluded)."""
        out: dict[str, list[str]] = {p: [] for p in PARTS}
        for j in self.joints:
            if j.part != BASE_PART:
                out[j.part].append(j.name)
        return out

    def part_dof(self) -> dict[str, int]:
        """Per-part DoF plus "total" (the base is not counted)."""
        counts = {p: len(names) for p, names in self.parts().items()}
        counts["total"] = sum(counts.values())
        return counts

    def validate(self) -> None:
        """Raise ValueError on any inconsistency in the tree or names."""
        names = [link.name for link in self.links]
        if len(set(names)) != len(names):
            raise ValueError(f"{self.name}: duplicate link names")
        if len(set(self.joint_names)) != len(self.joint_names):
            raise ValueError(f"{self.name}: duplicate joint names")
        children = [j.child for j in self.joints]
        if len(set(children)) != len(children):
            raise ValueError(f"{self.name}: a link has two parent joints")
        valid_parents = set(names) | ({"world"} if not self.floating_base else set())
        for j in self.joints:
            if j.parent not in valid_parents or j.child not in names:
                raise ValueError(f"{self.name}: joint {j.name} has unknown links")
            if j.part not in PARTS and j.part != BASE_PART:
                raise ValueError(f"{self.name}: joint {j.name} has unknown part")
        for role, body in self.key_bodies.items():
            if role not in KEY_BODY_ROLES or body not in names:
                raise ValueError(f"{self.name}: bad key body {role}={body}")
        limits = {j.name: (j.lower, j.upper) for j in self.joints}
        for joint, q in self.standing_pose.items():
            lo, hi = limits[joint]
            if not lo <= q <= hi:
                raise ValueError(f"{self.name}: standing pose of {joint} outside limits")


# Colours of the functional parts (RGBA), used by every exporter and the gallery.
PART_COLORS: dict[str, tuple[float, float, float, float]] = {
    "pelvis": (0.55, 0.55, 0.58, 1.0),
    "base": (0.35, 0.35, 0.38, 1.0),
    "torso": (0.20, 0.47, 0.75, 1.0),
    "neck": (0.95, 0.75, 0.20, 1.0),
    "shoulder": (0.90, 0.35, 0.25, 1.0),
    "elbow": (0.95, 0.55, 0.15, 1.0),
    "wrist": (0.60, 0.35, 0.75, 1.0),
    "finger": (0.90, 0.45, 0.70, 1.0),
    "hip": (0.20, 0.65, 0.40, 1.0),
    "knee": (0.45, 0.75, 0.25, 1.0),
    "ankle": (0.15, 0.60, 0.60, 1.0),
}
