"""Body frames built from landmark positions, the same way on source and target.

Each frame is a rotation whose columns are x (forward), y (left), z (up) of
a body segment. Built from points alone, they do not depend on a source's
joint conventions, and at a neutral standing pose they are close to the
identity on every embodiment.
"""

import numpy as np

from hotu_drake.rotations import normalize


def _normalize(v: np.ndarray) -> np.ndarray:
    return normalize(v, floor=1e-9)


def frame_from_zy(z: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Frame with z along `z` and y as close to `y` as orthogonality allows."""
    z = _normalize(np.asarray(z, dtype=float))
    y = np.asarray(y, dtype=float)
    y = _normalize(y - np.sum(y * z, axis=-1, keepdims=True) * z)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def frame_from_xy(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Frame with x along `x` and y as close to `y` as orthogonality allows."""
    x = _normalize(np.asarray(x, dtype=float))
    y = np.asarray(y, dtype=float)
    y = _normalize(y - np.sum(y * x, axis=-1, keepdims=True) * x)
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def pelvis_frame(p: dict) -> np.ndarray:
    """y from the right to the left hip, z up the lower spine (which moves with
    the pelvis; the chest would mix in the torso's own rotation)."""
    up = p["spine"] - p["pelvis"] if "spine" in p else p["chest"] - p["pelvis"]
    return frame_from_zy(up, p["left_hip"] - p["right_hip"])


def chest_frame(p: dict) -> np.ndarray:
    return frame_from_zy(p["neck"] - p["chest"], p["left_shoulder"] - p["right_shoulder"])


def head_frame(p: dict) -> np.ndarray:
    """z from the neck to the top of the head; the face's direction gives the
    yaw when `head_front` is known, else the shoulder line does."""
    z = p["head_top"] - p["neck"]
    if "head_front" in p:
        return frame_from_zy(z, np.cross(z, p["head_front"] - p["head"]))
    return frame_from_zy(z, p["left_shoulder"] - p["right_shoulder"])


def hand_frame(p: dict, side: str) -> np.ndarray:
    """z from the wrist to the end of the palm, y across the knuckles (to the
    thumb side on the left hand, mirrored on the right)."""
    across = p[f"{side}_index_1"] - p[f"{side}_little_1"]
    return frame_from_zy(p[f"{side}_hand"] - p[f"{side}_wrist"], across)


def thumb_hand_frame(p: dict, side: str) -> np.ndarray:
    """A hand frame for a capture without a knuckle line (CMU's hands carry
    one chain for the four fingers and one for the thumb): z from the wrist
    to the end of the palm, y towards the thumb's tip. It is turned about z
    from `hand_frame` by a fixed angle (`source_frames.thumb_frame_offset`)."""
    return frame_from_zy(p[f"{side}_hand"] - p[f"{side}_wrist"], p[f"{side}_thumb_4"] - p[f"{side}_wrist"])


def foot_frame(p: dict, side: str, lateral: np.ndarray) -> np.ndarray:
    """x from the ankle to the ball of the foot, y along the pelvis' lateral axis."""
    return frame_from_xy(p[f"{side}_toe"] - p[f"{side}_ankle"], lateral)
