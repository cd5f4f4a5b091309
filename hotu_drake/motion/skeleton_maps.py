"""Skeleton maps: which BVH joint carries each human landmark.

A map is {landmark: target}; a target names a joint (its origin) or, as
`"JointName:end"`, the joint's End Site. Built-in families cover the common
naming conventions and are chosen by how many landmarks they find in a file;
a user map (YAML file or dict) overrides single entries or whole skeletons.

Landmark semantics (see `hotu_drake.motion.human`): shoulder = upper-arm
joint, elbow = forearm joint, wrist = hand joint, hand = a point about 0.1 m
beyond the wrist (knuckles), hip = upper-leg joint, ankle = foot joint,
toe = ball of the foot, chest = upper spine, spine = lower spine.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from hotu_drake.embodiment.spec import FINGERS, SIDES
from hotu_drake.motion.clip import ClipFormatError
from hotu_drake.motion.human import (
    AXIAL_LANDMARKS,
    FINGER_POINTS,
    LANDMARKS,
    LIMB_LANDMARKS,
    REQUIRED_LANDMARKS,
)

END = ":end"

# Per family: axial landmarks, limb landmarks with side placeholders, finger
# landmarks, and signature joints (names only this family uses, to break ties).
# Placeholders: {Side} = Left/Right, {S} = L/R, {side} = left/right.
# Each landmark lists candidate targets, the first one found wins.
_FAMILIES: dict[str, dict] = {
    "cmu_motionbuilder": {
        "axial": {
            "pelvis": ("Hips",),
            "spine": ("Spine",),
            "chest": ("Spine1",),
            # CMU's Neck sits at Spine1's origin; Neck1 is the neck proper.
            "neck": ("Neck1", "Neck"),
            "head": ("Head",),
            "head_top": ("Head:end",),
        },
        "limb": {
            "shoulder": ("{Side}Arm",),
            "elbow": ("{Side}ForeArm",),
            "wrist": ("{Side}Hand",),
            "hand": ("{S}Fingers", "{Side}HandIndex1", "{Side}FingerBase:end"),
            "hip": ("{Side}UpLeg",),
            "knee": ("{Side}Leg",),
            "ankle": ("{Side}Foot",),
            "toe": ("{Side}ToeBase", "{Side}Foot:end"),
        },
        # One chain carries the four fingers together (FingerBase -> Fingers ->
        # tips) and one the thumb (from the wrist): only the tips are points
        # of their own; a finger is matched from the knuckles (`hand`) to its
        # tip, the thumb from the wrist (`retargeter.whole_finger_points`).
        "finger": {
            "names": {
                "thumb": "Thumb",
                "index": "Fingers",
                "middle": "Fingers",
                "ring": "Fingers",
                "little": "Fingers",
            },
            "points": {4: ("{S}{F}:end",)},
        },
        "signature": ("LHipJoint", "RHipJoint", "LowerBack", "Neck1", "LeftFingerBase", "LFingers", "LThumb"),
    },
    "cmu_3dsmax": {
        "axial": {
            "pelvis": ("Hips",),
            "spine": ("Chest",),
            "chest": ("Chest2", "Chest"),
            "neck": ("Neck",),
            "head": ("Head",),
            "head_top": ("Head:end",),
        },
        "limb": {
            "shoulder": ("{Side}Shoulder",),
            "elbow": ("{Side}Elbow",),
            "wrist": ("{Side}Wrist",),
            "hand": ("{Side}Wrist:end",),
            "hip": ("{Side}Hip",),
            "knee": ("{Side}Knee",),
            "ankle": ("{Side}Ankle",),
            "toe": ("{Side}Toe", "{Side}Ankle:end"),
        },
        "finger": {},
        "signature": ("LeftCollar", "RightCollar", "Chest2", "LeftElbow", "LeftKnee"),
    },
    "mixamo": {
        "axial": {
            "pelvis": ("Hips",),
            "spine": ("Spine",),
            "chest": ("Spine2", "Spine1"),
            "neck": ("Neck",),
            "head": ("Head",),
            "head_top": ("HeadTop_End", "Head:end"),
        },
        "limb": {
            "shoulder": ("{Side}Arm",),
            "elbow": ("{Side}ForeArm",),
            "wrist": ("{Side}Hand",),
            "hand": ("{Side}HandMiddle1", "{Side}Hand:end"),
            "hip": ("{Side}UpLeg",),
            "knee": ("{Side}Leg",),
            "ankle": ("{Side}Foot",),
            "toe": ("{Side}ToeBase", "{Side}Foot:end"),
        },
        # Finger point i -> joint {Side}Hand<Finger>i (4 = the end joint).
        "finger": {
            "names": {"thumb": "Thumb", "index": "Index", "middle": "Middle", "ring": "Ring", "little": "Pinky"},
            "points": {
                1: ("{Side}Hand{F}1",),
                2: ("{Side}Hand{F}2",),
                3: ("{Side}Hand{F}3",),
                4: ("{Side}Hand{F}4", "{Side}Hand{F}3:end"),
            },
        },
        "signature": ("Spine2", "HeadTop_End", "LeftToe_End", "LeftHandIndex1", "LeftHandThumb1"),
    },
    "optitrack": {
        "axial": {
            "pelvis": ("Hip",),
            "spine": ("Ab",),
            "chest": ("Chest",),
            "neck": ("Neck",),
            "head": ("Head",),
            "head_top": ("Head:end",),
        },
        "limb": {
            "shoulder": ("{S}UArm",),
            "elbow": ("{S}FArm",),
            "wrist": ("{S}Hand",),
            "hand": ("{S}Middle1", "{S}Hand:end"),
            "hip": ("{S}Thigh",),
            "knee": ("{S}Shin",),
            "ankle": ("{S}Foot",),
            "toe": ("{S}Toe", "{S}Foot:end"),
        },
        "finger": {
            "names": {"thumb": "Thumb", "index": "Index", "middle": "Middle", "ring": "Ring", "little": "Pinky"},
            "points": {1: ("{S}{F}1",), 2: ("{S}{F}2",), 3: ("{S}{F}3",), 4: ("{S}{F}3:end",)},
        },
        "signature": ("Ab", "LUArm", "LFArm", "LThigh", "LShin"),
    },
    "daz": {
        "axial": {
            "pelvis": ("hip",),
            "spine": ("abdomen",),
            "chest": ("chest",),
            "neck": ("neck",),
            "head": ("head",),
            "head_top": ("head:end",),
        },
        "limb": {
            "shoulder": ("{s}Shldr",),
            "elbow": ("{s}ForeArm",),
            "wrist": ("{s}Hand",),
            "hand": ("{s}Hand:end",),
            "hip": ("{s}Thigh",),
            "knee": ("{s}Shin",),
            "ankle": ("{s}Foot",),
            "toe": ("{s}Toe", "{s}Foot:end"),
        },
        "finger": {},
        "signature": ("abdomen", "lShldr", "lButtock", "lCollar"),
    },
    # Files written by `hotu_drake.motion.bvh.write_udh_bvh`: one site per landmark.
    "hotu_udh": {
        "axial": {name: (f"{name}_site",) for name in AXIAL_LANDMARKS},
        "limb": {name: (f"{{side}}_{name}_site",) for name in LIMB_LANDMARKS},
        "finger": {
            "names": {finger: finger for finger in FINGERS},
            "points": {i: (f"{{side}}_{{F}}_{i}_site",) for i in FINGER_POINTS},
        },
        "signature": ("pelvis_site", "head_top_site", "left_toe_site"),
    },
}
FAMILY_NAMES: tuple[str, ...] = tuple(_FAMILIES)


def _fill(template: str, side: str, finger: str = "") -> str:
    return template.format(Side=side.capitalize(), S=side[0].upper(), s=side[0], side=side, F=finger)


def family_map(name: str) -> dict[str, tuple[str, ...]]:
    """The candidate targets of every landmark in built-in family `name`."""
    family = _FAMILIES[name]
    out: dict[str, tuple[str, ...]] = dict(family["axial"])
    for side in SIDES:
        for limb, templates in family["limb"].items():
            out[f"{side}_{limb}"] = tuple(_fill(t, side) for t in templates)
        if family["finger"]:
            for finger, label in family["finger"]["names"].items():
                for point, templates in family["finger"]["points"].items():
                    out[f"{side}_{finger}_{point}"] = tuple(_fill(t, side, label) for t in templates)
    return out


class JointNames:
    """Looks up joint names tolerantly: exact, then case-insensitive, then
    after a namespace or asset prefix (`mixamorig:Hips`, `Skeleton1_Hip`)."""

    def __init__(self, names: Sequence[str], end_sites: Sequence[bool]) -> None:
        self.names = list(names)
        self.has_end = list(end_sites)
        self._exact = {n: i for i, n in enumerate(self.names)}
        self._lower: dict[str, int] = {}
        for i, n in enumerate(self.names):
            self._lower.setdefault(n.lower(), i)

    def find(self, joint: str) -> int | None:
        """Index of the joint called `joint`, or None."""
        if joint in self._exact:
            return self._exact[joint]
        key = joint.lower()
        if key in self._lower:
            return self._lower[key]
        hits = [i for i, n in enumerate(self.names) if n.lower().endswith((":" + key, "_" + key))]
        return hits[0] if len(hits) == 1 else None

    def resolve(self, target: str) -> tuple[int, bool] | None:
        """(joint index, End Site?) of a target, or None when absent."""
        end = target.lower().endswith(END)
        index = self.find(target[: -len(END)] if end else target)
        if index is None or (end and not self.has_end[index]):
            return None
        return index, end


def resolve_map(candidates: Mapping[str, Sequence[str]], joints: JointNames) -> dict[str, tuple[int, bool]]:
    """Landmark -> (joint index, End Site?) for every landmark whose target exists.

    Optional landmarks that land on a point already taken are dropped (a
    zero-length segment carries no direction).
    """
    out: dict[str, tuple[int, bool]] = {}
    order = [n for n in LANDMARKS if n in REQUIRED_LANDMARKS] + [n for n in LANDMARKS if n not in REQUIRED_LANDMARKS]
    for landmark in order:
        for target in candidates.get(landmark, ()):
            hit = joints.resolve(target)
            if hit is None:
                continue
            if landmark not in REQUIRED_LANDMARKS and hit in out.values():
                continue
            out[landmark] = hit
            break
    return out


def best_family(joints: JointNames) -> tuple[str | None, dict[str, tuple[int, bool]]]:
    """The built-in family that finds the most landmarks (required ones first)."""
    best, best_key, best_map = None, None, {}
    for name, family in _FAMILIES.items():
        resolved = resolve_map(family_map(name), joints)
        required = sum(n in resolved for n in REQUIRED_LANDMARKS)
        signature = sum(joints.find(s) is not None for s in family["signature"])
        key = (required, signature, len(resolved))
        if best_key is None or key > best_key:
            best, best_key, best_map = name, key, resolved
    if best_key is None or best_key[0] < len(REQUIRED_LANDMARKS):
        return None, best_map
    return best, best_map


def load_user_map(source: str | Path | Mapping) -> dict[str, str | None]:
    """A user map from a YAML file or a dict: {landmark: target or null}.

    A top-level `landmarks:` key is accepted too. Raises `ClipFormatError`
    naming the map on an unreadable file or an unknown landmark.
    """
    where = "skeleton map" if isinstance(source, Mapping) else str(source)
    data = source if isinstance(source, Mapping) else _read_yaml(Path(source))
    if isinstance(data, Mapping) and isinstance(data.get("landmarks"), Mapping):
        data = data["landmarks"]
    if not isinstance(data, Mapping):
        raise ClipFormatError(f"{where}: a skeleton map must be a mapping {{landmark: joint name}}")
    out: dict[str, str | None] = {}
    for landmark, target in data.items():
        if landmark not in LANDMARKS:
            raise ClipFormatError(f"{where}: unknown landmark {landmark!r} (see hotu_drake.motion.human.LANDMARKS)")
        if target is not None and not isinstance(target, str):
            raise ClipFormatError(f"{where}: the target of {landmark} must be a joint name, not {target!r}")
        out[str(landmark)] = target
    return out


def _read_yaml(path: Path):
    if not path.is_file():
        raise ClipFormatError(f"{path}: no such skeleton map file")
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        import yaml

        return yaml.safe_load(text)
    except ImportError:
        pass
    except Exception as error:  # yaml.YAMLError and friends
        raise ClipFormatError(f"{path}: not valid YAML ({type(error).__name__})") from None
    from pydrake.common.yaml import yaml_load

    try:
        return yaml_load(data=text)
    except Exception as error:
        raise ClipFormatError(f"{path}: not valid YAML ({type(error).__name__})") from None


def apply_user_map(
    resolved: dict[str, tuple[int, bool]], user: Mapping[str, str | None], joints: JointNames, where: str
) -> dict[str, tuple[int, bool]]:
    """`resolved` with the user's entries on top; a target the file lacks is an error."""
    out = dict(resolved)
    for landmark, target in user.items():
        if target is None:
            out.pop(landmark, None)
            continue
        hit = joints.resolve(target)
        if hit is None:
            raise ClipFormatError(f"{where}: the skeleton map names {target!r} (for {landmark}), not in this file")
        out[landmark] = hit
    return out
