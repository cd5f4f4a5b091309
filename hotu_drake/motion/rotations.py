"""Quaternion (w, x, y, z) and rotation-matrix helpers, vectorised over frames,
and finite-difference velocities consistent with sampled positions."""

import numpy as np


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
    aw, ax, ay, az = np.moveaxis(np.asarray(a, float), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, float), -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        -1,
    )


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
