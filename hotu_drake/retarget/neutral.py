"""Per-embodiment neutral-pose calibration of the limb direction targets.

A robot built with angled shins or offset shoulders cannot hold a limb the
way a human standing straight does; matching raw directions makes its
joints fight that geometry all clip long. Its neutral pose is the
(uncalibrated) retargeting of the UDH at rest, a human standing straight,
with the legs' sideways targets weighted `NEUTRAL_SIDEWAYS_FACTOR` times
over (so it stands at the robot's own width, as those targets ask in every
clip; with their clip weight its hips' roll was 1.6-2.4 degrees from the
robot's standing pose, and a clip's directions and widths pulled against
each other);
there each limb segment sits at a small rotation C from the human's,
measured in the segment's parent frame (the body frame, pelvis or chest,
turned by the parent segment's swing away from rest). The retargeting
matches a source direction d as S C S' d (S that parent frame), so that a
human standing straight maps to the robot's neutral pose; where the joints
can match the human, C is the identity and nothing changes (an offset under
a degree, as the neutral solve leaves on every robot's thighs, counts as
none). A hinge (an
elbow or knee of one joint) bends in its own plane by itself, so only the
part of C out of that plane (a carrying angle, knock-kneed shins) counts:
an offset within it is a bend the hinge matches anyway.

Calibrated segments: upper arms, thighs, shins and feet (`CALIBRATED`).
A foot's robot direction is its own at rest (q = 0, its sole flat on the
floor), not the neutral solve's, and its pitch counts even on a one-joint
ankle: a human foot flat on the floor then makes a robot foot flat on the
floor (with the neutral solve's, NAVIAI's planted toes stood 6.8 degrees
up and Walker's 12.9; H1's and BRUCE's 3.3 and 5.1, their one-joint ankles
treated as hinges).
Forearms are left raw: on CURI's Panda arms the wrist landmark moves with
the wrist joints, so the forearm's neutral offset is not a fixed property of
the arm, and calibrating it raised CURI's elbow error (8.7 to 12.5 degrees
on CMU 01_01).
"""

from __future__ import annotations

import numpy as np

from hotu_drake.retarget.source_frames import source_frames
from hotu_drake.retarget.udh_rest import udh_rest_landmarks
from hotu_drake.rotations import normalize

NEUTRAL_SWEEPS = 40  # passes over the parts that find an embodiment's neutral pose
NEUTRAL_SIDEWAYS_FACTOR = 10.0  # the sideways targets' weight in the neutral solve, over a clip's
SMALLEST_TURN = np.radians(1.0)  # a smaller offset from the human's direction is no calibration
LEG = ("hip", "knee", "ankle")
CALIBRATED = ("shoulder", "hip", "knee", "ankle")  # by the segment's start
# The segment a limb segment hangs from: its start landmark is that segment's end.
PARENT_SEGMENT = {"elbow": "shoulder", "wrist": "elbow", "knee": "hip", "ankle": "knee"}


def rotations_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotations (..., 3, 3) that turn unit vectors a onto b."""
    a, b = np.broadcast_arrays(a, b)
    axis = np.cross(a, b)
    sin = np.linalg.norm(axis, axis=-1)
    cos = np.sum(a * b, axis=-1)
    k = axis / np.maximum(sin, 1e-12)[..., None]
    skew = np.zeros(a.shape + (3,))
    skew[..., 0, 1], skew[..., 0, 2], skew[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    skew -= np.swapaxes(skew, -1, -2)
    # (Directions a half turn apart do not occur between two standing bodies.)
    return np.eye(3) + sin[..., None, None] * skew + (1.0 - cos)[..., None, None] * skew @ skew


def _segment(key: tuple) -> tuple[str, str]:
    """('dir', 'left_knee', 'left_ankle') -> ('left_', 'knee')."""
    side, joint = key[1].rsplit("_", 1)
    return side + "_", joint


def neutral_calibration(retargeter, source_landmarks: set[str]) -> dict:
    """{direction target key: (body frame, C, parent key or None, parent's rest
    direction in the body frame)} of one embodiment, measured by its
    `retargeter.Retargeter` (which calls this, so is not imported); empty for
    a source without a torso."""
    from hotu_drake.retarget.tree import axis_angles, rotation_vector

    r = retargeter
    src = {name: point[None] for name, point in udh_rest_landmarks().items() if name in source_landmarks}
    if not {"pelvis", "chest", "left_shoulder", "right_shoulder"} <= set(src):
        return {}
    src_frames = source_frames(src)
    q = r.embodiment.standing_pose.copy()
    base, rotations, positions = r.root_path(src, src_frames, r.scale_ratio(src))
    if base is not None:
        q[r.base] = base[0]
    with r.sideways_weighted(NEUTRAL_SIDEWAYS_FACTOR):  # the neutral legs stand at the robot's own width
        r._solve_parts(q, q.copy(), rotations[0], positions[0], 0, src, src_frames, NEUTRAL_SWEEPS)
    pose = r.tree.forward(q, rotations[0], positions[0])
    hinges = {part.name: part.problem.joints[0] for part in r.parts if len(part.problem.joints) == 1}
    keys = [key for part in r.parts for _, key in part.targets if isinstance(key, tuple) and key[0] == "dir"]
    keys = [key for key in keys if _segment(key)[1] in CALIBRATED]
    calibration = {}
    for key in keys:
        side, joint = _segment(key)
        frame = "pelvis" if joint in LEG else "chest"
        body = src_frames[frame][0]
        human = body.T @ normalize(src[key[2]][0] - src[key[1]][0], floor=1e-9)
        if joint == "ankle":  # a foot's neutral is flat on the floor: its links' pose at rest
            robot = body.T @ normalize(r.rest[key[2]] - r.rest[key[1]], floor=1e-9)
        else:
            robot = body.T @ normalize(r.marks.position(pose, key[2]) - r.marks.position(pose, key[1]), floor=1e-9)
        turn = rotation_vector(rotations_between(human, robot))
        if key[1] in hinges and joint != "ankle":  # keep what lies out of the hinge's plane (a foot's pitch counts)
            axis = body.T @ pose.joint_axes[hinges[key[1]]]
            turn = turn - np.dot(turn, axis) * axis
        if np.linalg.norm(turn) < SMALLEST_TURN:  # the neutral solve's residual, not the robot's build
            continue
        parent = ("dir", side + PARENT_SEGMENT[joint], key[1]) if joint in PARENT_SEGMENT else None
        parent_rest = None
        if parent is not None and parent in keys:
            parent_rest = body.T @ normalize(src[parent[2]][0] - src[parent[1]][0], floor=1e-9)
        else:
            parent = None
        calibration[key] = (
            frame,
            axis_angles(turn[None] / max(np.linalg.norm(turn), 1e-12), np.linalg.norm(turn)[None])[0],
            parent,
            parent_rest,
        )
    return calibration


def calibrate(calibration: dict, key, directions: np.ndarray, src: dict, src_frames: dict) -> np.ndarray:
    """Source directions (T, 3) of direction target `key`, turned as the
    embodiment's neutral pose holds them (unchanged without a calibration)."""
    if key not in calibration:
        return directions
    frame, turn, parent, parent_rest = calibration[key]
    body = src_frames[frame]  # (T, 3, 3)
    if parent is not None:  # the parent segment's swing from rest, in the body frame
        parent_now = normalize(src[parent[2]] - src[parent[1]], floor=1e-9)
        swing = rotations_between(parent_rest, np.einsum("tji,tj->ti", body, parent_now))
        body = body @ swing
    local = np.einsum("tji,tj->ti", body, directions)
    return np.einsum("tij,tj->ti", body, local @ turn.T)
