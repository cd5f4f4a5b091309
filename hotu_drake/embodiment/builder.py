"""A small builder that turns facts-sheet rows into an `EmbodimentSpec`.

Robot modules describe chains the way the facts sheet lists them: a joint
offset from the previous joint, one or more axes at the same point (each
extra axis gets a light intermediate link), and the child link's shapes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hotu_drake.embodiment.kinematics import balance_over_feet
from hotu_drake.embodiment.spec import (
    SIDES,
    EmbodimentSpec,
    Geometry,
    JointSpec,
    LinkSpec,
    Vec3,
    sphere,
)

# Mass of the light links between the axes of a multi-DoF joint, as a
# fraction of the child link's mass (kept > 0 so every body has inertia).
_INTERMEDIATE_MASS_FRACTION = 0.02
_INTERMEDIATE_MIN_MASS = 1e-3


@dataclass(frozen=True)
class Dof:
    """One axis of a joint: name suffix, world axis, position limits.

    Optional fields override the chain's effort, velocity and gains.
    """

    suffix: str
    axis: Vec3
    lower: float
    upper: float
    effort: float | None = None
    velocity: float | None = None
    kp: float | None = None
    kd: float | None = None
    kind: str = "revolute"


@dataclass(frozen=True)
class Drive:
    """Actuator figures shared by the axes of one chain segment."""

    effort: float
    velocity: float
    kp: float
    kd: float
    armature: float = 0.0
    damping: float = 0.0


def side_sign(side: str) -> float:
    """+1 for the left side (y > 0), -1 for the right side."""
    return {"left": 1.0, "right": -1.0}[side]


def pick(side: str, right, left):
    """The facts sheet lists right and left values; choose one."""
    return left if side == "left" else right


def mirror_limits(side: str, lower: float, upper: float) -> tuple[float, float]:
    """Right-side limits as given; left side mirrored (roll and yaw axes)."""
    return (lower, upper) if side == "right" else (-upper, -lower)


class SpecBuilder:
    """Accumulates links and joints with world-aligned frames."""

    def __init__(self, name: str, title: str, hands: str) -> None:
        if hands not in ("full", "none"):
            raise ValueError(f"hands must be 'full' or 'none', not {hands!r}")
        self.name, self.title, self.hands = name, title, hands
        self.links: list[LinkSpec] = []
        self.joints: list[JointSpec] = []
        self._origin: dict[str, np.ndarray] = {"world": np.zeros(3)}
        self.hand_mounts: dict[str, tuple[str, np.ndarray, np.ndarray]] = {}

    def origin(self, link: str) -> np.ndarray:
        """World position of a link's frame at q = 0."""
        return self._origin[link].copy()

    def add_link(
        self,
        name: str,
        mass: float,
        part: str,
        origin: Vec3 | np.ndarray,
        visuals: list[Geometry],
        collisions: list[Geometry] | None = None,
        side: str = "",
    ) -> LinkSpec:
        origin = np.asarray(origin, dtype=float)
        link = LinkSpec(
            name=name,
            mass=mass,
            part=part,
            side=side,
            visuals=list(visuals),
            collisions=list(collisions or []),
            origin=tuple(float(x) for x in origin),
        )
        self.links.append(link)
        self._origin[name] = origin
        return link

    def root(self, name: str, mass: float, part: str, visuals, collisions=None) -> LinkSpec:
        return self.add_link(name, mass, part, (0.0, 0.0, 0.0), visuals, collisions)

    def chain(
        self,
        parent: str,
        child: str,
        offset: Vec3,
        dofs: list[Dof],
        drive: Drive,
        part: str,
        mass: float,
        visuals: list[Geometry],
        collisions: list[Geometry] | None = None,
        side: str = "",
        prefix: str | None = None,
    ) -> LinkSpec:
        """Add one or more joints at `offset` from `parent`, ending in `child`.

        Joint names are `<prefix>_<suffix>`; the prefix defaults to
        `<side>_<part>` (or `<part>` for central joints).
        """
        if prefix is None:
            prefix = f"{side}_{part}" if side else part
        position = self._origin[parent] + np.asarray(offset, dtype=float)
        current = parent
        # The light links between axes take their mass out of the child's.
        light = max(_INTERMEDIATE_MASS_FRACTION * mass, _INTERMEDIATE_MIN_MASS)
        child_mass = mass - light * (len(dofs) - 1)
        for i, dof in enumerate(dofs):
            last = i == len(dofs) - 1
            joint_name = f"{prefix}_{dof.suffix}"
            if last:
                self.add_link(child, child_mass, part, position, visuals, collisions, side)
                link_name = child
            else:
                link_name = f"{joint_name}_link"
                radius = 0.01 if mass > 0.5 else 0.003
                self.add_link(link_name, light, part, position, [sphere(radius)], [], side)
            joint_offset = position - self._origin[current]
            self.joints.append(
                JointSpec(
                    name=joint_name,
                    kind=dof.kind,
                    parent=current,
                    child=link_name,
                    offset=tuple(float(x) for x in joint_offset),
                    axis=dof.axis,
                    lower=dof.lower,
                    upper=dof.upper,
                    effort=dof.effort if dof.effort is not None else drive.effort,
                    velocity=dof.velocity if dof.velocity is not None else drive.velocity,
                    kp=dof.kp if dof.kp is not None else drive.kp,
                    kd=dof.kd if dof.kd is not None else drive.kd,
                    part=part,
                    side=side,
                    armature=drive.armature,
                    damping=drive.damping,
                )
            )
            current = link_name
        return self.links[-1]

    def build(
        self,
        key_bodies: dict[str, str],
        standing_pose: dict[str, float],
        floating_base: bool = True,
        notes: str = "",
    ) -> EmbodimentSpec:
        spec = EmbodimentSpec(
            name=self.name,
            title=self.title,
            links=self.links,
            joints=self.joints,
            key_bodies=key_bodies,
            standing_pose={k: v for k, v in standing_pose.items() if k in self._joint_set()},
            floating_base=floating_base,
            hands=self.hands,
            notes=notes,
            hand_mounts=dict(self.hand_mounts),
        )
        if floating_base and {"left_foot", "right_foot"} <= key_bodies.keys():
            spec.standing_pose = balance_over_feet(spec)
        spec.validate()
        return spec

    def _joint_set(self) -> set[str]:
        return {j.name for j in self.joints}


def mirror_point(p: np.ndarray | Vec3) -> np.ndarray:
    """Reflect a position through the sagittal (x-z) plane."""
    x, y, z = p
    return np.array([x, -y, z], dtype=float)


def mirror_axis(a: np.ndarray | Vec3) -> np.ndarray:
    """Reflect a rotation axis (a pseudo-vector) through the x-z plane.

    A joint with the mirrored axis and the same limits moves as the mirror
    image of the original.
    """
    x, y, z = a
    return np.array([-x, y, -z], dtype=float)


def key_bodies(pelvis: str, torso: str, head: str, legs: bool = True) -> dict[str, str]:
    """A robot's key bodies: its pelvis, torso and head links, and the hand
    and foot links, which every spec names `left_hand`, `right_foot`, ..."""
    bodies = {"pelvis": pelvis, "torso": torso, "head": head, "left_hand": "left_hand", "right_hand": "right_hand"}
    if legs:
        bodies |= {"left_foot": "left_foot", "right_foot": "right_foot"}
    return bodies


def mirrored_pose(per_side: Callable[[str], dict[str, float]]) -> dict[str, float]:
    """A standing pose given one side at a time: `per_side(side)` maps that
    side's joint names to angles (left first, then right)."""
    return {joint: angle for side in SIDES for joint, angle in per_side(side).items()}
