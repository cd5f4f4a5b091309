"""Forward kinematics of one embodiment, with what partial IK needs: one
frame (`Tree.forward`) or every frame of a clip at once (`Tree.forward_frames`).

A plain NumPy pass over the joints (parent first): each link's world
rotation and position, and each joint's world axis and position. Link
frames are world-aligned at q = 0, so a joint rotates its child about its
own spec axis expressed in the parent's frame.
"""

from dataclasses import dataclass

import numpy as np

from hotu_drake.embodiment.spec import EmbodimentSpec


def axis_angles(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations about unit `axes` (n, 3) by `angles` (n,) (Rodrigues)."""
    x, y, z = axes.T
    c, s = np.cos(angles), np.sin(angles)
    t = 1.0 - c
    return np.stack(
        [
            np.stack([c + x * x * t, x * y * t - z * s, x * z * t + y * s], -1),
            np.stack([y * x * t + z * s, c + y * y * t, y * z * t - x * s], -1),
            np.stack([z * x * t - y * s, z * y * t + x * s, c + z * z * t], -1),
        ],
        -2,
    )


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis of two arrays of 3-vectors (broadcast):
    much faster than np.cross for one pair or a few thousand."""
    if a.ndim == 1 and b.ndim == 1:
        return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], -1)


def rotation_vector(r: np.ndarray) -> np.ndarray:
    """Axis * angle of one rotation matrix."""
    cos = max(-1.0, min(1.0, (r[0, 0] + r[1, 1] + r[2, 2] - 1.0) / 2.0))
    angle = np.arccos(cos)
    skew = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    if angle < 1e-6:
        return 0.5 * skew
    if np.pi - angle < 1e-4:  # half turn: axis from the symmetric part
        axis = np.sqrt(np.maximum((np.diag(r) + 1.0) / 2.0, 0.0))
        i = int(np.argmax(axis))
        axis = (r[i] + r[:, i]) / (2.0 * axis[i] + 1e-12)
        axis[i] = np.sqrt(max((r[i, i] + 1.0) / 2.0, 0.0))
        return angle * axis / max(np.linalg.norm(axis), 1e-12)
    return angle / (2.0 * np.sin(angle)) * skew


@dataclass
class Pose:
    """Link and joint quantities of one configuration (indices as in `Tree`)."""

    rotations: np.ndarray  # (links, 3, 3)
    positions: np.ndarray  # (links, 3)
    joint_axes: np.ndarray  # (joints, 3), world
    joint_positions: np.ndarray  # (joints, 3), world

    def point(self, link: int, offset: np.ndarray) -> np.ndarray:
        return self.positions[link] + self.rotations[link] @ offset

    def translated(self, delta) -> "Pose":
        """The same configuration moved rigidly by `delta` (a root shift)."""
        return Pose(self.rotations, self.positions + delta, self.joint_axes, self.joint_positions + delta)


class Tree:
    """Index tables of an embodiment's links and joints."""

    def __init__(self, spec: EmbodimentSpec):
        self.spec = spec
        self.link_names = [link.name for link in spec.links]
        self.link_index = {name: i for i, name in enumerate(self.link_names)}
        self.joint_names = spec.joint_names
        self.joint_index = {name: i for i, name in enumerate(self.joint_names)}
        self._parent = [self.link_index.get(j.parent, -1) for j in spec.joints]
        self._child = [self.link_index[j.child] for j in spec.joints]
        self._offset = [np.asarray(j.offset, dtype=float) for j in spec.joints]
        self._axis = [np.asarray(j.axis, dtype=float) for j in spec.joints]
        self._axes = np.array(self._axis).reshape(-1, 3)
        self._revolute = [j.kind == "revolute" for j in spec.joints]
        self._prismatic = ~np.array(self._revolute, dtype=bool)
        self._offsets = np.array(self._offset).reshape(-1, 3)
        # Rodrigues' terms per joint: R(q) = I + sin q K + (1 - cos q) K^2.
        skew = np.zeros((len(self._offset), 3, 3))
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -self._axes[:, 2], self._axes[:, 1], -self._axes[:, 0]
        skew -= np.swapaxes(skew, 1, 2)
        self._skew, self._skew2 = skew, skew @ skew
        self._offset_axis = np.stack([self._offsets, self._axes], axis=-1)
        self.root = self.link_index[spec.root.name]
        # ancestors[j] = joint indices that move joint j's child link (itself included).
        parent_joint = {self._child[i]: i for i in range(len(spec.joints))}
        self.ancestors: list[list[int]] = []
        for i in range(len(spec.joints)):
            chain, link = [], self._child[i]
            while link in parent_joint:
                j = parent_joint[link]
                chain.append(j)
                link = self._parent[j]
            self.ancestors.append(chain[::-1])
        self.link_ancestors = [[] for _ in self.link_names]
        for i, link in enumerate(self._child):
            self.link_ancestors[link] = self.ancestors[i]
        self._all_groups = self.depth_groups()

    def depth_groups(self, joints: list[int] | None = None) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Joints grouped by depth in the tree (parents before children), as
        (joint indices, parent link slots, child link slots), for `forward`."""
        chosen = range(len(self._child)) if joints is None else joints
        world = len(self.link_names)  # an extra slot that holds the world frame
        depth = {i: len(self.ancestors[i]) for i in chosen}
        groups = []
        for d in sorted(set(depth.values())):
            members = np.array([i for i in chosen if depth[i] == d], dtype=int)
            parents = np.array([self._parent[i] if self._parent[i] >= 0 else world for i in members], dtype=int)
            children = np.array([self._child[i] for i in members], dtype=int)
            groups.append((members, parents, children))
        return groups

    def forward(self, q: np.ndarray, root_rotation=None, root_position=None, groups=None) -> Pose:
        """Poses for joint vector `q` (spec order) and a floating root pose.

        `groups` (from `depth_groups`) limits the pass to some joints; the
        other links are left unset. Each depth of the tree is one batched step.
        """
        if groups is None:
            groups = self._all_groups
        n_links = len(self.link_names)
        rotations = np.empty((n_links + 1, 3, 3))
        positions = np.empty((n_links + 1, 3))
        rotations[n_links], positions[n_links] = np.eye(3), 0.0
        rotations[self.root] = np.eye(3) if root_rotation is None else root_rotation
        positions[self.root] = np.zeros(3) if root_position is None else root_position
        axes = np.empty((len(self._child), 3))
        joints = np.empty((len(self._child), 3))
        angle = np.where(self._prismatic, 0.0, q)[:, None, None]
        local = np.eye(3) + np.sin(angle) * self._skew + (1.0 - np.cos(angle)) * self._skew2
        slide = np.where(self._prismatic, q, 0.0)
        for members, parents, children in groups:
            rot, pos = rotations[parents], positions[parents]
            moved = rot @ self._offset_axis[members]  # (k, 3, 2): offset and axis columns
            here = pos + moved[:, :, 0]
            axis = moved[:, :, 1]
            axes[members], joints[members] = axis, here
            rotations[children] = rot @ local[members]
            positions[children] = here + axis * slide[members, None]
        return Pose(rotations[:n_links], positions[:n_links], axes, joints)

    def forward_frames(self, q: np.ndarray, root_rotation=None, root_position=None, groups=None) -> Pose:
        """`forward` for T frames at once: `q` (T, n), root rotations (T, 3, 3)
        and positions (T, 3); the `Pose` fields gain a leading frame axis.

        Each depth of the tree is one batched step over joints and frames,
        computed component by component (arrays (3, 3, links, T)): plain
        elementwise arithmetic over long rows instead of many 3 x 3 products.
        """
        q = np.asarray(q, dtype=float)
        frames = len(q)
        if groups is None:
            groups = self._all_groups
        n_links = len(self.link_names)
        rotations = np.empty((3, 3, n_links + 1, frames))
        positions = np.empty((3, n_links + 1, frames))
        rotations[:, :, n_links], positions[:, n_links] = np.eye(3)[:, :, None], 0.0
        root = np.broadcast_to(np.eye(3) if root_rotation is None else root_rotation, (frames, 3, 3))
        rotations[:, :, self.root] = np.transpose(root, (1, 2, 0))
        positions[:, self.root] = 0.0 if root_position is None else np.asarray(root_position).T
        axes = np.empty((3, len(self._child), frames))
        joints = np.empty((3, len(self._child), frames))
        for members, parents, children in groups:
            rot, pos = rotations[:, :, parents], positions[:, parents]  # (3, 3, k, T), (3, k, T)
            offset_axis = np.transpose(self._offset_axis[members], (1, 2, 0))[..., None]  # (3, 2, k, 1)
            here = pos + np.einsum("ijkt,jkt->ikt", rot, np.broadcast_to(offset_axis[:, 0], rot.shape[1:]))
            axis = np.einsum("ijkt,jkt->ikt", rot, np.broadcast_to(offset_axis[:, 1], rot.shape[1:]))
            axes[:, members], joints[:, members] = axis, here
            value = q[:, members].T  # (k, T)
            revolute = ~self._prismatic[members][:, None]
            angle = np.where(revolute, value, 0.0)
            skew = np.transpose(self._skew[members], (1, 2, 0))[..., None]  # (3, 3, k, 1)
            skew2 = np.transpose(self._skew2[members], (1, 2, 0))[..., None]
            local = np.sin(angle) * skew + (1.0 - np.cos(angle)) * skew2
            local[0, 0] += 1.0
            local[1, 1] += 1.0
            local[2, 2] += 1.0
            rotations[:, :, children] = np.einsum("ijkt,jlkt->ilkt", rot, local)
            positions[:, children] = here + axis * np.where(revolute, 0.0, value)
        return Pose(
            np.transpose(rotations[:, :, :n_links], (3, 2, 0, 1)),
            np.transpose(positions[:, :n_links], (2, 1, 0)),
            np.transpose(axes, (2, 1, 0)),
            np.transpose(joints, (2, 1, 0)),
        )
