"""What each part's partial IK tries to match, linearised.

Every target compares a quantity of the embodiment (from its landmarks and
`Pose`) with the same quantity of the source and returns the Jacobian rows
over a part's joints: `rows` for one frame (the streaming path), and
`rows_frames` for every frame of a clip at once (the whole-clip programs),
with a leading frame axis on the Jacobians, errors and weights.
"""

from dataclasses import dataclass

import numpy as np

from hotu_drake.retarget.frames import pelvis_frame
from hotu_drake.retarget.tree import Pose, Tree, cross, rotation_vector
from hotu_drake.rotations import heading_rotation, rotation_log


def _normalize(v: np.ndarray) -> tuple[np.ndarray, float]:
    n = float(np.linalg.norm(v))
    return v / max(n, 1e-9), n


def _normalize_frames(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.linalg.norm(v, axis=-1)
    return v / np.maximum(n, 1e-9)[:, None], n


class Landmarks:
    """The embodiment's landmarks: (link index, offset) by name."""

    def __init__(self, tree: Tree, placements: dict[str, tuple[str, np.ndarray]]):
        self.tree = tree
        self._mask_cache: dict = {}
        self.items = {
            name: (tree.link_index[link], np.asarray(offset, float)) for name, (link, offset) in placements.items()
        }

    def __contains__(self, name: str) -> bool:
        return name in self.items

    def position(self, pose: Pose, name: str) -> np.ndarray:
        link, offset = self.items[name]
        return pose.point(link, offset)

    def all_positions(self, pose: Pose) -> dict[str, np.ndarray]:
        return {name: pose.point(link, offset) for name, (link, offset) in self.items.items()}

    def point_jacobian(self, pose: Pose, name: str, joints: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """Position of a landmark and its Jacobian over `joints` (3 x k)."""
        link, offset = self.items[name]
        point = pose.point(link, offset)
        return point, self.tree_point_jacobian(pose, link, point, joints)

    def _masks(self, link: int, joints: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Which of `joints` move `link` (revolute, prismatic), cached."""
        key = (link, tuple(joints))
        if key not in self._mask_cache:
            ancestors = set(self.tree.link_ancestors[link])
            moves = np.array([j in ancestors for j in joints], dtype=bool)
            revolute = np.array([self.tree._revolute[j] for j in joints], dtype=bool)
            rows = (moves & revolute).astype(float)[:, None], (moves & ~revolute).astype(float)[:, None]
            self._mask_cache[key] = (np.asarray(joints, dtype=int), *rows)
        return self._mask_cache[key]

    def tree_point_jacobian(self, pose: Pose, link: int, point: np.ndarray, joints: list[int]) -> np.ndarray:
        index, revolute, prismatic = self._masks(link, joints)
        a = pose.joint_axes[index]
        b = point - pose.joint_positions[index]
        turned = np.column_stack(
            (
                a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
            )
        )
        return (turned * revolute + a * prismatic).T

    def point_jacobian_frames(self, poses: Pose, name: str, joints: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """`point_jacobian` for every frame of `poses` (`Tree.forward_frames`):
        positions (T, 3) and Jacobians (T, 3, k)."""
        link, offset = self.items[name]
        points = poses.positions[:, link] + poses.rotations[:, link] @ offset
        index, revolute, prismatic = self._masks(link, joints)
        axes = poses.joint_axes[:, index]  # (T, k, 3)
        turned = cross(axes, points[:, None, :] - poses.joint_positions[:, index])
        return points, np.swapaxes(turned * revolute + axes * prismatic, 1, 2)

    def rotation_jacobian_frames(self, link: int, poses: Pose, joints: list[int]) -> np.ndarray:
        """`rotation_jacobian` for every frame of `poses`: (T, 3, k)."""
        index, revolute, _ = self._masks(link, joints)
        return np.swapaxes(poses.joint_axes[:, index] * revolute, 1, 2)

    def rotation_jacobian(self, link: int, pose: Pose, joints: list[int]) -> np.ndarray:
        index, revolute, _ = self._masks(link, joints)
        return (pose.joint_axes[index] * revolute).T


@dataclass
class Segment:
    """A target on the segment from landmark `start` to landmark `end`."""

    start: str
    end: str
    weight: float = 1.0

    def span(self, marks: Landmarks, pose: Pose, joints: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """end - start (3,) and its Jacobian over `joints` (3, k)."""
        ps, js = marks.point_jacobian(pose, self.start, joints)
        pe, je = marks.point_jacobian(pose, self.end, joints)
        return pe - ps, je - js

    def span_frames(self, marks: Landmarks, poses: Pose, joints: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """`span` for every frame: (T, 3) and (T, 3, k)."""
        ps, js = marks.point_jacobian_frames(poses, self.start, joints)
        pe, je = marks.point_jacobian_frames(poses, self.end, joints)
        return pe - ps, je - js


@dataclass
class Direction(Segment):
    """The unit vector from landmark `start` to `end` should match the source's."""

    def rows(self, marks: Landmarks, pose: Pose, joints: list[int], target: np.ndarray):
        span, jacobian = self.span(marks, pose, joints)
        u, length = _normalize(span)
        return (np.eye(3) - np.outer(u, u)) @ jacobian / max(length, 1e-9), target - u, self.weight

    def rows_frames(self, marks: Landmarks, poses: Pose, joints: list[int], targets: np.ndarray):
        span, jacobian = self.span_frames(marks, poses, joints)
        u, length = _normalize_frames(span)
        projector = np.eye(3) - u[:, :, None] * u[:, None, :]
        weights = np.full(len(u), self.weight)
        return projector @ jacobian / np.maximum(length, 1e-9)[:, None, None], targets - u, weights


@dataclass
class Sideways(Segment):
    """How far landmark `end` lies to the body's left of landmark `start`
    should be the source's, scaled: a foot's offset from its own hip, so a
    robot stands at its own width. Its target is the body's left axis and
    the offset along it (4,), or (T, 4) over frames, or (T, 5) with a
    factor on its weight per frame."""

    def rows(self, marks: Landmarks, pose: Pose, joints: list[int], target: np.ndarray):
        span, jacobian = self.span(marks, pose, joints)
        left, offset = target[:3], target[3]
        return (left @ jacobian)[None], np.array([offset - left @ span]), self.weight

    def rows_frames(self, marks: Landmarks, poses: Pose, joints: list[int], targets: np.ndarray):
        span, jacobian = self.span_frames(marks, poses, joints)
        left, offset = targets[:, :3], targets[:, 3]
        error = (offset - np.einsum("ti,ti->t", left, span))[:, None]
        weight = self.weight * (targets[:, 4] if targets.shape[1] > 4 else np.ones(len(error)))
        return np.einsum("ti,tik->tk", left, jacobian)[:, None, :], error, weight


def sideways_offsets(points: dict[str, np.ndarray], end: str = "ankle") -> dict[str, np.ndarray]:
    """Each leg's `end` landmark's offset (m) from its hip along the pelvis'
    left axis (heading frame), per side (T,) (positive: to the body's left)."""
    left = heading_rotation(pelvis_frame(points))[:, :, 1]
    return {s: np.einsum("ti,ti->t", left, points[f"{s}_{end}"] - points[f"{s}_hip"]) for s in ("left", "right")}


@dataclass(frozen=True)
class SidewaysStance:
    """Where a leg point's sideways target moves from, and its bounds: the
    embodiment's own offset from its hip standing (m), the human's standing
    straight (per unit of leg), and the offsets (m) that keep it clear of
    the other leg (its side of the body's midline, less half the legs'
    clearance)."""

    standing: float
    neutral: float
    low: float = -np.inf
    high: float = np.inf


def sideways_target(src: dict, src_frames: dict, key: tuple, leg: float, stance: SidewaysStance) -> np.ndarray:
    """A `Sideways` target's values over the source's frames (T, 4): the
    source pelvis' left axis (heading frame), and the offset of the
    embodiment's leg point from its hip along it: its own `stance.standing`
    offset, moved by the source's offset away from the human standing
    straight, scaled from the source's leg to `leg` (the embodiment's), and
    kept within the stance's bounds. `key`: ("side", hip, knee, ankle, point)."""
    _, hip, knee, ankle, point = key
    left = heading_rotation(src_frames["pelvis"])[:, :, 1]
    length = np.linalg.norm(src[knee] - src[hip], axis=-1) + np.linalg.norm(src[ankle] - src[knee], axis=-1)
    offset = np.einsum("ti,ti->t", left, src[point] - src[hip]) / np.maximum(length, 1e-6)
    target = np.clip(stance.standing + leg * (offset - stance.neutral), stance.low, stance.high)
    return np.column_stack((left, target))


@dataclass
class BendPlane:
    """A hinge's axis (elbow, knee) should be normal to the source's bend plane.

    This sets the twist of the proximal part (shoulder, hip) that the limb's
    own direction leaves free; its weight fades as the source limb straightens.
    """

    joint: int
    sign: float
    weight: float = 0.5

    def rows(self, marks: Landmarks, pose: Pose, joints: list[int], target: np.ndarray):
        axis = pose.joint_axes[self.joint]
        ancestors = marks.tree.ancestors[self.joint][:-1]
        jacobian = np.zeros((3, len(joints)))
        for col, j in enumerate(joints):
            if j in ancestors and marks.tree._revolute[j]:
                jacobian[:, col] = cross(pose.joint_axes[j], axis)
        normal, bend = _normalize(target)
        return jacobian, self.sign * normal - axis, self.weight * min(1.0, bend / 0.3)

    def rows_frames(self, marks: Landmarks, poses: Pose, joints: list[int], targets: np.ndarray):
        axis = poses.joint_axes[:, self.joint]  # (T, 3)
        ancestors = marks.tree.ancestors[self.joint][:-1]
        jacobian = np.zeros((len(axis), 3, len(joints)))
        for col, j in enumerate(joints):
            if j in ancestors and marks.tree._revolute[j]:
                jacobian[:, :, col] = cross(poses.joint_axes[:, j], axis)
        normal, bend = _normalize_frames(targets)
        return jacobian, self.sign * normal - axis, self.weight * np.minimum(1.0, bend / 0.3)


@dataclass
class Orientation:
    """A link's orientation should be source frame x (the link's frame at rest)^T."""

    link: int
    rest_frame: np.ndarray  # the embodiment's own body frame at q = 0
    weight: float = 1.0

    def rows(self, marks: Landmarks, pose: Pose, joints: list[int], target: np.ndarray):
        desired = target @ self.rest_frame.T
        error = rotation_vector(desired @ pose.rotations[self.link].T)
        return marks.rotation_jacobian(self.link, pose, joints), error, self.weight

    def rows_frames(self, marks: Landmarks, poses: Pose, joints: list[int], targets: np.ndarray):
        desired = targets @ self.rest_frame.T
        error = rotation_log(desired @ np.swapaxes(poses.rotations[:, self.link], 1, 2))
        return marks.rotation_jacobian_frames(self.link, poses, joints), error, np.full(len(error), self.weight)


@dataclass
class LevelSideways:
    """A link's sideways axis (its body frame's y, the frame at rest given by
    `rest_frame`) should stay horizontal: a foot not rolled. Where the
    source's two foot points leave the roll free, an ankle would otherwise
    roll the foot to point its toe, and a rolled swing foot hits the other
    leg. Its target is 0 (no tilt)."""

    link: int
    rest_frame: np.ndarray
    weight: float = 1.0

    def rows(self, marks: Landmarks, pose: Pose, joints: list[int], target):
        side = pose.rotations[self.link] @ self.rest_frame[:, 1]
        tilt = cross(side, np.array([0.0, 0.0, 1.0]))
        jacobian = tilt @ marks.rotation_jacobian(self.link, pose, joints)
        return jacobian[None], np.array([-side[2]]), self.weight

    def rows_frames(self, marks: Landmarks, poses: Pose, joints: list[int], targets):
        side = poses.rotations[:, self.link] @ self.rest_frame[:, 1]
        tilt = np.cross(side, np.array([0.0, 0.0, 1.0]))
        jacobian = np.einsum("ti,tik->tk", tilt, marks.rotation_jacobian_frames(self.link, poses, joints))
        return jacobian[:, None, :], -side[:, 2:3], np.full(len(side), self.weight)


@dataclass
class Coupling:
    """Two joints of one part should move together (qb SoftHand virtual joints)."""

    first: int  # column within the part
    second: int
    weight: float = 1.0

    def rows(self, marks: Landmarks, pose: Pose, joints: list[int], q: np.ndarray):
        jacobian = np.zeros((1, len(joints)))
        jacobian[0, self.first], jacobian[0, self.second] = 1.0, -1.0
        return jacobian, np.array([q[joints[self.second]] - q[joints[self.first]]]), self.weight

    def rows_frames(self, marks: Landmarks, poses: Pose, joints: list[int], q: np.ndarray):
        jacobian = np.zeros((len(q), 1, len(joints)))
        jacobian[:, 0, self.first], jacobian[:, 0, self.second] = 1.0, -1.0
        error = (q[:, joints[self.second]] - q[:, joints[self.first]])[:, None]
        return jacobian, error, np.full(len(q), self.weight)


@dataclass
class Position:
    """A landmark should sit at a given world point (a planted foot)."""

    landmark: str
    weight: float = 1.0

    def rows(self, marks: Landmarks, pose: Pose, joints: list[int], target: np.ndarray):
        point, jacobian = marks.point_jacobian(pose, self.landmark, joints)
        return jacobian, target - point, self.weight

    def rows_frames(self, marks: Landmarks, poses: Pose, joints: list[int], targets: np.ndarray):
        points, jacobian = marks.point_jacobian_frames(poses, self.landmark, joints)
        return jacobian, targets - points, np.full(len(points), self.weight)
