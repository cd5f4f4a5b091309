"""Foot contact phases of a source motion, and the soles of an embodiment."""

import numpy as np

from hotu_drake.embodiment.spec import EmbodimentSpec
from hotu_drake.retarget.tree import Pose, Tree

CONTACT_HEIGHT = 0.04  # m above the clip's floor
CONTACT_SPEED = 0.12  # m/s horizontal, of the foot's stiller end (the ankle's landmark or the toe's)
# m/s: a planted foot stays planted, low, until its stiller end moves this fast (and from when it moved this
# slowly before landing). A capture's toe landmark (on top of the toes, which bend as the heel rises over them)
# moves at 0.1-0.4 m/s before the toes leave the floor: at CONTACT_SPEED the Qualisys walk had no double
# support, 5-7 frames with no foot down at each step.
RELEASE_SPEED = 0.3
MIN_PHASE_FRAMES = 3
MIN_PHASE_SECONDS = 0.05  # and no contact or flight phase shorter than this (but at the clip's ends)


def _clean(flags: np.ndarray, min_frames: int) -> np.ndarray:
    """Drop contact and flight phases shorter than `min_frames`."""
    flags = flags.copy()
    for value in (True, False):
        start = None
        for t in range(len(flags) + 1):
            inside = t < len(flags) and flags[t] == value
            if inside and start is None:
                start = t
            elif not inside and start is not None:
                if t - start < min_frames and start > 0 and t < len(flags):
                    flags[start:t] = not value
                start = None
    return flags


def _held(landed: np.ndarray, holding: np.ndarray) -> np.ndarray:
    """The contact phases of `landed` (T,) each grown, forwards and back, over the frames `holding` (T,) next to it."""
    out = landed.copy()
    for t in range(1, len(out)):
        if not out[t] and out[t - 1] and holding[t]:
            out[t] = True
    for t in range(len(out) - 2, -1, -1):
        if not out[t] and out[t + 1] and holding[t]:
            out[t] = True
    return out


def detect_foot_contacts(landmarks: dict[str, np.ndarray], fps: float) -> dict[str, np.ndarray]:
    """side -> (T,) bool: the foot is low and one of its ends (nearly)
    still: the heel as it lands, the toe as the heel rises to push off; and
    it stays planted, low, until that end moves at `RELEASE_SPEED` (and is
    planted from when it came that slow and low before: a heel landing
    still sliding)."""
    heights = np.stack(
        [np.minimum(landmarks[f"{s}_toe"][:, 2], landmarks[f"{s}_ankle"][:, 2]) for s in ("left", "right")]
    )
    floor = np.percentile(heights.min(axis=0), 5)
    shortest = max(MIN_PHASE_FRAMES, int(round(MIN_PHASE_SECONDS * fps)))
    out = {}
    for i, side in enumerate(("left", "right")):
        ends = [landmarks[f"{side}_{end}"][:, :2] for end in ("toe", "ankle")]
        if len(heights[i]) > 1:
            speed = np.minimum(*(np.linalg.norm(np.gradient(end, 1.0 / fps, axis=0), axis=1) for end in ends))
        else:
            speed = np.zeros(1)
        low = heights[i] - floor < CONTACT_HEIGHT
        landed = low & (speed < CONTACT_SPEED)
        out[side] = _clean(_held(landed, low & (speed < RELEASE_SPEED)), shortest)
    return out


class Soles:
    """The lowest points of each foot's collision shapes."""

    def __init__(self, spec: EmbodimentSpec, tree: Tree):
        self.feet = {}
        for side in ("left", "right"):
            name = spec.key_bodies.get(f"{side}_foot")
            if name is None:
                continue
            points, radii = [], []
            for g in spec.link(name).collisions:
                center = np.asarray(g.position, dtype=float)
                if g.shape == "box":
                    for corner in np.array(np.meshgrid(*[[-s / 2, s / 2] for s in g.size])).reshape(3, -1).T:
                        points.append(center + g.rotation() @ corner)
                        radii.append(0.0)
                elif g.shape == "sphere":
                    points.append(center)
                    radii.append(g.size[0])
                else:
                    half = g.rotation() @ np.array([0.0, 0.0, g.size[1] / 2])
                    points += [center + half, center - half]
                    radii += [g.size[0], g.size[0]]
            self.feet[side] = (tree.link_index[name], np.array(points), np.array(radii))

    def lowest(self, pose: Pose, side: str) -> float:
        link, points, radii = self.feet[side]
        z = pose.positions[link][2] + points @ pose.rotations[link][2]
        return float(np.min(z - radii))

    def points_frames(self, poses: Pose, side: str) -> tuple[np.ndarray, np.ndarray]:
        """A sole's contact points in the world (T, K, 3) for every frame of
        `poses` (`Tree.forward_frames`), and their radii (K,)."""
        link, points, radii = self.feet[side]
        return poses.positions[:, link, None, :] + np.einsum("tij,kj->tki", poses.rotations[:, link], points), radii

    def lowest_frames(self, poses: Pose, side: str) -> np.ndarray:
        """`lowest` for every frame of `poses` (`Tree.forward_frames`): (T,)."""
        link, points, radii = self.feet[side]
        z = poses.positions[:, link, 2:3] + poses.rotations[:, link, 2] @ points.T
        return np.min(z - radii, axis=1)
