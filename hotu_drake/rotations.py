"""Rotations, vectorised over frames: quaternions (w, x, y, z) and matrices,
elementary rotations, Euler angles, the heading (yaw) frame, and
finite-difference velocities consistent with sampled positions.

The one home of these helpers for every stage (embodiments, motions,
retargeting, systems); it imports nothing but numpy.
"""

import math

import numpy as np


def normalize(v: np.ndarray, floor: float = 1e-12) -> np.ndarray:
    """Unit vectors along the last axis (vectors shorter than `floor` are divided by `floor`)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), floor)


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2 * np.pi)


def _axis_rotation(angle, i: int, j: int) -> np.ndarray:
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    r = np.zeros(angle.shape + (3, 3))
    k = 3 - i - j
    r[..., k, k] = 1.0
    r[..., i, i] = r[..., j, j] = c
    r[..., i, j], r[..., j, i] = -s, s
    return r


def rot_x(angle) -> np.ndarray:
    """Rotations about x by `angle` (rad), shape (..., 3, 3)."""
    return _axis_rotation(angle, 1, 2)


def rot_y(angle) -> np.ndarray:
    """Rotations about y by `angle` (rad), shape (..., 3, 3)."""
    return _axis_rotation(angle, 2, 0)


def rot_z(angle) -> np.ndarray:
    """Rotations about z by `angle` (rad), shape (..., 3, 3)."""
    return _axis_rotation(angle, 0, 1)


def heading_rotation(rotation: np.ndarray) -> np.ndarray:
    """Yaw-only rotations (..., 3, 3) sharing the heading of `rotation`'s x axis
    (the heading frame of AMP observations and of root trajectories). A
    rotation whose x axis points straight up or down gets the identity."""
    rotation = np.asarray(rotation, dtype=float)
    if rotation.shape == (3, 3):  # one rotation: the common case, per control step
        x0, x1 = rotation[0, 0], rotation[1, 0]
        n = math.sqrt(x0 * x0 + x1 * x1)
        c, s = (x0 / n, x1 / n) if n >= 1e-9 else (1.0, 0.0)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    x = np.array(rotation[..., :, 0])
    x[..., 2] = 0.0
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    x = np.where(n < 1e-9, np.array([1.0, 0.0, 0.0]), x / np.maximum(n, 1e-9))
    zero, one = np.zeros(x.shape[:-1]), np.ones(x.shape[:-1])
    y = np.stack([-x[..., 1], x[..., 0], zero], axis=-1)
    z = np.stack([zero, zero, one], axis=-1)
    return np.stack([x, y, z], axis=-1)


def heading_yaw(rotation: np.ndarray) -> np.ndarray:
    """Yaw angles (...,) of the headings of rotations (..., 3, 3), in (-pi, pi]."""
    r = np.asarray(rotation, dtype=float)
    return np.arctan2(r[..., 1, 0], r[..., 0, 0])


def euler_xyz(rotations: np.ndarray) -> np.ndarray:
    """(T, 3) angles (a, b, c) with R = Rx(a) Ry(b) Rz(c), continuous over frames."""
    r = np.asarray(rotations, dtype=float)
    b = np.arcsin(np.clip(r[:, 0, 2], -1.0, 1.0))
    locked = np.abs(r[:, 0, 2]) > 1.0 - 1e-10
    a = np.where(locked, np.arctan2(np.sign(r[:, 0, 2]) * r[:, 1, 0], r[:, 1, 1]), np.arctan2(-r[:, 1, 2], r[:, 2, 2]))
    c = np.where(locked, 0.0, np.arctan2(-r[:, 0, 1], r[:, 0, 0]))
    return np.stack([np.unwrap(a), b, np.unwrap(c)], axis=1)


def euler_xyz_within_limits(r: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Angles (a, b, c) with r = Rx(a) Ry(b) Rz(c), the order of the UDH's
    3-DoF joints, for a trajectory of rotations (T, 3, 3).

    Every rotation has two such solutions; the trajectory takes the one
    that stays within the joint limits and continuous in time (a dynamic
    programme over the two branches), so passing near gimbal lock does not
    flip the joint by half a turn.
    """
    a1 = np.arctan2(-r[..., 1, 2], r[..., 2, 2])
    b1 = np.arcsin(np.clip(r[..., 0, 2], -1.0, 1.0))
    c1 = np.arctan2(-r[..., 0, 1], r[..., 0, 0])
    first = np.stack([a1, b1, c1], -1)
    second = wrap(first + np.array([np.pi, 0.0, np.pi]))
    second[..., 1] = wrap(np.pi - b1)
    branches = np.stack([first, second])  # (2, T, 3)
    violation = (np.maximum(lower - branches, 0.0) + np.maximum(branches - upper, 0.0)).sum(-1)
    cost = 10.0 * violation + 0.01 * np.abs(branches).sum(-1)  # (2, T)
    jump = np.abs(wrap(branches[:, None, 1:] - branches[None, :, :-1])).sum(-1)  # (to, from, T - 1)
    total, back = cost[:, 0].copy(), np.zeros((len(first), 2), dtype=int)
    for t in range(1, len(first)):
        options = total[None, :] + jump[:, :, t - 1]
        back[t] = np.argmin(options, axis=1)
        total = cost[:, t] + options[[0, 1], back[t]]
    choice = np.empty(len(first), dtype=int)
    choice[-1] = int(np.argmin(total))
    for t in range(len(first) - 1, 0, -1):
        choice[t - 1] = back[t, choice[t]]
    return branches[choice, np.arange(len(first))]


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(..., 4) unit quaternions -> (..., 3, 3) rotation matrices."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices -> (..., 4) unit quaternions with w >= 0."""
    r = np.asarray(r, dtype=float)
    m00, m11, m22 = r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]
    q = np.stack(
        [
            1 + m00 + m11 + m22,
            1 + m00 - m11 - m22,
            1 - m00 + m11 - m22,
            1 - m00 - m11 + m22,
        ],
        -1,
    )
    i = np.argmax(q, axis=-1)
    out = np.empty(r.shape[:-2] + (4,))
    s = np.sqrt(np.maximum(np.take_along_axis(q, i[..., None], -1)[..., 0], 1e-12)) * 2
    # Case analysis on the largest component for numerical stability.
    cases = [
        lambda: np.stack(
            [
                s / 4,
                (r[..., 2, 1] - r[..., 1, 2]) / s,
                (r[..., 0, 2] - r[..., 2, 0]) / s,
                (r[..., 1, 0] - r[..., 0, 1]) / s,
            ],
            -1,
        ),
        lambda: np.stack(
            [
                (r[..., 2, 1] - r[..., 1, 2]) / s,
                s / 4,
                (r[..., 0, 1] + r[..., 1, 0]) / s,
                (r[..., 0, 2] + r[..., 2, 0]) / s,
            ],
            -1,
        ),
        lambda: np.stack(
            [
                (r[..., 0, 2] - r[..., 2, 0]) / s,
                (r[..., 0, 1] + r[..., 1, 0]) / s,
                s / 4,
                (r[..., 1, 2] + r[..., 2, 1]) / s,
            ],
            -1,
        ),
        lambda: np.stack(
            [
                (r[..., 1, 0] - r[..., 0, 1]) / s,
                (r[..., 0, 2] + r[..., 2, 0]) / s,
                (r[..., 1, 2] + r[..., 2, 1]) / s,
                s / 4,
            ],
            -1,
        ),
    ]
    for k, case in enumerate(cases):
        mask = i == k
        if np.any(mask):
            out[mask] = case()[mask]
    out *= np.where(out[..., :1] < 0, -1.0, 1.0)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product a b (w x y z; arrays of quaternions, broadcast)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    one_pair = a.shape == b.shape == (4,)  # the controller's reference, every step: in Python floats, faster
    (aw, ax, ay, az), (bw, bx, by, bz) = (
        (a.tolist(), b.tolist()) if one_pair else (np.moveaxis(a, -1, 0), np.moveaxis(b, -1, 0))
    )
    product = [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]
    return np.array(product) if one_pair else np.stack(product, -1)


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    return np.asarray(q, float) * np.array([1.0, -1.0, -1.0, -1.0])


def make_continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs so consecutive quaternions lie in the same hemisphere."""
    q = np.array(q, dtype=float)
    for t in range(1, len(q)):
        if np.dot(q[t], q[t - 1]) < 0:
            q[t] = -q[t]
    return q


def rotation_log(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotations -> (..., 3) rotation vectors (axis * angle)."""
    q = matrix_to_quat(r)
    w = np.clip(q[..., 0], -1.0, 1.0)
    v = q[..., 1:]
    sin_half = np.linalg.norm(v, axis=-1)
    angle = 2 * np.arctan2(sin_half, w)
    scale = np.where(sin_half > 1e-9, angle / np.maximum(sin_half, 1e-12), 2.0)
    return v * scale[..., None]


def finite_difference(x: np.ndarray, fps: float) -> np.ndarray:
    """Velocity of samples `x` (T, ...) by central differences (one-sided at the ends)."""
    x = np.asarray(x, dtype=float)
    if len(x) < 2:
        return np.zeros_like(x)
    return np.gradient(x, 1.0 / fps, axis=0)


def angular_velocity(quaternions: np.ndarray, fps: float) -> np.ndarray:
    """World-frame angular velocity (T, 3) of an orientation trajectory (T, 4)."""
    r = quat_to_matrix(quaternions)
    t = len(r)
    if t < 2:
        return np.zeros((t, 3))
    omega = np.zeros((t, 3))
    # Central difference of the relative rotation: R(t+1) R(t-1)^T over 2 dt.
    omega[1:-1] = rotation_log(r[2:] @ np.swapaxes(r[:-2], -1, -2)) * fps / 2.0
    omega[0] = rotation_log(r[1] @ r[0].T) * fps
    omega[-1] = rotation_log(r[-1] @ r[-2].T) * fps
    return omega


# --- up axes of captured data -------------------------------------------------------


def signed_axis(text: str) -> str:
    """An axis name normalised: y, +Y, -z -> +y, +y, -z. `ValueError` for anything else."""
    text = str(text).strip().lower()
    axis = text.lstrip("+-")
    if axis not in ("x", "y", "z") or len(text) - len(axis) > 1:
        raise ValueError(f"{text!r} is not an axis (x, y or z, optionally signed)")
    return ("-" if text.startswith("-") else "+") + axis


def up_rotation(up: str) -> np.ndarray:
    """The rotation taking a file's up axis ("+y", "-z", ...) to +z, right-handed.

    A Y-up lab's (x, y, z) becomes (z, x, y); a -axis is turned half a
    turn about the new x axis.
    """
    up = signed_axis(up)
    rows = {
        "z": np.eye(3),
        "y": np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
        "x": np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),
    }
    rotation = rows[up[-1]]
    return rotation if up[0] == "+" else np.diag([1.0, -1.0, -1.0]) @ rotation


def up_from_body(head: np.ndarray, feet: np.ndarray, clarity: float = 2.0) -> str | None:
    """The signed file axis along which `head` (T, 3) stands above `feet`
    (T, 3), or None when no axis is clearly it (the mean head-to-feet vector
    is not at least `clarity` times longer along one axis than along any
    other: a person lying down, or a bad marker set)."""
    up = np.nanmean(np.asarray(head, dtype=float) - np.asarray(feet, dtype=float), axis=0)
    if not np.all(np.isfinite(up)):
        return None
    order = np.argsort(np.abs(up))[::-1]
    if np.abs(up[order[0]]) < clarity * np.abs(up[order[1]]):
        return None
    return ("+" if up[order[0]] > 0 else "-") + "xyz"[order[0]]
