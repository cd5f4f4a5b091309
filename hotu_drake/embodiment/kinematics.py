"""Forward kinematics on a spec, in NumPy, with no plant.

Used to place a robot on the floor (standing height) and for quick checks;
simulation and retargeting use Drake's own kinematics.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from hotu_drake.embodiment.spec import EmbodimentSpec


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    c, s = np.cos(angle), np.sin(angle)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + s * k + (1 - c) * k @ k


def link_poses(
    spec: EmbodimentSpec, q: Mapping[str, float], root_position=(0.0, 0.0, 0.0)
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """World rotation and position of every link (root unrotated at `root_position`)."""
    poses = {"world": (np.eye(3), np.zeros(3))}
    if spec.floating_base:
        poses[spec.root.name] = (np.eye(3), np.asarray(root_position, dtype=float))
    for j in spec.joints:  # joints are stored parent-first
        rot, pos = poses[j.parent]
        pos_joint = pos + rot @ np.asarray(j.offset)
        value = float(q.get(j.name, 0.0))
        if j.kind == "revolute":
            poses[j.child] = (rot @ _axis_angle(np.asarray(j.axis), value), pos_joint)
        else:
            poses[j.child] = (rot, pos_joint + rot @ np.asarray(j.axis) * value)
    return poses


def lowest_collision_point(spec: EmbodimentSpec, q: Mapping[str, float], links: list[str] | None = None) -> float:
    """Lowest z of the collision spheres and capsules of `links` (default all)."""
    poses = link_poses(spec, q)
    lowest = np.inf
    for link in spec.links:
        if links is not None and link.name not in links:
            continue
        rot, pos = poses[link.name]
        for g in link.collisions:
            center = pos + rot @ np.asarray(g.position)
            if g.shape == "sphere":
                lowest = min(lowest, center[2] - g.size[0])
            elif g.shape == "capsule":
                half = rot @ g.rotation() @ np.array([0.0, 0.0, g.size[1] / 2.0])
                lowest = min(lowest, center[2] - abs(half[2]) - g.size[0])
            elif g.shape == "box":
                corners = np.array(np.meshgrid(*[[-s / 2, s / 2] for s in g.size])).reshape(3, -1)
                lowest = min(lowest, float(np.min(center[2] + (rot @ g.rotation() @ corners)[2])))
            else:  # cylinder: bound by its circumscribed capsule-like extent
                half = rot @ g.rotation() @ np.array([0.0, 0.0, g.size[1] / 2.0])
                lowest = min(lowest, center[2] - abs(half[2]) - g.size[0])
    return float(lowest)


def mass_table(spec: EmbodimentSpec) -> list[tuple[str, float, np.ndarray]]:
    """(link, mass, centre of mass in the link frame) for every link."""
    return [(link.name, link.mass, link.mass_properties()[0]) for link in spec.links]


def center_of_mass(
    spec: EmbodimentSpec, q: Mapping[str, float], masses: list[tuple[str, float, np.ndarray]] | None = None
) -> np.ndarray:
    """Whole-body centre of mass (root at the origin); pass `mass_table(spec)`
    as `masses` when calling repeatedly."""
    poses = link_poses(spec, q)
    total, moment = 0.0, np.zeros(3)
    for name, mass, com in masses or mass_table(spec):
        rot, pos = poses[name]
        total += mass
        moment += mass * (pos + rot @ com)
    return moment / total


def batch_center_of_mass(poses: dict[str, tuple[np.ndarray, np.ndarray]], spec: EmbodimentSpec) -> np.ndarray:
    """Whole-body centre of mass (T, 3) over frames, from `batch_link_poses`' poses."""
    total, moment = 0.0, 0.0
    for name, mass, com in mass_table(spec):
        rot, pos = poses[name]
        total += mass
        moment = moment + mass * (pos + rot @ com)
    return moment / total


def foot_contact_points(spec: EmbodimentSpec, q: Mapping[str, float]) -> np.ndarray:
    """World centres of the feet's collision shapes (N x 3)."""
    poses = link_poses(spec, q)
    points = []
    for role in ("left_foot", "right_foot"):
        rot, pos = poses[spec.key_bodies[role]]
        points += [pos + rot @ np.asarray(g.position) for g in spec.link(spec.key_bodies[role]).collisions]
    return np.array(points)


def balance_over_feet(spec: EmbodimentSpec) -> dict[str, float]:
    """The standing pose with both legs swung about the hips (hip pitch +d,
    ankle pitch -d, so the feet stay flat and the trunk upright) until the
    centre of mass lies over the middle of the feet in x."""
    pose = dict(spec.standing_pose)
    hips = [f"{side}_hip_y" for side in ("left", "right")]
    ankles = [f"{side}_ankle_y" for side in ("left", "right")]

    def shifted(delta: float) -> dict[str, float]:
        return pose | {j: pose.get(j, 0.0) + delta for j in hips} | {j: pose.get(j, 0.0) - delta for j in ankles}

    masses = mass_table(spec)

    def error(delta: float) -> float:
        trial = shifted(delta)
        points = foot_contact_points(spec, trial)
        middle = 0.5 * (points[:, 0].min() + points[:, 0].max())
        return float(center_of_mass(spec, trial, masses)[0] - middle)

    # Secant iterations: the offset is smooth and nearly linear in the swing.
    a, b = 0.0, 0.05
    error_a, error_b = error(a), error(b)
    for _ in range(20):
        if abs(error_b) < 1e-5 or error_b == error_a:
            break
        a, b, error_a = b, b - error_b * (b - a) / (error_b - error_a), error_b
        error_b = error(b)
    if abs(error_b) > 1e-3 or abs(b) > 0.5:
        raise ValueError(f"{spec.name}: cannot balance the standing pose over the feet")
    return {k: round(v, 4) for k, v in shifted(b).items()}


def _axis_angle_batch(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations about a fixed unit `axis` by `angles` (T,)."""
    x, y, z = axis
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    c, s = np.cos(angles)[:, None, None], np.sin(angles)[:, None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


def batch_link_poses(
    spec: EmbodimentSpec,
    joint_names: list[str],
    q: np.ndarray,
    root_rotation: np.ndarray | None = None,
    root_position: np.ndarray | None = None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """World rotations (T, 3, 3) and positions (T, 3) of every link over T frames.

    `q` is (T, len(joint_names)); joints not named stay at zero. The root
    pose defaults to identity at the origin (ignored for a fixed base).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    frames = q.shape[0]
    column = {name: i for i, name in enumerate(joint_names)}
    identity = np.broadcast_to(np.eye(3), (frames, 3, 3))
    poses = {"world": (identity, np.zeros((frames, 3)))}
    if spec.floating_base:
        rot = identity if root_rotation is None else np.asarray(root_rotation, dtype=float)
        pos = np.zeros((frames, 3)) if root_position is None else np.asarray(root_position, dtype=float)
        poses[spec.root.name] = (rot, pos)
    for j in spec.joints:
        rot, pos = poses[j.parent]
        pos_joint = pos + rot @ np.asarray(j.offset)
        values = q[:, column[j.name]] if j.name in column else np.zeros(frames)
        axis = np.asarray(j.axis)
        if j.kind == "revolute":
            poses[j.child] = (rot @ _axis_angle_batch(axis, values), pos_joint)
        else:
            poses[j.child] = (rot, pos_joint + (rot @ axis) * values[:, None])
    return poses
