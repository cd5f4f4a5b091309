"""`Embodiment`: a built spec plus what the rest of the pipeline asks of it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from hotu_drake.embodiment.formats.mjcf import to_mjcf
from hotu_drake.embodiment.formats.sdf import to_sdf
from hotu_drake.embodiment.formats.urdf import to_urdf
from hotu_drake.embodiment.kinematics import link_poses, lowest_collision_point
from hotu_drake.embodiment.robots import bruce, curi, h1, naviai, udh, walker
from hotu_drake.embodiment.spec import FINGER_PART, EmbodimentSpec
from hotu_drake.errors import InputError

EMBODIMENT_NAMES: tuple[str, ...] = ("udh", "naviai", "h1", "bruce", "walker", "curi")
HANDS_VARIANTS: tuple[str, ...] = ("full", "none")
_BUILDERS: dict[str, Callable[..., EmbodimentSpec]] = {
    "udh": udh.build,
    "naviai": naviai.build,
    "h1": h1.build,
    "bruce": bruce.build,
    "walker": walker.build,
    "curi": curi.build,
}
EXPORT_FORMATS: dict[str, Callable[[EmbodimentSpec], str]] = {
    "sdf": to_sdf,
    "urdf": to_urdf,
    "mjcf": to_mjcf,
}
# Where a model file for each format goes under models/ (and its suffix).
EXPORT_SUFFIX = {"sdf": ".sdf", "urdf": ".urdf", "mjcf": ".xml"}


def build_spec(name: str, hands: str = "full", **options) -> EmbodimentSpec:
    """Build the spec of embodiment `name` (`height=` and `mass=` for the UDH)."""
    if name not in _BUILDERS:
        raise InputError(f"unknown embodiment {name!r}; choose from {', '.join(EMBODIMENT_NAMES)}", field="embodiment")
    if hands not in HANDS_VARIANTS:
        raise InputError(f"hands must be one of {HANDS_VARIANTS}, not {hands!r}", field="hands")
    if options and name != "udh":
        raise InputError(f"{name} takes no options (only the UDH takes height and mass)", field="options")
    return _BUILDERS[name](hands, **options)


@dataclass
class Embodiment:
    """One robot (or the UDH): parts, key bodies, limits, pose, model text."""

    spec: EmbodimentSpec

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def hands(self) -> str:
        return self.spec.hands

    @property
    def floating_base(self) -> bool:
        return self.spec.floating_base

    @property
    def joint_names(self) -> list[str]:
        """Actuated joints in model order (CURI's base joints first)."""
        return self.spec.joint_names

    @cached_property
    def parts(self) -> dict[str, list[str]]:
        """Functional part -> joint names (parts the robot lacks are empty)."""
        return self.spec.parts()

    @cached_property
    def part_dof(self) -> dict[str, int]:
        return self.spec.part_dof()

    @property
    def base_joints(self) -> list[str]:
        """Actuated joints outside the body parts (CURI's x, y, yaw)."""
        named = {n for names in self.parts.values() for n in names}
        return [n for n in self.joint_names if n not in named]

    @property
    def finger_joints(self) -> list[str]:
        return self.parts[FINGER_PART]

    @property
    def key_bodies(self) -> dict[str, str]:
        """Role (pelvis, torso, head, hands, feet) -> link name."""
        return dict(self.spec.key_bodies)

    @cached_property
    def position_lower(self) -> np.ndarray:
        return np.array([j.lower for j in self.spec.joints])

    @cached_property
    def position_upper(self) -> np.ndarray:
        return np.array([j.upper for j in self.spec.joints])

    @cached_property
    def velocity_limits(self) -> np.ndarray:
        return np.array([j.velocity for j in self.spec.joints])

    @cached_property
    def effort_limits(self) -> np.ndarray:
        return np.array([j.effort for j in self.spec.joints])

    @cached_property
    def kp(self) -> np.ndarray:
        return np.array([j.kp for j in self.spec.joints])

    @cached_property
    def kd(self) -> np.ndarray:
        return np.array([j.kd for j in self.spec.joints])

    @cached_property
    def standing_pose(self) -> np.ndarray:
        """Default standing joint positions, in `joint_names` order."""
        return np.array([self.spec.standing_pose.get(n, 0.0) for n in self.joint_names])

    def standing_pose_dict(self) -> dict[str, float]:
        return dict(zip(self.joint_names, self.standing_pose.tolist()))

    @cached_property
    def standing_root_height(self) -> float:
        """Root-link height that puts the feet on the floor in the standing pose."""
        if not self.floating_base:
            return 0.0
        feet = [self.spec.key_bodies[f] for f in ("left_foot", "right_foot")]
        return -lowest_collision_point(self.spec, self.standing_pose_dict(), feet)

    @cached_property
    def standing_pelvis_height(self) -> float:
        """Nominal pelvis height standing on the floor."""
        poses = link_poses(self.spec, self.standing_pose_dict(), (0.0, 0.0, self.standing_root_height))
        return float(poses[self.key_bodies["pelvis"]][1][2])

    def model_text(self, fmt: str = "sdf") -> str:
        """The model file as text: `sdf`, `urdf` or `mjcf`."""
        if fmt not in EXPORT_FORMATS:
            raise ValueError(f"unknown format {fmt!r}; choose from {', '.join(EXPORT_FORMATS)}")
        return EXPORT_FORMATS[fmt](self.spec)

    def add_to_plant(self, plant, model_name_prefix: str = "", builtin_pd: bool = True):
        """Parse this embodiment into a (not yet finalized) MultibodyPlant.

        Returns the new model instance. Registers geometry when the plant
        is connected to a SceneGraph. `builtin_pd=False` leaves out the
        plant's implicit PD, for an explicit controller on the actuation
        input (Drake's PD-controlled actuators would absorb that input).
        """
        from pydrake.multibody.parsing import Parser

        from hotu_drake.embodiment.formats.sdf import to_sdf

        parser = Parser(plant, model_name_prefix) if model_name_prefix else Parser(plant)
        (model,) = parser.AddModelsFromString(to_sdf(self.spec, controller_gains=builtin_pd), "sdf")
        return model

    def __repr__(self) -> str:
        return f"Embodiment({self.name!r}, hands={self.hands!r}, dof={self.part_dof['total']})"


def load(name: str, hands: str = "full", **options) -> Embodiment:
    """Load an embodiment by name: udh, naviai, h1, bruce, walker or curi.

    `hands="none"` removes the finger joints; the UDH also takes `height`
    (metres) and `mass` (kg) to size it to a performer.
    """
    return Embodiment(build_spec(name, hands, **options))
