"""Body frames of a source's landmarks over all frames, where they allow.

A capture may lack the hips (the upper body only), the head's top, the
knuckle line or the toes; the streaming and whole-clip paths, the neutral
calibration and the metrics all read the source's body frames from here.
"""

from functools import cache

import numpy as np

from hotu_drake.embodiment.spec import FINGERS, SIDES
from hotu_drake.motion.synthesis import smooth
from hotu_drake.retarget import frames
from hotu_drake.retarget.udh_rest import udh_rest_landmarks
from hotu_drake.rotations import heading_rotation


def hand_frame_kind(names, side: str) -> str | None:
    """How landmarks `names` define a hand frame: across the knuckles, towards
    the thumb's tip (a capture without a knuckle line), or not at all."""
    names = set(names)
    if not {f"{side}_wrist", f"{side}_hand"} <= names:
        return None
    if {f"{side}_index_1", f"{side}_little_1"} <= names:
        return "knuckles"
    return "thumb" if f"{side}_thumb_4" in names else None


@cache
def thumb_frame_offset(side: str) -> np.ndarray:
    """The turn from `frames.thumb_hand_frame` to `frames.hand_frame` of an
    open hand (the UDH's at rest), so that both name the same hand frame."""
    rest = udh_rest_landmarks()
    return frames.thumb_hand_frame(rest, side).T @ frames.hand_frame(rest, side)


def source_frames(src: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Body frames of the source over all frames, where its landmarks allow."""
    out = {"chest": frames.chest_frame(src)}
    # A capture of the upper body has no pelvis: the root stands upright, turned with the chest.
    out["pelvis"] = frames.pelvis_frame(src) if "left_hip" in src else heading_rotation(out["chest"])
    if "head_top" in src:
        out["head"] = frames.head_frame(src)
    lateral = out["pelvis"][:, :, 1]
    for side in SIDES:
        kind = hand_frame_kind(src, side)
        if kind == "knuckles":
            out[f"{side}_hand"] = frames.hand_frame(src, side)
        elif kind == "thumb":
            out[f"{side}_hand"] = frames.thumb_hand_frame(src, side) @ thumb_frame_offset(side)
        if f"{side}_toe" in src:
            out[f"{side}_foot"] = frames.foot_frame(src, side, lateral)
    return out


def low_passed(src: dict[str, np.ndarray], fps: float, sigma: float) -> dict[str, np.ndarray]:
    """The landmarks (T, 3) each low-passed along time (a Gaussian of
    `sigma` s), but the fingers' moved with their hand as a rigid body: each
    finger landmark keeps its place in its hand's frame, so the hand's shape
    is the source's (low-passed point by point, a turning hand's fingers
    would seem to bend: the CMU finger test's still fingers moved 0.09 rad)."""
    out = {name: smooth(points, fps, sigma) for name, points in src.items()}
    raw, moved = source_frames(src), source_frames(out)
    for side in SIDES:
        hand = f"{side}_hand"  # the hand's frame, and its origin landmark
        if hand not in raw:
            continue
        turn = moved[hand] @ np.swapaxes(raw[hand], -1, -2)
        for name in src:
            if name.startswith(f"{side}_") and any(f"_{finger}_" in name for finger in FINGERS):
                out[name] = out[hand] + np.einsum("tij,tj->ti", turn, src[name] - src[hand])
    return out
