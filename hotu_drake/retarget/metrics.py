"""How good a retargeted clip is, against its human source.

Directions and key-body offsets are compared in each body's heading frame
(yaw of the pelvis), so a robot that walks the same way but is smaller or
turned is judged by its posture, not its position.
"""

import numpy as np

from hotu_drake import embodiment as embodiments
from hotu_drake.embodiment.landmarks import landmark_placements
from hotu_drake.embodiment.spec import FINGERS
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import FINGER_POINTS, body_height, landmarks_of
from hotu_drake.motion.udh_skeleton import points_on_clip
from hotu_drake.retarget import frames
from hotu_drake.retarget.balance import ON_FLOOR, ClipBalance, TorqueDemand, clear_of_flight, inside_share
from hotu_drake.retarget.contacts import Soles, detect_foot_contacts
from hotu_drake.retarget.neutral import calibrate
from hotu_drake.retarget.retargeter import Retargeter, foot_contacts_of, whole_finger_points
from hotu_drake.retarget.source_frames import source_frames
from hotu_drake.retarget.stance import leg_contacts, stance
from hotu_drake.retarget.tree import Pose, Tree
from hotu_drake.rotations import finite_difference, heading_rotation, quat_to_matrix, rotation_log

# The segment that shows each part's posture (torso and neck: a body frame).
PART_FRAMES = {"torso": frames.chest_frame, "neck": frames.head_frame}
PART_SEGMENTS = {
    "shoulder": ("shoulder", "elbow"),
    "elbow": ("elbow", "wrist"),
    "wrist": ("wrist", "hand"),
    "hip": ("hip", "knee"),
    "knee": ("knee", "ankle"),
    "ankle": ("ankle", "toe"),
}
# The direction error as measured, and relative to the robot's neutral pose (`neutral`).
DIRECTION_FIGURES = ("part_direction_error_deg", "part_direction_error_neutral_deg")
# Key bodies and the landmark they are measured from (hands from the chest,
# feet from the pelvis), so a wheeled base or a short torso is not penalised twice.
KEY_BODIES = {"left_wrist": "chest", "right_wrist": "chest", "left_ankle": "pelvis", "right_ankle": "pelvis"}
LEG_PENETRATION_ALLOWED = 0.005  # m: deeper than this between the two legs counts (`leg_penetration_share`)
PLANTED_HIGH = 0.01  # m: a planted sole higher than this above the floor counts (`planted_sole_height_m`)


def clip_landmarks(emb: embodiments.Embodiment, clip: MotionClip) -> dict[str, np.ndarray]:
    """World positions of an embodiment's landmarks over a clip."""
    return points_on_clip(emb, clip, landmark_placements(emb.spec))


def _heading(points: dict[str, np.ndarray]) -> np.ndarray:
    """The body's heading: the pelvis's, or the chest's for a capture of the upper body."""
    return heading_rotation(frames.pelvis_frame(points) if "left_hip" in points else frames.chest_frame(points))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def _angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.sum(_unit(a) * _unit(b), axis=-1), -1.0, 1.0)))


def _margin_figures(margins: np.ndarray) -> dict:
    supported = margins[~np.isnan(margins)]
    if not supported.size:
        return {"inside_share": None, "median_m": None, "least_m": None}
    return {
        "inside_share": round(inside_share(supported), 4),
        "median_m": round(float(np.median(supported)), 4),
        "least_m": round(float(supported.min()), 4),
    }


def balance_figures(
    emb: embodiments.Embodiment, clip: MotionClip, contacts: dict, before=None, poses: Pose | None = None
) -> dict:
    """The clip's centre-of-pressure margin inside its planted soles (share of
    the frames with a foot down where it is inside, median, least; before the
    balance pass too when given) and the torques it asks of each joint
    against its limit (share of frames over any limit; each joint over its
    limit: on what share of frames, and by how much at most). `poses`: the
    clip's (`clip_poses`), if already posed."""
    dynamics = ClipBalance(emb)
    poses = clip_poses(dynamics.tree, clip) if poses is None else poses
    _, pressure = dynamics.centroidal(poses, clip.fps)
    margins = dynamics.support_margin(poses, pressure, contacts)
    margin = {"after": _margin_figures(margins)}
    if contacts:  # the share over the frames whose estimate does not straddle a flight phase (a jump's)
        share = inside_share(margins[clear_of_flight(contacts, clip.fps)])
        margin["after"]["inside_share_clear_of_flight"] = None if share is None else round(share, 4)
    if before is not None:
        margin = {"before": _margin_figures(np.asarray(before))} | margin
    ratios = TorqueDemand(emb).ratios(clip, contacts)
    over = ratios > 1.0
    joints = {
        name: {"share": round(float(over[:, j].mean()), 4), "most": round(float(ratios[:, j].max()), 2)}
        for j, name in enumerate(emb.joint_names)
        if over[:, j].any()
    }
    return {
        "centre_of_pressure_margin": margin,
        "torque_over_limit_share": round(float(over.any(axis=1).mean()), 4),
        "torque_over_limit": dict(sorted(joints.items(), key=lambda item: -item[1]["share"])),
    }


def clip_poses(tree: Tree, clip: MotionClip) -> Pose:
    """Every link's pose on every frame of `clip` (one vectorised pass)."""
    return tree.forward_frames(clip.joint_positions, quat_to_matrix(clip.root_quaternion), clip.root_position)


def planted_sole_tilt(
    emb: embodiments.Embodiment, tree: Tree, clip: MotionClip, contacts: dict, poses: Pose | None = None
) -> dict:
    """How far (degrees) each planted foot's sole is from flat on the floor,
    median and most over the planted frames: a robot stands on a flat sole
    (every shipped foot's sole is flat in its link's frame), not on a heel
    with its toes up. `poses`: the clip's (`clip_poses`), if already posed."""
    poses = clip_poses(tree, clip) if poses is None else poses
    tilts = []
    for side, planted in contacts.items():
        link = tree.link_index[emb.key_bodies[f"{side}_foot"]]
        up = poses.rotations[np.asarray(planted, bool), link, 2, 2]  # the sole's normal, its world z
        tilts.append(np.degrees(np.arccos(np.clip(up, -1.0, 1.0))))
    tilt = np.concatenate(tilts) if tilts else np.zeros(0)
    if not tilt.size:
        return {"median": None, "most": None}
    return {"median": round(float(np.median(tilt)), 2), "most": round(float(tilt.max()), 2)}


def planted_sole_height(
    emb: embodiments.Embodiment, tree: Tree, clip: MotionClip, contacts: dict, poses: Pose | None = None
) -> dict:
    """How high (m) a planted foot's lowest sole point is above the floor,
    median and most over the planted frames, and the share of those frames
    more than `PLANTED_HIGH` up: a foot the clip says stands is on the floor,
    not hovering (a controller that trusts the flag stands on air)."""
    soles = Soles(emb.spec, tree)
    poses = clip_poses(tree, clip) if poses is None else poses
    heights = [
        soles.lowest_frames(poses, side)[np.asarray(planted, bool)]
        for side, planted in contacts.items()
        if side in soles.feet
    ]
    height = np.concatenate(heights) if heights else np.zeros(0)
    if not height.size:
        return {"median": None, "most": None, "high_share": None}
    return {
        "median": round(float(np.median(height)), 4),
        "most": round(float(height.max()), 4),
        "high_share": round(float(np.mean(height > PLANTED_HIGH)), 4),
    }


def planted_sole_slip(
    emb: embodiments.Embodiment, tree: Tree, clip: MotionClip, contacts: dict, poses: Pose | None = None
) -> float | None:
    """How fast (m/s, horizontally) a planted foot's sole slides where it is
    on the floor: per planted frame, the mean speed of its sole points within
    `balance.ON_FLOOR` of the floor (a flat sole's every point, a rolling
    foot's edge), averaged over the planted frames. A foot rolling over its
    toes is not slipping though its ankle moves (`foot_skate_m_per_s`, the
    ankle's speed, counts it)."""
    soles = Soles(emb.spec, tree)
    poses = clip_poses(tree, clip) if poses is None else poses
    speeds = []
    for side, planted in contacts.items():
        if side not in soles.feet:
            continue
        world, radii = soles.points_frames(poses, side)
        speed = np.linalg.norm(finite_difference(world[..., :2], clip.fps), axis=-1)  # (T, K)
        down = world[..., 2] - radii < ON_FLOOR
        frames = np.asarray(planted, bool) & down.any(axis=1)
        speeds.append((speed * down).sum(axis=1)[frames] / down.sum(axis=1)[frames])
    speed = np.concatenate(speeds) if speeds else np.zeros(0)
    return round(float(speed.mean()), 4) if speed.size else None


def report(
    source: MotionClip, result: MotionClip, emb: embodiments.Embodiment, seconds: float, margins: dict | None = None
) -> dict:
    """The per-clip, per-robot figures of `--report` (`margins`: the balance
    pass's support margins before it, per frame, when it ran)."""
    src = landmarks_of(source)
    dst = clip_landmarks(emb, result)
    frames_count = result.num_frames
    q = result.joint_positions
    violations = int(np.sum((q < emb.position_lower - 1e-9) | (q > emb.position_upper + 1e-9)))
    out = {
        "frames": frames_count,
        "frames_per_second": round(frames_count / seconds, 1) if seconds > 0 else None,
        "joint_limit_violations": violations,
        "part_direction_error_deg": {},
    }
    legged = "left_hip" in dst and "left_hip" in src
    h_src = _heading(src)
    h_dst = _heading(dst) if legged else h_src
    for part, frame_of in PART_FRAMES.items():
        needed = {"neck", "head_top", "left_shoulder", "right_shoulder", "chest"}
        if emb.part_dof[part] > 0 and needed <= set(src) and needed <= set(dst):
            f_src = np.swapaxes(h_src, -1, -2) @ frame_of(src)
            f_dst = np.swapaxes(h_dst, -1, -2) @ frame_of(dst)
            e = np.degrees(np.linalg.norm(rotation_log(np.swapaxes(f_src, -1, -2) @ f_dst), axis=-1))
            out["part_direction_error_deg"][part] = {"mean": round(float(e.mean()), 2), "max": round(float(e.max()), 2)}
    neutral = Retargeter(emb, set(src)).calibration if emb.name != "udh" else {}
    body_frames = {"pelvis": frames.pelvis_frame(src) if "left_hip" in src else None, "chest": frames.chest_frame(src)}
    out["part_direction_error_neutral_deg"] = {}
    for part, (start, end) in PART_SEGMENTS.items():
        errors, from_neutral = [], []
        for side in ("left_", "right_"):
            a, b = side + start, side + end
            if {a, b} <= set(src) and {a, b} <= set(dst) and emb.part_dof[part] > 0:
                d_src = np.einsum("tji,tj->ti", h_src, src[b] - src[a])
                d_dst = np.einsum("tji,tj->ti", h_dst, dst[b] - dst[a])
                errors.append(_angles(d_src, d_dst))
                # The same, with the source direction turned as the robot's neutral pose holds it.
                turned = calibrate(neutral, ("dir", a, b), src[b] - src[a], src, body_frames)
                from_neutral.append(_angles(np.einsum("tji,tj->ti", h_src, turned), d_dst))
        if errors:
            for key, values in zip(DIRECTION_FIGURES, (errors, from_neutral)):
                e = np.concatenate(values)
                out[key][part] = {"mean": round(float(e.mean()), 2), "max": round(float(e.max()), 2)}
    finger_errors = []
    src_hands = source_frames(src)
    for side in ("left", "right"):
        if f"{side}_hand" not in src_hands or not {f"{side}_index_1", f"{side}_little_1"} <= set(dst):
            continue
        for finger in FINGERS:
            # The segment the retargeting matched: base to tip, or the whole finger of a coarser capture.
            chain = [f"{side}_{finger}_{i}" for i in FINGER_POINTS]
            a, b = chain[0], chain[-1]
            pair = (a, b, a, b) if set(chain) <= set(src) else whole_finger_points(set(src), set(dst), side, finger)
            if pair is not None and {pair[2], pair[3]} <= set(dst):
                d_src = np.einsum("tji,tj->ti", src_hands[f"{side}_hand"], src[pair[1]] - src[pair[0]])
                d_dst = np.einsum("tji,tj->ti", frames.hand_frame(dst, side), dst[pair[3]] - dst[pair[2]])
                finger_errors.append(_angles(d_src, d_dst))
    if finger_errors:
        e = np.concatenate(finger_errors)
        out["part_direction_error_deg"]["finger"] = {"mean": round(float(e.mean()), 2), "max": round(float(e.max()), 2)}

    keys = [k for k in KEY_BODIES if k in src and k in dst]
    if keys and "pelvis" in dst:
        hs = body_height(src)
        hd = body_height(dst) if legged else hs
        errs = []
        for key in keys:
            base = KEY_BODIES[key]
            rel_src = np.einsum("tji,tj->ti", h_src, src[key] - src[base]) / hs
            rel_dst = np.einsum("tji,tj->ti", h_dst, dst[key] - dst[base]) / hd
            errs.append(np.linalg.norm(rel_src - rel_dst, axis=-1))
        out["key_body_error"] = round(float(np.mean(errs)), 4)
    if legged:
        contacts = foot_contacts_of(source, source.num_frames) or detect_foot_contacts(src, source.fps)
        speeds = []
        for side in ("left", "right"):
            ankle = dst[f"{side}_ankle"]
            speed = np.linalg.norm(finite_difference(ankle[:, :2], result.fps), axis=1)
            speeds.append(speed[contacts[side]])
        planted = np.concatenate(speeds)
        out["foot_skate_m_per_s"] = round(float(planted.mean()), 4) if planted.size else 0.0
        tree = Tree(emb.spec)
        soles, poses = Soles(emb.spec, tree), clip_poses(tree, result)
        lowest = min(float(soles.lowest_frames(poses, side).min()) for side in soles.feet)
        out["foot_penetration_m"] = round(max(0.0, -lowest), 4)
        out["planted_sole_tilt_deg"] = planted_sole_tilt(emb, tree, result, contacts, poses)
        out["planted_sole_height_m"] = planted_sole_height(emb, tree, result, contacts, poses)
        out["planted_sole_slip_m_per_s"] = planted_sole_slip(emb, tree, result, contacts, poses)
        # The robot's own stance (feet apart over its standing width), and its legs clear of each other.
        out["stance_ratio"] = stance(emb, dst)
        depths = leg_contacts(emb).depths(result)
        out["leg_penetration_m"] = round(float(depths.max()), 4)
        out["leg_penetration_share"] = round(float(np.mean(depths > LEG_PENETRATION_ALLOWED)), 4)
        if emb.floating_base:
            planted = foot_contacts_of(result, result.num_frames) or contacts
            out |= balance_figures(emb, result, planted, (margins or {}).get("before"), poses)
    else:
        out["foot_skate_m_per_s"] = None
        out["foot_penetration_m"] = None
    return out
