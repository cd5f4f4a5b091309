"""Where the human landmarks sit on an embodiment (UDH or robot).

Retargeting matches the directions between landmarks (shoulder -> elbow,
wrist -> hand, ...), so each embodiment needs the same named points on its
own links. They follow from the joint naming convention: a shoulder is the
first shoulder joint, an elbow the first elbow joint, and so on; hands come
from the mounted hand model (also for `hands="none"`, so a hand's
orientation is known without fingers); toes from the feet's contact shapes.
Each landmark is (link, offset in that link's frame); link frames are
world-aligned at q = 0, so offsets are world vectors at q = 0.
"""

import numpy as np

from hotu_drake.embodiment.spec import FINGER_PART, FINGERS, SIDES, EmbodimentSpec


def _first_joint(spec: EmbodimentSpec, prefix: str):
    for joint in spec.joints:
        if joint.name.startswith(prefix):
            return joint
    return None


def _world_origin(spec: EmbodimentSpec, link: str) -> np.ndarray:
    return np.asarray(spec.link(link).origin, dtype=float)


def _joint_point(spec: EmbodimentSpec, joint) -> tuple[str, np.ndarray]:
    """A joint's location, attached to the joint's parent link."""
    child_origin = _world_origin(spec, joint.child)
    return joint.parent, child_origin - _world_origin(spec, joint.parent)


def _attach(spec: EmbodimentSpec, link: str, world_point: np.ndarray) -> tuple[str, np.ndarray]:
    return link, np.asarray(world_point, dtype=float) - _world_origin(spec, link)


def _world(spec: EmbodimentSpec, placement: tuple[str, np.ndarray]) -> np.ndarray:
    return _world_origin(spec, placement[0]) + placement[1]


def _head(spec: EmbodimentSpec, out: dict) -> None:
    head_link = spec.key_bodies["head"]
    spheres = [g for g in spec.link(head_link).visuals if g.shape == "sphere"]
    if spheres:
        top = max(spheres, key=lambda g: g.position[2])
        center, radius = np.asarray(top.position, dtype=float), top.size[0]
    else:
        center, radius = np.array([0.0, 0.0, 0.1]), 0.08
    out["head"] = (head_link, center)
    out["head_top"] = (head_link, center + [0.0, 0.0, radius])
    out["head_front"] = (head_link, center + [0.1, 0.0, 0.0])
    neck = _first_joint(spec, "neck_")
    if neck is not None:
        out["neck"] = _joint_point(spec, neck)
    else:  # no neck joint: above the chest at the base of the head
        shoulders = 0.5 * (_world(spec, out["left_shoulder"]) + _world(spec, out["right_shoulder"]))
        base = _world(spec, out["head"]) - [0.0, 0.0, 1.5 * radius]
        chest = _world(spec, out["chest"])
        out["neck"] = _attach(spec, spec.key_bodies["torso"], [chest[0], 0.0, max(base[2], shoulders[2])])


def _hand(spec: EmbodimentSpec, side: str, out: dict) -> None:
    from hotu_drake.embodiment.hands import HAND_LANDMARKS

    hand_link = f"{side}_hand"
    # The wrist is where the hand turns: the last wrist joint (NAVIAI's first
    # wrist joint twists the forearm next to the elbow).
    wrists = [j for j in spec.joints if j.name.startswith(f"{side}_wrist_")]
    wrist = wrists[-1] if wrists else None
    if wrist is not None:
        out[f"{side}_wrist"] = _joint_point(spec, wrist)
    if side not in spec.hand_mounts:
        if wrist is None:  # no wrist and no hand (BRUCE): the forearm's end
            capsule = spec.link(hand_link).visuals[0]
            out[f"{side}_wrist"] = (hand_link, 2.0 * np.asarray(capsule.position))
        return
    model, linear, root = spec.hand_mounts[side]
    for name, point in HAND_LANDMARKS[model].items():
        out[f"{side}_{name}"] = _attach(spec, hand_link, root + linear @ np.asarray(point))
    if spec.hands != "full":
        return
    for finger in FINGERS:
        joints = [j for j in spec.joints if j.part == FINGER_PART and j.name.startswith(f"{side}_{finger}_")]
        if not joints:
            continue
        # Points 1-3 at evenly spread joints, 4 at the tip of the last phalanx.
        picks = np.unique(np.round(np.linspace(0, len(joints) - 1, 3)).astype(int))
        if finger == "thumb" and len(joints) > 2:
            picks = np.unique(np.round(np.linspace(1, len(joints) - 1, 3)).astype(int))
        for point, index in enumerate(picks, start=1):
            link = joints[index].child
            out[f"{side}_{finger}_{point}"] = (link, np.zeros(3))
        last = spec.link(joints[-1].child)
        out[f"{side}_{finger}_4"] = (last.name, 2.0 * np.asarray(last.visuals[0].position))


def _foot(spec: EmbodimentSpec, side: str, out: dict) -> None:
    ankle = _first_joint(spec, f"{side}_ankle_")
    foot = spec.key_bodies[f"{side}_foot"]
    out[f"{side}_ankle"] = _joint_point(spec, ankle)
    contacts = np.array([g.position for g in spec.link(foot).collisions], dtype=float)
    radius = min(g.size[0] for g in spec.link(foot).collisions)
    front = contacts[:, 0].max()
    ball = np.array([0.8 * front, 0.0, contacts[:, 2].min() - radius + 0.01])
    out[f"{side}_toe"] = (foot, ball)


def landmark_placements(spec: EmbodimentSpec) -> dict[str, tuple[str, np.ndarray]]:
    """Landmark -> (link, offset in the link's frame) for the landmarks this embodiment has."""
    out: dict[str, tuple[str, np.ndarray]] = {}
    pelvis = spec.key_bodies["pelvis"]
    out["pelvis"] = (pelvis, np.zeros(3))
    for side in SIDES:
        for name, prefix in (("shoulder", "shoulder"), ("elbow", "elbow"), ("hip", "hip"), ("knee", "knee")):
            joint = _first_joint(spec, f"{side}_{prefix}_")
            if joint is not None:
                out[f"{side}_{name}"] = _joint_point(spec, joint)
        _hand(spec, side, out)
        if f"{side}_foot" in spec.key_bodies:
            _foot(spec, side, out)
    if "left_hip" in out:  # the pelvis point sits between the hip joints, as a mocap root does
        hips = 0.5 * (_world(spec, out["left_hip"]) + _world(spec, out["right_hip"]))
        out["pelvis"] = _attach(spec, pelvis, hips)
    shoulders = 0.5 * (_world(spec, out["left_shoulder"]) + _world(spec, out["right_shoulder"]))
    upper_arm = np.linalg.norm(_world(spec, out["left_elbow"]) - _world(spec, out["left_shoulder"]))
    # The chest sits straight below the neck (so an upright torso has an
    # upright chest frame on every embodiment), half an upper arm below the
    # shoulders.
    neck = _first_joint(spec, "neck_")
    x = _world(spec, _joint_point(spec, neck))[0] if neck is not None else shoulders[0]
    out["chest"] = _attach(spec, spec.key_bodies["torso"], [x, 0.0, shoulders[2] - 0.5 * upper_arm])
    base = _world(spec, out["pelvis"])
    out["spine"] = _attach(spec, pelvis, base + 0.35 * (_world(spec, out["chest"]) - base))
    _head(spec, out)  # after the chest: a robot without a neck joint puts its neck above it
    return out
