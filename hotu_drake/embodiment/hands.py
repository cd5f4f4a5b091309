"""The two hand models of the method: the qb SoftHand and the Walker hand.

Hands are described in a hand frame (right hand): fingers along +z for the
qb SoftHand and +x for the Walker hand, palm normal +y. A robot mounts a
hand by giving the rotation from that frame to the world at q = 0; the left
hand is the mirror image of the right one through the sagittal plane.
Joint names are `<side>_<finger>_<index>` (e.g. `right_index_2`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hotu_drake.embodiment.builder import Dof, Drive, SpecBuilder, mirror_axis, mirror_point
from hotu_drake.embodiment.spec import FINGER_PART, Geometry, capsule, rpy_aligning_z_to

_M = np.diag([1.0, -1.0, 1.0])  # reflection through the x-z plane


def rpy_from_rotation(rotation: np.ndarray) -> tuple[float, float, float]:
    """Fixed-axis roll, pitch, yaw of a rotation matrix."""
    r = np.asarray(rotation)
    pitch = math.asin(-max(-1.0, min(1.0, r[2, 0])))
    if abs(math.cos(pitch)) > 1e-9:
        roll = math.atan2(r[2, 1], r[2, 2])
        yaw = math.atan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: put everything in yaw
        roll, yaw = 0.0, math.atan2(-r[0, 1], r[1, 1])
    return (roll, pitch, yaw)


@dataclass(frozen=True)
class HandFrame:
    """Where a right hand sits: hand-frame -> world rotation at q = 0."""

    rotation: np.ndarray

    def place(self, side: str, origin, p_hand) -> np.ndarray:
        """World position of a hand-frame point, relative to `origin`."""
        p = self.rotation @ np.asarray(p_hand, dtype=float)
        return origin + (mirror_point(p) if side == "left" else p)

    def direction(self, side: str, v_hand) -> np.ndarray:
        v = self.rotation @ np.asarray(v_hand, dtype=float)
        return mirror_point(v) if side == "left" else v

    def linear_map(self, side: str) -> np.ndarray:
        """Hand-frame vector -> world vector at q = 0 (a reflection on the left)."""
        return self.rotation if side == "right" else _M @ self.rotation

    def axis(self, side: str, a_hand) -> np.ndarray:
        a = self.rotation @ np.asarray(a_hand, dtype=float)
        return mirror_axis(a) if side == "left" else a

    def box(self, side: str, size, center_hand, at=(0.0, 0.0, 0.0)) -> Geometry:
        """An oriented box in the hand link's (world-aligned) frame.

        `at` is where the hand root sits in that link frame.
        """
        rot = self.rotation if side == "right" else _M @ self.rotation @ _M
        center = self.place(side, np.asarray(at, dtype=float), center_hand)
        return Geometry("box", tuple(size), tuple(float(c) for c in center), rpy_from_rotation(rot))

    def cylinder(self, side: str, radius: float, length: float, center_hand, axis_hand, at=(0.0, 0.0, 0.0)) -> Geometry:
        center = self.place(side, np.asarray(at, dtype=float), center_hand)
        direction = self.direction(side, axis_hand)
        return Geometry(
            "cylinder",
            (radius, length),
            tuple(float(c) for c in center),
            rpy_aligning_z_to(direction),
        )


@dataclass(frozen=True)
class FingerChain:
    """A finger: base point, direction, joint spacings, masses, limits."""

    name: str
    base: tuple[float, float, float]
    direction: tuple[float, float, float]
    spacings: tuple[float, ...]  # base -> joint 0, joint 0 -> joint 1, ..., last -> tip
    masses: tuple[float, ...]  # one per joint (child link mass)
    first_axis: tuple[float, float, float] | None = None  # None: flexion axis
    first_range: tuple[float, float] | None = None


def _add_finger(
    b: SpecBuilder,
    side: str,
    hand_link: str,
    frame: HandFrame,
    finger: FingerChain,
    flexion_range: tuple[float, float],
    drive: Drive,
    palm_normal: tuple[float, float, float],
    radius: float,
    mount: np.ndarray | None,
) -> None:
    origin = b.origin(hand_link) if mount is None else np.asarray(mount, dtype=float)
    d_hand = np.asarray(finger.direction, dtype=float)
    d_hand /= np.linalg.norm(d_hand)
    flexion_hand = np.cross(d_hand, np.asarray(palm_normal, dtype=float))
    flexion_hand /= np.linalg.norm(flexion_hand)
    # Joint points along the finger (hand frame), then the tip.
    distance = np.cumsum(finger.spacings)
    points = [np.asarray(finger.base) + s * d_hand for s in distance]
    parent = hand_link
    for i, mass in enumerate(finger.masses):
        joint_world = frame.place(side, origin, points[i])
        next_world = frame.place(side, origin, points[i + 1])
        if i == 0 and finger.first_axis is not None:
            axis_hand, (lo, hi) = np.asarray(finger.first_axis), finger.first_range
        else:
            axis_hand, (lo, hi) = flexion_hand, flexion_range
        segment = capsule(radius, (0.0, 0.0, 0.0), tuple(next_world - joint_world))
        child = f"{side}_{finger.name}_{i}_link"
        b.chain(
            parent=parent,
            child=child,
            offset=tuple(joint_world - b.origin(parent)),
            dofs=[Dof(str(i), tuple(frame.axis(side, axis_hand)), lo, hi)],
            drive=drive,
            part=FINGER_PART,
            mass=mass,
            visuals=[segment],
            collisions=[segment],
            side=side,
            prefix=f"{side}_{finger.name}",
        )
        parent = child


def register_hand(b: SpecBuilder, side: str, model: str, hand_link: str, frame: HandFrame, mount=None) -> None:
    """Record where a hand model sits, so its landmarks can be placed (both variants)."""
    root = b.origin(hand_link) if mount is None else np.asarray(mount, dtype=float)
    b.hand_mounts[side] = (model, frame.linear_map(side), root)


# Landmarks of each hand model in its (right-hand) frame: the end of the palm
# ("hand", at the middle knuckle) and the base knuckle of each finger.
HAND_LANDMARKS: dict[str, dict[str, tuple[float, float, float]]] = {
    "qbhand": {
        "hand": (-0.0045, 0.0005, 0.144),
        "thumb_1": (-0.0485, 0.0165, 0.0975),
        "index_1": (-0.0245, 0.0005, 0.137),
        "middle_1": (-0.0045, 0.0005, 0.144),
        "ring_1": (0.0155, 0.0005, 0.137),
        "little_1": (0.0355, 0.0005, 0.132),
    },
    "walker": {
        "hand": (0.1578, 0.0104, 0.0091),
        "thumb_1": (0.0807, 0.0431, 0.0246),
        "index_1": (0.1527, 0.0106, 0.0333),
        "middle_1": (0.1578, 0.0104, 0.0091),
        "ring_1": (0.1517, 0.0102, -0.0146),
        "little_1": (0.1468, 0.0088, -0.0379),
    },
}


# Joints that move together (joint indices within one finger): the qb
# SoftHand's rolling-contact "virtual" joints copy their partners 1:1 (Q1).
COUPLED_JOINTS: dict[str, dict[str, tuple[tuple[int, int], ...]]] = {
    "qbhand": {
        "thumb": ((1, 2), (3, 4)),
        "index": ((0, 1), (2, 3), (4, 5)),
        "middle": ((0, 1), (2, 3), (4, 5)),
        "ring": ((0, 1), (2, 3), (4, 5)),
        "little": ((0, 1), (2, 3), (4, 5)),
    },
    "walker": {},
}


# --- qb SoftHand (UDH, NAVIAI, H1, CURI): 29 joints per hand --------------------

QBHAND_PALM_MASS = 0.90  # base flange 0.45 + palm 0.45 (facts Q1)
# The facts give 0.785 rad flexion per joint; tips and thumb direction are est.
_QB_FLEXION = (0.0, 0.785)
_QB_FINGER_SPACING = (0.009, 0.013, 0.017, 0.013, 0.009, 0.013, 0.020)
_QB_LITTLE_SPACING = (0.009, 0.013, 0.009, 0.013, 0.009, 0.013, 0.020)
# Each real phalanx mass split evenly with its rolling-contact "virtual" twin.
_QB_FINGER_MASSES = (0.0041, 0.0041, 0.00315, 0.00315, 0.0045, 0.0045)
_QB_LITTLE_MASSES = (0.00315, 0.00315, 0.00315, 0.00315, 0.0045, 0.0045)
QBHAND_FINGERS = (
    FingerChain(
        "thumb",
        base=(-0.0485, 0.0165, 0.0975),
        direction=(-1.0, 0.25, 0.35),
        spacings=(0.0, 0.0255, 0.013, 0.009, 0.013, 0.020),
        masses=(0.010, 0.00315, 0.00315, 0.0045, 0.0045),
        first_axis=(0.0, 0.0, -1.0),  # rotation about the hand's long axis
        first_range=(0.0, 1.571),
    ),
    FingerChain("index", (-0.0245, 0.0005, 0.137), (0, 0, 1), _QB_FINGER_SPACING, _QB_FINGER_MASSES),
    FingerChain("middle", (-0.0045, 0.0005, 0.144), (0, 0, 1), _QB_FINGER_SPACING, _QB_FINGER_MASSES),
    FingerChain("ring", (0.0155, 0.0005, 0.137), (0, 0, 1), _QB_FINGER_SPACING, _QB_FINGER_MASSES),
    FingerChain("little", (0.0355, 0.0005, 0.132), (0, 0, 1), _QB_LITTLE_SPACING, _QB_LITTLE_MASSES),
)
# Facts R1: finger kp 5, kd 0.1, armature 0.007. Effort and speed (est.).
QBHAND_DRIVE = Drive(effort=2.0, velocity=10.0, kp=5.0, kd=0.1, armature=0.007)


def qbhand_palm(side: str, frame: HandFrame, at=(0.0, 0.0, 0.0)) -> tuple[list[Geometry], list[Geometry]]:
    """Visual and collision shapes of the qb SoftHand palm and flange.

    `at` is the hand root's position in the hand link frame.
    """
    palm = frame.box(side, (0.09, 0.03, 0.10), (0.0, 0.01, 0.085), at)
    flange = frame.cylinder(side, 0.035, 0.035, (0.0, 0.0, 0.0175), (0.0, 0.0, 1.0), at)
    return [flange, palm], [palm]


def add_qbhand(b: SpecBuilder, side: str, hand_link: str, frame: HandFrame, mount: np.ndarray | None = None) -> None:
    """Add the 29 finger joints of one qb SoftHand to `hand_link`.

    `mount` is the hand root's world position at q = 0 (default: the hand
    link's origin).
    """
    for finger in QBHAND_FINGERS:
        _add_finger(b, side, hand_link, frame, finger, _QB_FLEXION, QBHAND_DRIVE, (0, 1, 0), 0.009, mount)


# --- Walker hand: 10 joints per hand ---------------------------------------------

WALKER_PALM_MASS = 0.085
_WALKER_FLEXION = (0.0, 1.5708)
WALKER_FINGERS = (
    FingerChain("thumb", (0.0807, 0.0431, 0.0246), (0.7, 0.3, 0.65), (0.0, 0.0393, 0.030), (0.0086, 0.0042)),
    FingerChain("index", (0.1527, 0.0106, 0.0333), (1, 0, 0), (0.0, 0.0404, 0.030), (0.0061, 0.0045)),
    FingerChain("middle", (0.1578, 0.0104, 0.0091), (1, 0, 0), (0.0, 0.0404, 0.030), (0.0061, 0.0045)),
    FingerChain("ring", (0.1517, 0.0102, -0.0146), (1, 0, 0), (0.0, 0.0404, 0.030), (0.0061, 0.0045)),
    FingerChain("little", (0.1468, 0.0088, -0.0379), (1, 0, 0), (0.0, 0.0354, 0.030), (0.0048, 0.0039)),
)
# Facts W2/W3: position servo kp 870, force range 1, damping 0.01; speed (est.).
WALKER_HAND_DRIVE = Drive(effort=1.0, velocity=5.0, kp=870.0, kd=0.05, armature=0.002, damping=0.01)


def walker_palm(side: str, frame: HandFrame) -> tuple[list[Geometry], list[Geometry]]:
    palm = frame.box(side, (0.10, 0.03, 0.09), (0.09, 0.0, 0.0))
    return [palm], [palm]


def add_walker_hand(b: SpecBuilder, side: str, hand_link: str, frame: HandFrame) -> None:
    """Add the 10 finger joints of one Walker hand to `hand_link`."""
    for finger in WALKER_FINGERS:
        _add_finger(b, side, hand_link, frame, finger, _WALKER_FLEXION, WALKER_HAND_DRIVE, (0, 1, 0), 0.008, None)
