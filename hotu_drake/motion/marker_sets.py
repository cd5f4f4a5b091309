"""Marker sets: from labelled markers to the human landmarks, and back onto the UDH.

`markers_to_landmarks` turns markers (a C3D capture, read by
`motion.c3d.read_c3d`) into the human landmarks through a marker set.
`udh_markers` places the same markers on a UDH clip, which makes synthetic
captures for round-trip tests and is what the marker fit
(`hotu_drake.retarget.marker_fit`) matches.

Two sets are built in: `plug_in_gait` (Vicon Plug-in Gait full body:
LASI, LKNE, LANK, ...) and `anatomical` (markers on palpable bony
landmarks, named as in Van Sint Jan's atlas of skeletal landmarks (2007)
and the Qualisys sports and animation marker sets: L_IAS, L_FLE, L_FME,
L_FAL, L_TAM, L_HLE, L_RSP, ...; joint centres at the midpoints of the
epicondyles and malleoli, as the ISB recommends, Wu et al. 2002/2005). A
reader that is given no set takes the built-in one whose markers the file
has most of (`choose_marker_set`).

Your own set is a dict, or a YAML file of one:

```yaml
extends: anatomical              # optional: start from a built-in set, then override
mirror: true                     # optional: every left entry also defines the right one
frames:                          # segment orientations from markers
  pelvis: {primary: [y, [R_IAS], [L_IAS]], secondary: [x, [L_IPS, R_IPS], [L_IAS, R_IAS]]}
landmarks:                       # landmark -> rule
  neck: [CV7, SNJ]               # mean of points
  chest: {TV8: 0.5, SXS: 0.5}    # weighted mean
  left_hip: {rule: hip_joint_centre, side: left, asis: [L_IAS, R_IAS], psis: [L_IPS, R_IPS]}
  left_knee: [L_FLE, L_FME]
  left_elbow: {rule: hinge, proximal: left_shoulder, distal: left_wrist, lateral: L_HLE, distance: 0.04, sign: -1}
  left_shoulder: {rule: offset, from: L_SAJ, frame: thorax, offset: [0, 0, -0.05]}
  left_toe: {rule: offset, from: [L_FM1, L_FM5], frame: left_foot, offset: udh, optional: true}
placements:                      # where each marker sits on the nominal 1.61 m UDH (optional)
  L_FLE: {link: left_thigh, offset: [0, 0.05, -0.4215]}
```

Sections and keys:

- `extends`: a built-in set's frames, landmarks and placements come first;
  yours replace entries of the same name and add new ones. Inherited rules
  keep the offsets they had in the built-in set.
- `mirror`: `true` mirrors every left entry (`left_*` landmarks and frames,
  markers named `L...` such as `LKNE` or `L_FLE`) that has no right twin:
  names to their right twins, `side` to right, `sign` negated, lateral
  offsets (`y`) of placements negated. `[LeftPrefix, RightPrefix]` (for
  example `[Left, Right]`) names the marker prefixes instead.
- `frames`: `{primary: [axis, from, to], secondary: [axis, from, to]}`: an
  axis (x, y or z) from the mean of the `from` points to the mean of the
  `to` points; `primary` exactly, `secondary` orthogonalised to it; the
  third axis completes a right-handed frame.
- `landmarks`: a point name or list (the mean), a `{point: weight}` map
  (the weighted mean), or a rule:
  - `hip_joint_centre`: keys `side` (left or right), `method` (`harrington`,
    Harrington et al. 2007, J Biomech 40:595; or `bell`, Bell et al. 1990),
    `asis` (left and right ASIS, default `[LASI, RASI]`), `psis` (the PSIS
    markers, default `[LPSI, RPSI]`).
  - `chord`: keys `proximal`, `plane`, `lateral`, `distance` (m): the joint
    centre lies in the plane of the three points, `distance` from
    `lateral`, with the segment from `proximal` perpendicular to the one
    to `lateral` (Plug-in Gait's chord function).
  - `hinge`: keys `proximal`, `distal`, `lateral`, `distance` (m), `sign`
    (+1 or -1): `distance` from `lateral` along the hinge axis, which is
    perpendicular to both the proximal and the distal segment; `sign`
    picks the solution (the sign of axis . (p - l) x (d - l)).
  - `offset`: keys `from` (a point or list), `frame` (a frame of the set),
    `offset` (three numbers, metres, in that frame; or `udh`: the offset
    the nominal UDH has between the landmark and the `from` point, which
    needs placements of the markers involved).
  Every landmark form takes `optional: true`: leave it out when its markers
  are missing.
- `placements`: `{link: <UDH link>, offset: [x, y, z]}` per marker: where
  it sits on the nominal UDH (for `offset: udh`, for synthetic captures and
  for the marker fit). Optional otherwise.

A point named in a rule is a marker or another landmark. A capture may
cover only part of the body (the torso and arms, say): landmarks of body
regions whose markers are all missing are left out, and retargeting holds
those parts at the standing pose; a region with some of its markers
missing is an error that names them (`human.check_coverage`).
"""

import copy
import functools
import logging
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.spec import FINGERS
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.human import LANDMARKS, REGIONS, check_coverage

log = logging.getLogger("hotu_drake.input")

MarkerSetLike = str | Path | Mapping | None
AXES = {"x": 0, "y": 1, "z": 2}  # a frame axis or an up axis, by letter

_HIP_REGRESSIONS = ("harrington", "bell")
HIP_DEFAULTS = {"asis": ["LASI", "RASI"], "psis": ["LPSI", "RPSI"]}  # Plug-in Gait's names
_RULE_KEYS = {
    "hip_joint_centre": {"side"},
    "chord": {"proximal", "plane", "lateral", "distance"},
    "hinge": {"proximal", "distal", "lateral", "distance"},
    "offset": {"from", "frame", "offset"},
}
_OPTIONAL_KEYS = {"hip_joint_centre": {"method", "asis", "psis"}, "chord": set(), "hinge": {"sign"}, "offset": set()}
NOMINAL_THIGH = 0.4215  # thigh length of the nominal 1.61 m UDH
MIN_COMMON_MARKERS = 6  # a built-in set is chosen for a file only with at least this many of its markers


# --- the built-in Vicon Plug-in Gait full-body marker set -------------------


def _mirror(name: str, prefixes: tuple[str, str] | None = None) -> str:
    """Left name -> right name (left_thigh -> right_thigh; LASI -> RASI and
    L_FLE -> R_FLE, or with `prefixes` (left, right) those marker prefixes)."""
    if name.startswith("left_"):
        return "right_" + name[5:]
    if prefixes is not None:
        left, right = prefixes
        return right + name[len(left) :] if name.startswith(left) else name
    if name.startswith("L") and name[1:].isupper():
        return "R" + name[1:]
    return name


def _mirror_spec(spec, prefixes: tuple[str, str] | None = None):
    """Mirror a left-side rule, frame or placement (names; y and signs flipped)."""
    if isinstance(spec, str):
        return _mirror(spec, prefixes)
    if isinstance(spec, list):
        return [_mirror_spec(s, prefixes) for s in spec]
    if isinstance(spec, dict):
        out = {}
        for key, value in spec.items():
            if key == "offset" and "link" in spec:
                out[key] = [value[0], -value[1], value[2]]
            elif key == "link":
                out[key] = _mirror(value)
            elif key == "side":
                out[key] = "right" if value == "left" else value
            elif key == "sign":
                out[key] = -value
            elif key in ("distance", "method", "rule", "optional", "offset"):
                out[key] = value
            elif key in ("asis", "psis"):
                out[key] = value  # both sides' markers, in a fixed order
            else:
                out[_mirror(key, prefixes)] = _mirror_spec(value, prefixes)
        return out
    return spec


def _mirror_sets(data: dict, prefixes: tuple[str, str] | None) -> None:
    """Add the right twin of every left entry that has none (`mirror:`)."""
    for section in ("frames", "landmarks", "placements"):
        entries = data.get(section) or {}
        for name, spec in list(entries.items()):
            twin = _mirror(name, prefixes)
            if twin != name and twin not in entries:
                entries[twin] = _mirror_spec(spec, prefixes)


def _udh_offset(point, frame: str, optional: bool = True) -> dict:
    """An offset rule whose offset is taken from where the UDH has the landmark."""
    return {"rule": "offset", "from": point, "frame": frame, "offset": "udh", "optional": optional}


def _plug_in_gait() -> dict:
    """Vicon Plug-in Gait full body, placed on the nominal UDH.

    The placements put every marker where Plug-in Gait expects it (e.g. LASI
    at the front of the pelvis, LKNE on the lateral knee, LTHI in the plane
    of hip centre and knee axis), and the widths in the joint-centre rules
    are the matching subject measurements, so the rules recover the UDH's
    joint centres from its virtual markers. Landmarks that are not joint
    centres (chest, toe, hand, ...) use `offset: udh`: the offset the UDH
    has between the landmark and the markers.
    """
    left_landmarks = {
        "left_hip": {"rule": "hip_joint_centre", "side": "left", "method": "harrington"},
        "left_knee": {"rule": "chord", "proximal": "left_hip", "plane": "LTHI", "lateral": "LKNE", "distance": 0.055},
        "left_ankle": {"rule": "chord", "proximal": "left_knee", "plane": "LTIB", "lateral": "LANK", "distance": 0.045},
        "left_toe": _udh_offset("LTOE", "left_foot", optional=False),
        "left_shoulder": {"rule": "offset", "from": "LSHO", "frame": "thorax", "offset": [0.0, 0.0, -0.05]},
        "left_elbow": {
            "rule": "hinge",
            "proximal": "left_shoulder",
            "distal": "left_wrist",
            "lateral": "LELB",
            "distance": 0.04,
            "sign": -1,
        },
        "left_wrist": ["LWRA", "LWRB"],
        "left_hand": _udh_offset("left_wrist", "left_hand"),
        **{f"left_{finger}_1": _udh_offset("left_wrist", "left_hand") for finger in FINGERS},
    }
    left_frames = {
        "left_foot": {"primary": ["x", ["LHEE"], ["LTOE"]], "secondary": ["z", ["LHEE", "LTOE"], ["left_ankle"]]},
        "left_hand": {"primary": ["z", ["LFIN"], ["LWRA", "LWRB"]], "secondary": ["x", ["LWRB"], ["LWRA"]]},
    }
    left_placements = {
        "LFHD": ("head", (0.09, 0.05, 0.175)),
        "LBHD": ("head", (-0.09, 0.05, 0.175)),
        "LSHO": ("torso", (-0.0241, 0.1831, 0.2935)),
        "LELB": ("left_upper_arm", (0.0, 0.04, -0.2748)),
        "LWRA": ("left_hand", (0.03, 0.0, 0.0)),
        "LWRB": ("left_hand", (-0.03, 0.0, 0.0)),
        "LFIN": ("left_hand", (0.0, 0.0, -0.08)),
        "LASI": ("pelvis", (0.0459, 0.1175, 0.0814)),
        "LPSI": ("pelvis", (-0.1041, 0.045, 0.0814)),
        "LTHI": ("left_thigh", (0.0, 0.075, -0.21)),
        "LKNE": ("left_thigh", (0.0, 0.055, -0.4215)),
        "LTIB": ("left_shin", (0.0, 0.065, -0.20)),
        "LANK": ("left_shin", (0.0, 0.045, -0.4099)),
        "LHEE": ("left_foot", (-0.06, 0.0, -0.02)),
        "LTOE": ("left_foot", (0.10, 0.0, -0.02)),
    }
    placements = {
        "C7": ("torso", (-0.075, 0.0, 0.235)),
        "CLAV": ("torso", (0.075, 0.0, 0.2128)),
        "T10": ("torso", (-0.11, 0.0, 0.12)),
        "STRN": ("torso", (0.11, 0.0, 0.12)),
        "RBAK": ("torso", (-0.10, -0.09, 0.17)),
    }
    placements = {k: {"link": link, "offset": list(offset)} for k, (link, offset) in placements.items()}
    for name, (link, offset) in left_placements.items():
        left = {"link": link, "offset": list(offset)}
        placements[name] = left
        placements[_mirror(name)] = _mirror_spec(left)
    landmarks = {
        "pelvis": ["left_hip", "right_hip"],
        "spine": _udh_offset(["left_hip", "right_hip"], "pelvis"),
        "chest": _udh_offset(["T10", "STRN"], "thorax", optional=False),
        "neck": ["C7", "CLAV"],
        "head": _udh_offset(["LFHD", "RFHD", "LBHD", "RBHD"], "head", optional=False),
        "head_top": _udh_offset("head", "head"),
        "head_front": _udh_offset("head", "head"),
    }
    for name, spec in left_landmarks.items():
        landmarks[name] = spec
        landmarks[_mirror(name)] = _mirror_spec(spec)
    frames = {
        "pelvis": {"primary": ["y", ["RASI"], ["LASI"]], "secondary": ["x", ["LPSI", "RPSI"], ["LASI", "RASI"]]},
        "thorax": {
            "primary": ["z", ["T10", "STRN"], ["C7", "CLAV"]],
            "secondary": ["x", ["C7", "T10"], ["CLAV", "STRN"]],
        },
        "head": {
            "primary": ["y", ["RFHD", "RBHD"], ["LFHD", "LBHD"]],
            "secondary": ["x", ["LBHD", "RBHD"], ["LFHD", "RFHD"]],
        },
    }
    for name, spec in left_frames.items():
        frames[name] = spec
        frames[_mirror(name)] = _mirror_spec(spec)
    return {"name": "plug_in_gait", "frames": frames, "landmarks": landmarks, "placements": placements}


def _anatomical() -> dict:
    """Markers on palpable bony landmarks (Van Sint Jan 2007; the names of
    the Qualisys sports and animation marker sets), placed on the nominal UDH.

    Joint centres are midpoints (ISB, Wu et al. 2002/2005): knee between the
    femoral epicondyles (FLE, FME), ankle between the malleoli (FAL, TAM),
    elbow between the humeral epicondyles (HLE, HME), wrist between the
    radial and ulnar styloids (RSP, UHE); hip by Harrington's regression
    from the ASIS (IAS) and PSIS (IPS); the shoulder 5 cm below the
    acromion (SAJ). Trunk: C7 (CV7), T8 (TV8), jugular notch (SNJ),
    xiphoid (SXS); head: four markers (HDF, HDB); feet: calcaneus (FCC) and
    the first and fifth metatarsal heads (FM1, FM5); hands: the second and
    fifth metacarpal heads (HM2, HM5), which are also the base knuckles of
    the index and little fingers. Trochanter (FTC), fibula head (FAX),
    tibial tuberosity (TTC) and scapula (SCAP) markers are placed but not
    needed; wands are ignored.
    """
    left_placements = {
        "L_IAS": ("pelvis", (0.0459, 0.1175, 0.0814)),
        "L_IPS": ("pelvis", (-0.1041, 0.045, 0.0814)),
        "L_FTC": ("left_thigh", (0.0, 0.08, -0.06)),
        "L_FLE": ("left_thigh", (0.0, 0.05, -0.4215)),
        "L_FME": ("left_thigh", (0.0, -0.05, -0.4215)),
        "L_FAX": ("left_shin", (0.0, 0.05, -0.06)),
        "L_TTC": ("left_shin", (0.05, 0.0, -0.07)),
        "L_FAL": ("left_shin", (0.0, 0.04, -0.4099)),
        "L_TAM": ("left_shin", (0.0, -0.04, -0.4099)),
        "L_FCC": ("left_foot", (-0.06, 0.0, -0.02)),
        "L_FM1": ("left_foot", (0.10, -0.03, -0.03)),
        "L_FM5": ("left_foot", (0.08, 0.035, -0.03)),
        "L_SAJ": ("torso", (-0.0241, 0.1831, 0.2935)),
        "L_HLE": ("left_upper_arm", (0.0, 0.035, -0.2748)),
        "L_HME": ("left_upper_arm", (0.0, -0.035, -0.2748)),
        "L_RSP": ("left_hand", (0.03, 0.0, 0.0)),
        "L_UHE": ("left_hand", (-0.03, 0.0, 0.0)),
        "L_HM2": ("left_hand", (0.0245, -0.0005, -0.137)),
        "L_HM5": ("left_hand", (-0.0355, -0.0005, -0.132)),
        "L_HDF": ("head", (0.09, 0.05, 0.175)),
        "L_HDB": ("head", (-0.09, 0.05, 0.175)),
    }
    central = {
        "CV7": ("torso", (-0.075, 0.0, 0.235)),
        "TV8": ("torso", (-0.11, 0.0, 0.14)),
        "SNJ": ("torso", (0.075, 0.0, 0.2128)),
        "SXS": ("torso", (0.11, 0.0, 0.12)),
        "R_SCAP": ("torso", (-0.10, -0.09, 0.17)),
    }
    placements = {name: {"link": link, "offset": list(offset)} for name, (link, offset) in central.items()}
    placements |= {name: {"link": link, "offset": list(offset)} for name, (link, offset) in left_placements.items()}
    asis, psis = ["L_IAS", "R_IAS"], ["L_IPS", "R_IPS"]
    landmarks = {
        "pelvis": ["left_hip", "right_hip"],
        "spine": _udh_offset(["left_hip", "right_hip"], "pelvis"),
        "chest": _udh_offset(["TV8", "SXS"], "thorax", optional=False),
        "neck": ["CV7", "SNJ"],
        "head": _udh_offset(["L_HDF", "R_HDF", "L_HDB", "R_HDB"], "head", optional=False),
        "head_top": _udh_offset("head", "head"),
        "head_front": _udh_offset("head", "head"),
        "left_hip": {"rule": "hip_joint_centre", "side": "left", "method": "harrington", "asis": asis, "psis": psis},
        "left_knee": ["L_FLE", "L_FME"],
        "left_ankle": ["L_FAL", "L_TAM"],
        "left_toe": _udh_offset(["L_FM1", "L_FM5"], "left_foot", optional=False),
        "left_shoulder": {"rule": "offset", "from": "L_SAJ", "frame": "thorax", "offset": [0.0, 0.0, -0.05]},
        "left_elbow": ["L_HLE", "L_HME"],
        "left_wrist": ["L_RSP", "L_UHE"],
        "left_hand": _udh_offset(["L_HM2", "L_HM5"], "left_hand"),
        "left_index_1": {"L_HM2": 1.0, "optional": True},
        "left_little_1": {"L_HM5": 1.0, "optional": True},
    }
    frames = {
        "pelvis": {"primary": ["y", ["R_IAS"], ["L_IAS"]], "secondary": ["x", ["L_IPS", "R_IPS"], ["L_IAS", "R_IAS"]]},
        "thorax": {
            "primary": ["z", ["TV8", "SXS"], ["CV7", "SNJ"]],
            "secondary": ["x", ["CV7", "TV8"], ["SNJ", "SXS"]],
        },
        "head": {
            "primary": ["y", ["R_HDF", "R_HDB"], ["L_HDF", "L_HDB"]],
            "secondary": ["x", ["L_HDB", "R_HDB"], ["L_HDF", "R_HDF"]],
        },
        "left_foot": {
            "primary": ["x", ["L_FCC"], ["L_FM1", "L_FM5"]],
            "secondary": ["z", ["L_FCC", "L_FM1", "L_FM5"], ["left_ankle"]],
        },
        "left_hand": {
            "primary": ["z", ["L_HM2", "L_HM5"], ["L_RSP", "L_UHE"]],
            "secondary": ["x", ["L_UHE"], ["L_RSP"]],
        },
    }
    data = {"name": "anatomical", "frames": frames, "landmarks": landmarks, "placements": placements}
    _mirror_sets(data, None)
    return data


BUILTIN_MARKER_SETS: dict[str, dict] = {"plug_in_gait": _plug_in_gait(), "anatomical": _anatomical()}
# Plug-in Gait full-body marker names (the left and right twins of each).
PLUG_IN_GAIT_MARKERS: tuple[str, ...] = tuple(BUILTIN_MARKER_SETS["plug_in_gait"]["placements"])


# --- marker sets -------------------------------------------------------------


def load_marker_set(marker_set: MarkerSetLike = None) -> dict:
    """A validated marker set: a built-in name, a YAML file, a dict, or None (Plug-in Gait).

    `offset: udh` in a rule is replaced by the offset the nominal UDH has.
    """
    if marker_set is None:
        return copy.deepcopy(_builtin("plug_in_gait"))
    if isinstance(marker_set, Mapping):
        return _with_udh_offsets(_validated(copy.deepcopy(dict(marker_set)), "marker set"), "marker set")
    name = str(marker_set)
    if name.lower() in BUILTIN_MARKER_SETS:
        return copy.deepcopy(_builtin(name.lower()))
    return _with_udh_offsets(_validated(_read_yaml(Path(marker_set)), name), name)


@functools.cache
def _builtin(name: str) -> dict:
    return _with_udh_offsets(_validated(copy.deepcopy(BUILTIN_MARKER_SETS[name]), name), name)


@functools.cache
def _nominal_udh() -> Embodiment:
    from hotu_drake.embodiment import load

    return load("udh", hands="none")


def _with_udh_offsets(ms: dict, where: str) -> dict:
    """Replace `offset: udh` by the offset between the landmark and its `from`
    point, in the rule's frame, on the nominal UDH at q = 0 (virtual markers)."""
    wanted = {k: v for k, v in ms["landmarks"].items() if isinstance(v, Mapping) and v.get("offset") == "udh"}
    if not wanted:
        return ms
    from hotu_drake.motion.udh_skeleton import landmark_placements

    udh = _nominal_udh()
    origin = {link.name: np.asarray(link.origin, dtype=float) for link in udh.spec.links}
    unknown = sorted({p["link"] for p in ms["placements"].values()} - set(origin))
    if unknown:
        raise ClipFormatError(f"{where}: placements name unknown UDH links {', '.join(unknown[:3])}")
    markers = {name: origin[p["link"]] + np.asarray(p["offset"], dtype=float) for name, p in ms["placements"].items()}
    on_udh = {name: origin[link] + offset for name, (link, offset) in landmark_placements(udh).items()}
    missing = sorted(set(wanted) - set(on_udh))
    if missing:
        raise ClipFormatError(f"{where}: landmarks {', '.join(missing[:3])} use offset udh but the UDH lacks them")
    resolver = _Resolver(markers, ms, where)
    resolver.points.update({name: on_udh[name] for name in wanted})
    for name, spec in wanted.items():
        try:
            start, frame = resolver.point(spec["from"]), resolver.frame(spec["frame"])
        except _Missing as error:
            raise ClipFormatError(
                f"{where}: landmark {name} uses offset udh but {error.args[0]} has no placement"
            ) from None
        spec["offset"] = [round(float(v), 6) for v in frame.T @ (on_udh[name] - start)]
    return ms


def _read_yaml(path: Path) -> dict:
    """A YAML mapping from `path` (PyYAML ships with Drake)."""
    import yaml

    if not path.is_file():
        raise ClipFormatError(f"{path}: no such marker-set file (nor a built-in set: {', '.join(BUILTIN_MARKER_SETS)})")
    try:
        data = yaml.safe_load(path.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        raise ClipFormatError(f"{path}: not a readable YAML marker set ({type(error).__name__})") from None
    if not isinstance(data, dict):
        raise ClipFormatError(f"{path}: a marker set must be a YAML mapping")
    return data


def _validated(data: dict, where: str) -> dict:
    """Mirror, merge `extends`, check the sections and every rule; raise `ClipFormatError`."""
    unknown = sorted(set(data) - {"name", "extends", "mirror", "frames", "landmarks", "placements"})
    if unknown:
        raise ClipFormatError(
            f"{where}: unknown key(s) {', '.join(map(str, unknown))} "
            "(a marker set has name, extends, mirror, frames, landmarks, placements)"
        )
    for section in ("frames", "landmarks", "placements"):
        if not isinstance(data.get(section) or {}, Mapping):
            raise ClipFormatError(f"{where}: {section} must be a mapping")
    mirror = data.get("mirror", False)
    if mirror is not False:
        ok = mirror is True or (
            isinstance(mirror, list) and len(mirror) == 2 and all(isinstance(m, str) and m for m in mirror)
        )
        if not ok:
            raise ClipFormatError(f"{where}: mirror must be true or [left prefix, right prefix], not {mirror!r}")
        data = {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in data.items()}
        _mirror_sets(data, None if mirror is True else tuple(mirror))
    base = data.get("extends")
    if base is not None:
        if str(base).lower() not in BUILTIN_MARKER_SETS:
            raise ClipFormatError(
                f"{where}: extends unknown marker set {base!r} (built in: {', '.join(BUILTIN_MARKER_SETS)})"
            )
        merged = copy.deepcopy(_builtin(str(base).lower()))  # inherited `offset: udh` already resolved
        for section in ("frames", "landmarks", "placements"):
            merged[section].update(data.get(section) or {})
        merged["name"] = data.get("name", where)
        data = merged
    out = {"name": str(data.get("name", where))}
    for section in ("frames", "landmarks", "placements"):
        value = data.get(section) or {}
        if not isinstance(value, Mapping):
            raise ClipFormatError(f"{where}: {section} must be a mapping")
        out[section] = {str(k): v for k, v in value.items()}
    if not out["landmarks"]:
        raise ClipFormatError(f"{where}: the marker set defines no landmarks")
    for name, spec in out["landmarks"].items():
        _check_rule(name, spec, where, out["frames"])
    for name, spec in out["frames"].items():
        _check_frame(name, spec, where)
    for name, spec in out["placements"].items():
        if not isinstance(spec, Mapping) or "link" not in spec or np.shape(spec.get("offset")) != (3,):
            raise ClipFormatError(f"{where}: placement {name} needs a link and a 3-vector offset")
    return out


def _check_rule(name: str, spec, where: str, frames: Mapping) -> None:
    if isinstance(spec, str):
        spec = [spec]
    if isinstance(spec, list | tuple):
        if not spec:
            raise ClipFormatError(f"{where}: landmark {name} has no markers")
        return
    if not isinstance(spec, Mapping):
        raise ClipFormatError(f"{where}: landmark {name} must be a list, a weight map or a rule")
    if "rule" not in spec:
        weights = {k: v for k, v in spec.items() if k != "optional"}
        if not weights:
            raise ClipFormatError(f"{where}: landmark {name} has no markers")
        if not all(isinstance(w, int | float) for w in weights.values()) or sum(weights.values()) == 0:
            raise ClipFormatError(f"{where}: landmark {name}: weights must be numbers with a non-zero sum")
        return
    rule = spec["rule"]
    if rule not in _RULE_KEYS:
        raise ClipFormatError(f"{where}: landmark {name}: unknown rule {rule!r} (choose from {', '.join(_RULE_KEYS)})")
    missing = _RULE_KEYS[rule] - set(spec)
    if missing:
        raise ClipFormatError(f"{where}: landmark {name}: rule {rule} needs {', '.join(sorted(missing))}")
    if rule == "hip_joint_centre" and spec.get("method", "harrington") not in _HIP_REGRESSIONS:
        raise ClipFormatError(f"{where}: landmark {name}: method must be one of {', '.join(_HIP_REGRESSIONS)}")
    if rule == "hip_joint_centre" and spec.get("side") not in ("left", "right"):
        raise ClipFormatError(f"{where}: landmark {name}: side must be left or right")
    for key, count in (("asis", 2), ("psis", None)):
        value = spec.get(key)
        if rule == "hip_joint_centre" and value is not None:
            if not isinstance(value, list) or not value or (count and len(value) != count):
                raise ClipFormatError(f"{where}: landmark {name}: {key} must list {count or 'the'} marker names")
    unknown = set(spec) - _RULE_KEYS[rule] - _OPTIONAL_KEYS[rule] - {"rule", "optional"}
    if unknown:
        raise ClipFormatError(f"{where}: landmark {name}: rule {rule} has no key(s) {', '.join(sorted(unknown))}")
    if rule == "offset" and spec["offset"] != "udh" and np.shape(spec["offset"]) != (3,):
        raise ClipFormatError(f"{where}: landmark {name}: offset must be a 3-vector or 'udh'")
    if rule == "offset" and spec["frame"] not in frames:
        raise ClipFormatError(f"{where}: landmark {name}: no frame named {spec['frame']!r}")
    if "distance" in spec and not (isinstance(spec["distance"], int | float) and spec["distance"] >= 0):
        raise ClipFormatError(f"{where}: landmark {name}: distance must be a number >= 0")


def _check_frame(name: str, spec, where: str) -> None:
    ok = isinstance(spec, Mapping) and all(
        isinstance(spec.get(key), list | tuple) and len(spec[key]) == 3 and spec[key][0] in AXES
        for key in ("primary", "secondary")
    )
    if not ok or spec["primary"][0] == spec["secondary"][0]:
        raise ClipFormatError(f"{where}: frame {name} needs primary and secondary [axis, from, to] on two axes")


def marker_names(marker_set: MarkerSetLike = None) -> set[str]:
    """Every marker a marker set refers to (in rules, frames or placements)."""
    ms = load_marker_set(marker_set)
    names = set(ms["placements"])
    refs: set[str] = set()
    for spec in [*ms["landmarks"].values(), *ms["frames"].values()]:
        refs |= _references(spec)
    return names | (refs - set(ms["landmarks"]))


def _references(spec) -> set[str]:
    """Point names a rule or frame mentions."""
    if isinstance(spec, str):
        return {spec}
    if isinstance(spec, list | tuple):
        return set().union(*(_references(s) for s in spec)) if spec else set()
    if isinstance(spec, Mapping):
        if "rule" not in spec and "primary" not in spec:
            return {k for k in spec if k != "optional"}
        out: set[str] = set()
        for key, value in spec.items():
            if key in ("proximal", "distal", "lateral", "plane", "from", "primary", "secondary"):
                out |= {v for v in _references(value) if v not in AXES}
        if spec.get("rule") == "hip_joint_centre":
            out |= set(spec.get("asis", HIP_DEFAULTS["asis"])) | set(spec.get("psis", HIP_DEFAULTS["psis"]))
        return out
    return set()


# --- landmarks from markers --------------------------------------------------


class _Resolver:
    """Evaluates points (markers, landmarks) and frames lazily, with memo and cycle checks."""

    def __init__(self, markers: Mapping[str, np.ndarray], ms: dict, source: str):
        self.markers = {k: np.asarray(v, dtype=float) for k, v in markers.items()}
        self.ms = ms
        self.source = source
        self.points: dict[str, np.ndarray] = {}
        self.frames: dict[str, np.ndarray] = {}
        self.active: set[str] = set()

    def point(self, name) -> np.ndarray:
        if isinstance(name, list | tuple):
            return np.mean([self.point(n) for n in name], axis=0)
        if name in self.points:
            return self.points[name]
        if name in self.ms["landmarks"]:
            if name in self.active:
                raise ClipFormatError(f"{self.source}: landmark {name} depends on itself")
            self.active.add(name)
            try:
                with np.errstate(all="ignore"):
                    value = self._landmark(name, self.ms["landmarks"][name])
            except np.linalg.LinAlgError:
                value = np.full(3, np.nan)
            finally:
                self.active.discard(name)
            if not np.all(np.isfinite(value)):
                raise ClipFormatError(
                    f"{self.source}: landmark {name} cannot be computed from its markers (they coincide or are missing)"
                )
            self.points[name] = value
            return self.points[name]
        if name in self.markers:
            return self.markers[name]
        raise _Missing(name)

    def frame(self, name: str) -> np.ndarray:
        """(T, 3, 3) orientation of a marker frame (columns x, y, z)."""
        if name not in self.frames:
            spec = self.ms["frames"].get(name)
            if spec is None:
                raise ClipFormatError(f"{self.source}: the marker set has no frame {name!r}")
            axes = [(spec[k][0], self.point(spec[k][2]) - self.point(spec[k][1])) for k in ("primary", "secondary")]
            with np.errstate(all="ignore"):  # coinciding markers give NaN, refused where a landmark uses it
                self.frames[name] = _frame_from_axes(*axes)
        return self.frames[name]

    def _landmark(self, name: str, spec) -> np.ndarray:
        if isinstance(spec, str | list | tuple):
            return self.point(list(spec) if not isinstance(spec, str) else [spec])
        if "rule" not in spec:
            weights = {k: float(w) for k, w in spec.items() if k != "optional"}
            total = sum(weights.values())
            return sum(w * self.point(k) for k, w in weights.items()) / total
        rule = spec["rule"]
        if rule == "hip_joint_centre":
            return self._hip(spec)
        if rule == "chord":
            return chord_point(
                self.point(spec["proximal"]), self.point(spec["plane"]), self.point(spec["lateral"]), spec["distance"]
            )
        if rule == "hinge":
            return hinge_point(
                self.point(spec["proximal"]),
                self.point(spec["distal"]),
                self.point(spec["lateral"]),
                spec["distance"],
                spec.get("sign", 1),
            )
        return self.point(spec["from"]) + self.frame(spec["frame"]) @ np.asarray(spec["offset"], dtype=float)

    def _hip(self, spec) -> np.ndarray:
        left_asis, right_asis = (self.point(n) for n in spec.get("asis", HIP_DEFAULTS["asis"]))
        psis = self.point(list(spec.get("psis", HIP_DEFAULTS["psis"])))
        return hip_joint_centre(left_asis, right_asis, psis, spec["side"], spec.get("method", "harrington"))


class _Missing(KeyError):
    """A point that is neither a marker nor a landmark of the set."""


def _frame_from_axes(primary: tuple[str, np.ndarray], secondary: tuple[str, np.ndarray]) -> np.ndarray:
    """(T, 3, 3) rotation with `primary` exact and `secondary` orthogonalised."""
    (axis_a, a), (axis_b, b) = primary, secondary
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b - np.sum(a * b, axis=-1, keepdims=True) * a
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    i, j = AXES[axis_a], AXES[axis_b]
    k = 3 - i - j
    # The third axis completes a right-handed frame: e_k = e_i x e_j times the permutation's sign.
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    columns = [None, None, None]
    columns[i], columns[j], columns[k] = a, b, sign * np.cross(a, b)
    return np.stack(columns, axis=-1)


def hip_joint_centre(
    left_asis: np.ndarray, right_asis: np.ndarray, psis: np.ndarray, side: str, method: str = "harrington"
) -> np.ndarray:
    """Hip joint centre (T, 3) from the pelvis markers by a published regression.

    Harrington et al. (2007): posterior 0.24 PD + 9.9 mm, inferior
    0.30 PW + 10.9 mm, lateral 0.33 PW + 7.3 mm from the mid-ASIS; Bell et
    al. (1990): 0.19, 0.30 and 0.36 PW. PW is the inter-ASIS width and PD the
    mid-ASIS to mid-PSIS depth.
    """
    mid = 0.5 * (left_asis + right_asis)
    frame = _frame_from_axes(("y", left_asis - right_asis), ("x", mid - psis))
    width = np.linalg.norm(left_asis - right_asis, axis=-1)
    depth = np.sum((mid - psis) * frame[..., 0], axis=-1)
    lateral_sign = 1.0 if side == "left" else -1.0
    if method == "bell":
        local = np.stack([-0.19 * width, lateral_sign * 0.36 * width, -0.30 * width], axis=-1)
    else:
        local = np.stack(
            [-(0.24 * depth + 0.0099), lateral_sign * (0.33 * width + 0.0073), -(0.30 * width + 0.0109)], axis=-1
        )
    return mid + np.einsum("...ij,...j->...i", frame, local)


def chord_point(proximal: np.ndarray, plane: np.ndarray, lateral: np.ndarray, distance: float) -> np.ndarray:
    """Plug-in Gait's chord function: the joint centre J (T, 3) with |J - lateral| =
    `distance`, J in the plane of the three points, and (proximal - J) perpendicular
    to (lateral - J), on the side away from the `plane` marker."""
    u = proximal - lateral
    length = np.linalg.norm(u, axis=-1, keepdims=True)
    u = u / length
    w = plane - lateral
    w = w - np.sum(w * u, axis=-1, keepdims=True) * u
    w = -w / np.linalg.norm(w, axis=-1, keepdims=True)
    cos = np.clip(distance / length, -1.0, 1.0)
    return lateral + distance * (cos * u + np.sqrt(1.0 - cos**2) * w)


def hinge_point(
    proximal: np.ndarray, distal: np.ndarray, lateral: np.ndarray, distance: float, sign: float = 1.0
) -> np.ndarray:
    """Centre J = lateral + distance * n (T, 3) of a hinge whose axis n is
    perpendicular to both segments J -> proximal and J -> distal.

    n . (proximal - lateral) = n . (distal - lateral) = distance and |n| = 1:
    a component in the plane of the two vectors plus +- one along their normal.
    """
    a, b = proximal - lateral, distal - lateral
    gram = np.stack(
        [np.stack([np.sum(a * a, -1), np.sum(a * b, -1)], -1), np.stack([np.sum(a * b, -1), np.sum(b * b, -1)], -1)],
        -2,
    )
    gram = gram + 1e-12 * np.eye(2)  # a marker on the segments' line has no unique axis
    coefficients = np.linalg.solve(gram, np.full(a.shape[:-1] + (2, 1), float(distance)))[..., 0]
    in_plane = coefficients[..., :1] * a + coefficients[..., 1:] * b
    normal = np.cross(a, b)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    out_of_plane = np.sqrt(np.clip(1.0 - np.sum(in_plane**2, axis=-1, keepdims=True), 0.0, None))
    axis = in_plane + np.sign(sign) * out_of_plane * normal
    return lateral + distance * axis


def markers_to_landmarks(
    markers: Mapping[str, np.ndarray], marker_set: MarkerSetLike = None, *, source: str = "markers", say: bool = True
) -> dict[str, np.ndarray]:
    """{landmark: (T, 3)} of the human skeleton from {marker: (T, 3)}.

    Optional landmarks whose markers are absent are left out; so are
    required ones when every landmark of their body region is missing (a
    capture of part of the body, said on the `hotu_drake.input` logger).
    Otherwise a missing marker raises `ClipFormatError` starting with
    `source`, naming the markers the set looked for and those the file has.
    Points of the set that are not human landmarks are helpers only.
    """
    ms = load_marker_set(marker_set)
    resolver = _Resolver(markers, ms, source)
    out: dict[str, np.ndarray] = {}
    missing: dict[str, str] = {}  # required landmark -> a marker it lacks
    for name, spec in ms["landmarks"].items():
        optional = isinstance(spec, Mapping) and bool(spec.get("optional", False))
        try:
            value = resolver.point(name)
        except _Missing as absent:
            if not optional:
                missing[name] = absent.args[0]
            continue
        if name in LANDMARKS:
            out[name] = value
    if not missing:
        return out
    try:
        regions = check_coverage(out, source)
        for region, members in REGIONS.items():  # a region left out must have none of its markers
            specs = [ms["landmarks"][m] for m in members if m in ms["landmarks"]]
            direct = set().union(set(), *map(_references, specs)) - set(ms["landmarks"])
            if region not in regions and direct & set(markers):
                raise ClipFormatError(region)
    except ClipFormatError:
        raise ClipFormatError(_unfit_message(ms["name"], missing, markers, source)) from None
    absent = [r.replace("_", " ") for r in REGIONS if r not in regions]
    if say:
        log.info("%s: no markers for the %s: those parts hold their standing pose", source, ", ".join(absent))
    return out


def _unfit_message(name: str, missing: Mapping[str, str], markers: Mapping, source: str) -> str:
    wanted: dict[str, list[str]] = {}
    for landmark, marker in missing.items():
        wanted.setdefault(marker, []).append(landmark)
    looked = [f"{marker} (for {', '.join(landmarks[:2])})" for marker, landmarks in sorted(wanted.items())]
    has = sorted(markers)
    shown = ", ".join(has[:16]) + (f" and {len(has) - 16} more" if len(has) > 16 else "")
    return (
        f"{source}: the marker set '{name}' looks for markers {', '.join(looked[:6])}"
        f"{' ...' if len(looked) > 6 else ''} that the file does not have (it has {shown}); "
        f"choose a set with --marker-set (built in: {', '.join(BUILTIN_MARKER_SETS)}) or write one "
        "(see hotu_drake.motion.marker_sets)"
    )


def choose_marker_set(labels) -> str | None:
    """The built-in set that has the most markers in common with `labels`
    (at least `MIN_COMMON_MARKERS`), or None."""
    labels = set(labels)
    common = {name: len(set(ms["placements"]) & labels) for name, ms in BUILTIN_MARKER_SETS.items()}
    best = max(common, key=common.get)
    return best if common[best] >= MIN_COMMON_MARKERS else None


# --- virtual markers on the UDH ----------------------------------------------


def udh_scale(udh: Embodiment) -> float:
    """Size of a UDH relative to the nominal 1.61 m one (from its thigh length)."""
    shin = np.asarray(udh.spec.link("left_shin").origin)
    thigh = np.asarray(udh.spec.link("left_thigh").origin)
    return float(np.linalg.norm(shin - thigh) / NOMINAL_THIGH)


def marker_placements(udh: Embodiment, marker_set: MarkerSetLike = None) -> dict[str, tuple[str, np.ndarray]]:
    """Marker -> (UDH link, offset in that link's frame), scaled to this UDH."""
    ms = load_marker_set(marker_set)
    if not ms["placements"]:
        raise ValueError(f"marker set {ms['name']} has no placements on the UDH")
    s = udh_scale(udh)
    links = {link.name for link in udh.spec.links}
    unknown = sorted({p["link"] for p in ms["placements"].values()} - links)
    if unknown:
        raise ValueError(f"marker set {ms['name']} places markers on unknown UDH links {unknown[:3]}")
    return {name: (p["link"], s * np.asarray(p["offset"], dtype=float)) for name, p in ms["placements"].items()}


def udh_markers(udh: Embodiment, clip: MotionClip, marker_set: MarkerSetLike = None) -> dict[str, np.ndarray]:
    """{marker: (T, 3)} world positions of the virtual markers on a UDH clip."""
    from hotu_drake.motion.udh_skeleton import points_on_clip

    return points_on_clip(udh, clip, marker_placements(udh, marker_set))
