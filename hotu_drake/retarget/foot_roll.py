"""A planted foot that rolls over its sole's edge, as the source's does.

A person's stance ends with the heel rising over the still toes (and may
begin with the toes coming down onto a landed heel); a capture's contact
phases hold both, since one end of the foot stays put. A robot's planted
foot held flat on the ankle's landing point cannot follow: the body moves
on over a leg that cannot reach, the leg lifts the flat foot, and the other
foot (the person's already on the floor) holds the body up (the Qualisys
walk's planted feet were up to 14 cm above the floor on a fifth of their
frames). Here a planted foot turns about its sole's front edge as the
source's heel rises (about the back edge for toes coming down), by as much
as raises its ankle by the source's ankle's rise (scaled by the legs'
lengths: a robot's foot, longer or shorter for its legs than a person's,
turned by the person's angle would lift the body more or less than the
person's did), and the edge stays on the floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hotu_drake.embodiment.spec import SIDES
from hotu_drake.retarget.contacts import Soles
from hotu_drake.retarget.tree import Pose, axis_angles
from hotu_drake.rotations import heading_rotation

# rad: a source foot pitched less than this from its flat pitch counts as flat (the roll starts from 0 there).
FLAT = np.radians(3.0)
# rad: the furthest a planted foot is rolled (a person's foot near lift-off, its toes bent, turns further).
MOST_ROLLED = np.radians(40.0)


def foot_rolls(
    src: dict[str, np.ndarray], src_frames: dict[str, np.ndarray], contacts: dict[str, np.ndarray]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per side, how the source's planted foot rolls (each (T,), 0 off its
    planted frames): which way (+1 heel up, -1 toes up, 0 flat: its pitch,
    ankle to toe, within `FLAT` of its median over those frames), and how
    far (m) its ankle is above its median height over them. A side without
    a foot frame or a contact does not roll."""
    out = {}
    for side in SIDES:
        frame, planted = src_frames.get(f"{side}_foot"), contacts.get(side)
        if frame is None or planted is None or not np.any(planted):
            continue
        planted = np.asarray(planted, bool)
        pitch = np.arcsin(np.clip(-frame[:, 2, 0], -1.0, 1.0))
        tilt = pitch - np.median(pitch[planted])
        height = src[f"{side}_ankle"][:, 2]
        rise = np.clip(height - np.median(height[planted]), 0.0, None)
        way = np.where(np.abs(tilt) > FLAT, np.sign(tilt), 0.0)
        out[side] = (np.where(planted, way, 0.0), np.where(planted, rise, 0.0))
    return out


@dataclass(frozen=True)
class SoleEdges:
    """Where a flat sole's front and back edges are from the ankle's
    landmark, along the foot's heading (m), and how far below it the sole is."""

    front: float
    back: float
    down: float

    def rise(self, rolls: np.ndarray) -> np.ndarray:
        """How far (m) the ankle rises as the foot turns by `rolls` about its edge."""
        along = np.where(rolls >= 0.0, self.front, self.back)
        # The ankle from the edge: (-along, -down) forward and up, turned about the lateral axis.
        return np.abs(along) * np.sin(np.abs(rolls)) - self.down * (np.cos(rolls) - 1.0)

    def rolls_rising(self, rises: np.ndarray, signs: np.ndarray) -> np.ndarray:
        """The rolls (T,) that raise the ankle by `rises` (T,; m), heel up where
        `signs` > 0, toes up where < 0: at most `MOST_ROLLED`, and at most the
        roll that raises it most (about a short heel the ankle, turned past
        above its edge, comes down again: H1's at 26 degrees, 8 mm up)."""
        out = np.zeros(len(rises))
        for sign, along in ((1.0, self.front), (-1.0, self.back)):
            grid = np.linspace(0.0, min(MOST_ROLLED, np.arctan2(abs(along), -self.down)), 161)
            rolled = np.interp(rises, self.rise(sign * grid), grid)
            out = np.where(signs * sign > 0, sign * rolled, out)
        return out

    def pivots(self, headings: np.ndarray, rolls: np.ndarray) -> np.ndarray:
        """The edge each frame turns about, from the flat ankle (T, 3): the
        front for a heel up (roll > 0), the back for toes up. `headings`:
        the foot's yaw-only frames (T, 3, 3)."""
        along = np.where(rolls >= 0.0, self.front, self.back)
        return along[:, None] * headings[:, :, 0] + np.array([0.0, 0.0, self.down])

    def rolled(self, flat: np.ndarray, headings: np.ndarray, rolls: np.ndarray) -> np.ndarray:
        """The ankle (T, 3) of the foot whose flat ankle is at `flat`, turned
        by `rolls` about its edge (which stays where it is)."""
        edge = self.pivots(headings, rolls)
        turn = axis_angles(headings[:, :, 1], rolls)
        return flat + edge - np.einsum("tij,tj->ti", turn, edge)

    def unrolled(self, ankle: np.ndarray, headings: np.ndarray, rolls: np.ndarray) -> np.ndarray:
        """The flat ankle (T, 3) of a foot whose ankle, turned by `rolls`, is at `ankle`."""
        edge = self.pivots(headings, rolls)
        turn = axis_angles(headings[:, :, 1], rolls)
        return ankle + np.einsum("tij,tj->ti", turn, edge) - edge


def sole_edges(pose: Pose, soles: Soles, ankle: np.ndarray, side: str) -> SoleEdges:
    """A foot's `SoleEdges` from a pose of one frame with it flat (`ankle`:
    the ankle landmark's world position)."""
    link, points, radii = soles.feet[side]
    world = pose.positions[link] + points @ pose.rotations[link].T
    forward = heading_rotation(pose.rotations[link])[:, 0]
    along = (world - ankle) @ forward
    return SoleEdges(float(along.max()), float(along.min()), float((world[:, 2] - radii).min() - ankle[2]))
