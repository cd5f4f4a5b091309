"""BVH reading and writing: UDH round trips, channel orders, units, naming families, user maps, bad input."""

import numpy as np
import pytest

from hotu_drake.embodiment import load
from hotu_drake.motion.bvh import (
    UNIT_SCALES,
    detect_units,
    forward_kinematics,
    parse_bvh,
    parse_bvh_text,
    read_bvh,
    skeleton_height,
    write_udh_bvh,
)
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.human import REQUIRED_LANDMARKS, landmarks_of
from hotu_drake.motion.skeleton_maps import JointNames, best_family
from hotu_drake.motion.udh_skeleton import udh_landmarks
from hotu_drake.rotations import matrix_to_quat
from tests.conftest import SHARED

CMU_CLIP = SHARED / "data" / "cmu" / "01_01.bvh"


# --- a small UDH clip ---------------------------------------------------------------------------------------


def _rot(axis: int, angles: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations about a coordinate axis, written out independently of the module."""
    c, s = np.cos(angles), np.sin(angles)
    one, zero = np.ones_like(angles), np.zeros_like(angles)
    rows = {
        0: [[one, zero, zero], [zero, c, -s], [zero, s, c]],
        1: [[c, zero, s], [zero, one, zero], [-s, zero, c]],
        2: [[c, -s, zero], [s, c, zero], [zero, zero, one]],
    }[axis]
    return np.moveaxis(np.array(rows), [0, 1], [-2, -1])


def udh_clip(hands: str = "none", frames: int = 30, fps: float = 30.0):
    """Standing pose plus sinusoids within limits; the root walks, bobs, pitches and yaws."""
    udh = load("udh", hands)
    t = np.arange(frames) / fps
    lower, upper = udh.position_lower, udh.position_upper
    phase = np.random.default_rng(0).uniform(0.0, 2 * np.pi, len(lower))
    q = udh.standing_pose + 0.3 * (upper - lower) / 2 * np.sin(2 * np.pi * 0.7 * t[:, None] + phase)
    q = np.clip(q, lower, upper)
    root = np.stack([0.3 * t, 0.1 * np.sin(t), 0.9 + 0.02 * np.sin(3 * t)], axis=1)
    quat = matrix_to_quat(_rot(2, 2.5 + 0.8 * t) @ _rot(1, 0.2 * np.sin(2 * t)))
    clip = MotionClip.from_positions("udh", "test", fps, list(udh.joint_names), q, root, quat, part_index={})
    return udh, clip


@pytest.fixture(scope="module")
def udh_none():
    return udh_clip("none")


def _max_error(clip: MotionClip, reference: dict[str, np.ndarray]) -> float:
    landmarks = landmarks_of(clip)
    assert set(landmarks) == set(reference)
    return max(float(np.abs(landmarks[name] - reference[name]).max()) for name in reference)


@pytest.mark.parametrize(("up", "units"), [("y", "cm"), ("z", "m"), ("y", "in"), ("z", "cmu")])
def test_udh_round_trip_gives_the_udh_landmarks(tmp_path, udh_none, up, units):
    udh, clip = udh_none
    path = write_udh_bvh(clip, udh, tmp_path / "udh.bvh", up=up, units=units)
    back = read_bvh(path)
    assert back.embodiment == "human" and back.num_frames == clip.num_frames and back.fps == clip.fps
    assert _max_error(back, udh_landmarks(udh, clip)) < 1e-3
    # Explicit units and up axis give the same result as detection.
    explicit = read_bvh(path, units=units, up=up)
    np.testing.assert_allclose(explicit.key_body_positions, back.key_body_positions)


def test_udh_round_trip_with_fingers(tmp_path):
    udh, clip = udh_clip("full", frames=10)
    path = write_udh_bvh(clip, udh, tmp_path / "udh_hands.bvh")
    back = read_bvh(path)
    assert "left_index_4" in back.key_body_names and "right_thumb_1" in back.key_body_names
    assert _max_error(back, udh_landmarks(udh, clip)) < 1e-3


def test_multi_axis_udh_joints_become_one_bvh_joint(tmp_path, udh_none):
    udh, clip = udh_none
    bvh = parse_bvh(write_udh_bvh(clip, udh, tmp_path / "udh.bvh"))
    shoulder = bvh.names.index("left_upper_arm")
    assert len(bvh.channels[shoulder]) == 3
    assert not any(name.endswith("_x_link") for name in bvh.names)
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


# --- hand-made files: channel orders and position channels ---------------------------------------------------

ZXY_TEXT = """HIERARCHY
ROOT Hips
{
  OFFSET 1 2 3
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Arm
  {
    OFFSET 10 0 0
    CHANNELS 6 Yrotation Xposition Yposition Zposition Zrotation Xrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0.5 -1 2 30 -20 45 10 1 2 3 -60 15
0 0 0 0 0 0 0 0 0 0 0 0
"""


def test_channel_order_and_position_channels_on_a_child_joint():
    bvh = parse_bvh_text(ZXY_TEXT, "zxy.bvh")
    rotations, positions = forward_kinematics(bvh)
    a = np.radians(bvh.motion)
    root_r = _rot(2, a[:, 3]) @ _rot(0, a[:, 4]) @ _rot(1, a[:, 5])
    root_p = np.array([1.0, 2.0, 3.0]) + bvh.motion[:, 0:3]
    arm_r = root_r @ _rot(1, a[:, 6]) @ _rot(2, a[:, 10]) @ _rot(0, a[:, 11])
    arm_p = root_p + np.einsum("tab,tb->ta", root_r, np.array([10.0, 0.0, 0.0]) + bvh.motion[:, 7:10])
    np.testing.assert_allclose(rotations[:, 0], root_r, atol=1e-12)
    np.testing.assert_allclose(positions[:, 1], arm_p, atol=1e-12)
    np.testing.assert_allclose(rotations[:, 1], arm_r, atol=1e-12)
    end = positions[:, 1] + rotations[:, 1] @ bvh.end_sites[1]
    np.testing.assert_allclose(end[1], [11.0, 7.0, 3.0])  # rest pose
    assert bvh.fps == 30.0


# --- synthetic skeletons of the naming families ---------------------------------------------------------------

# role, parent role, offset (cm, Y up, left = +x, facing +z); ":end" roles are End Sites.
_BODY = [
    ("hips", None, (0, 0, 0)),
    ("spine", "hips", (0, 10, 0)),
    ("chest", "spine", (0, 25, 0)),
    ("neck", "chest", (0, 20, 0)),
    ("head", "neck", (0, 10, 0)),
    ("head:end", "head", (0, 18, 0)),
]
for _s, _x in (("l", 1), ("r", -1)):
    _BODY += [
        (f"{_s}_collar", "chest", (_x * 3, 15, 0)),
        (f"{_s}_shoulder", f"{_s}_collar", (_x * 15, 0, 0)),
        (f"{_s}_elbow", f"{_s}_shoulder", (_x * 28, 0, 0)),
        (f"{_s}_wrist", f"{_s}_elbow", (_x * 25, 0, 0)),
        (f"{_s}_wrist:end", f"{_s}_wrist", (_x * 10, 0, 0)),
        *[
            (f"{_s}_index{i}", f"{_s}_index{i - 1}" if i > 1 else f"{_s}_wrist", (_x * (8 if i == 1 else 2.5), 0, 0))
            for i in range(1, 5)
        ],
        (f"{_s}_hip", "hips", (_x * 9, -5, 0)),
        (f"{_s}_knee", f"{_s}_hip", (0, -42, 0)),
        (f"{_s}_ankle", f"{_s}_knee", (0, -42, 0)),
        (f"{_s}_toe", f"{_s}_ankle", (0, -6, 12)),
        (f"{_s}_toe:end", f"{_s}_toe", (0, 0, 5)),
    ]


def _sided(names: dict[str, str]) -> dict[str, str]:
    """Expand {role: name} with L/Left placeholders for both sides."""
    out = {}
    for role, name in names.items():
        if role.startswith("s_"):
            for s, side, short in (("l", "Left", "L"), ("r", "Right", "R")):
                out[f"{s}{role[1:]}"] = name.format(Side=side, S=short)
        else:
            out[role] = name
    return out


FAMILIES = {
    "cmu_3dsmax": _sided(
        {
            "hips": "Hips",
            "spine": "Chest",
            "chest": "Chest2",
            "neck": "Neck",
            "head": "Head",
            "s_collar": "{Side}Collar",
            "s_shoulder": "{Side}Shoulder",
            "s_elbow": "{Side}Elbow",
            "s_wrist": "{Side}Wrist",
            "s_hip": "{Side}Hip",
            "s_knee": "{Side}Knee",
            "s_ankle": "{Side}Ankle",
            "s_toe": "{Side}Toe",
        }
    ),
    "mixamo": _sided(
        {
            "hips": "mixamorig:Hips",
            "spine": "mixamorig:Spine",
            "chest": "mixamorig:Spine2",
            "neck": "mixamorig:Neck",
            "head": "mixamorig:Head",
            "s_collar": "mixamorig:{Side}Shoulder",
            "s_shoulder": "mixamorig:{Side}Arm",
            "s_elbow": "mixamorig:{Side}ForeArm",
            "s_wrist": "mixamorig:{Side}Hand",
            **{f"s_index{i}": f"mixamorig:{{Side}}HandIndex{i}" for i in range(1, 5)},
            "s_hip": "mixamorig:{Side}UpLeg",
            "s_knee": "mixamorig:{Side}Leg",
            "s_ankle": "mixamorig:{Side}Foot",
            "s_toe": "mixamorig:{Side}ToeBase",
        }
    ),
    "optitrack": _sided(
        {
            "hips": "Skeleton_Hip",
            "spine": "Skeleton_Ab",
            "chest": "Skeleton_Chest",
            "neck": "Skeleton_Neck",
            "head": "Skeleton_Head",
            "s_collar": "Skeleton_{S}Shoulder",
            "s_shoulder": "Skeleton_{S}UArm",
            "s_elbow": "Skeleton_{S}FArm",
            "s_wrist": "Skeleton_{S}Hand",
            "s_hip": "Skeleton_{S}Thigh",
            "s_knee": "Skeleton_{S}Shin",
            "s_ankle": "Skeleton_{S}Foot",
            "s_toe": "Skeleton_{S}Toe",
        }
    ),
    "cmu_motionbuilder": _sided(
        {
            "hips": "Hips",
            "spine": "Spine",
            "chest": "Spine1",
            "neck": "Neck1",
            "head": "Head",
            "s_collar": "{Side}Shoulder",
            "s_shoulder": "{Side}Arm",
            "s_elbow": "{Side}ForeArm",
            "s_wrist": "{Side}Hand",
            "s_hip": "{Side}UpLeg",
            "s_knee": "{Side}Leg",
            "s_ankle": "{Side}Foot",
            "s_toe": "{Side}ToeBase",
        }
    ),
}
CUSTOM = {role: f"bone_{role}" for role, _, _ in _BODY if not role.endswith(":end")}
SCALE = {"m": 0.01, "cm": 1.0, "in": 1 / 2.54, "cmu": 0.01 / 0.056444}


def skeleton_bvh(names: dict[str, str], scale: float = 1.0, frames: int = 3, angles: np.ndarray | None = None) -> str:
    """BVH text of the synthetic body under `names` (roles without a name are folded into their parent)."""
    children: dict[str | None, list] = {}
    for role, parent, offset in _BODY:
        children.setdefault(parent, []).append((role, np.asarray(offset, float)))
    lines, columns = ["HIERARCHY"], 0

    def emit(role: str, offset: np.ndarray, depth: int, root: bool) -> None:
        nonlocal columns
        tab = "  " * depth
        channels = "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation" if root else None
        lines.extend([f"{tab}{'ROOT' if root else 'JOINT'} {names[role]}", f"{tab}{{"])
        lines.append(f"{tab}  OFFSET {' '.join(f'{v * scale:.6f}' for v in offset)}")
        lines.append(f"{tab}  {channels or 'CHANNELS 3 Zrotation Xrotation Yrotation'}")
        columns += 6 if root else 3
        for kid, kid_offset in _named_children(role):
            if kid.endswith(":end"):
                lines.extend([f"{tab}  End Site", f"{tab}  {{", f"{tab}    OFFSET {_fmt(kid_offset * scale)}"])
                lines.append(f"{tab}  }}")
            else:
                emit(kid, kid_offset, depth + 1, False)
        lines.append(f"{tab}}}")

    def _named_children(role: str):
        for kid, offset in children.get(role, []):
            if kid in names or kid.endswith(":end"):
                yield kid, offset
            else:  # fold an unnamed role: its children hang from `role` with the offsets added
                for grandkid, grand_offset in _named_children(kid):
                    yield grandkid, offset + grand_offset

    emit("hips", np.zeros(3), 0, True)
    motion = np.zeros((frames, columns)) if angles is None else np.array(angles)
    motion[:, 1] += 95.0 * scale  # hips 95 cm above the floor
    rows = "\n".join(" ".join(f"{v:.5f}" for v in row) for row in motion)
    return "\n".join(lines) + f"\nMOTION\nFrames: {frames}\nFrame Time: 0.0083333\n{rows}\n"


def _fmt(v: np.ndarray) -> str:
    return " ".join(f"{x:.6f}" for x in v)


@pytest.mark.parametrize(
    ("family", "units"), [("cmu_3dsmax", "in"), ("mixamo", "cm"), ("optitrack", "m"), ("cmu_motionbuilder", "cmu")]
)
def test_naming_families_and_units_are_detected(tmp_path, family, units):
    path = tmp_path / f"{family}.bvh"
    path.write_text(skeleton_bvh(FAMILIES[family], SCALE[units]))
    clip = read_bvh(path)
    landmarks = {name: p[0] for name, p in landmarks_of(clip).items()}
    assert set(REQUIRED_LANDMARKS) <= set(landmarks)
    # Y-up (x, y, z) cm -> z-up (z, x, y) m; the shoulder is the upper-arm joint, not the collar.
    np.testing.assert_allclose(landmarks["left_shoulder"], [0.0, 0.18, 1.45], atol=1e-4)
    np.testing.assert_allclose(landmarks["right_toe"], [0.12, -0.09, 0.0], atol=1e-4)
    np.testing.assert_allclose(landmarks["head_top"], [0.0, 0.0, 1.78], atol=1e-4)
    if family == "mixamo":
        np.testing.assert_allclose(landmarks["left_index_4"], [0.0, 0.865, 1.45], atol=1e-4)


def test_detect_units_thresholds():
    assert [detect_units(h) for h in (1.7, 30.0, 67.0, 170.0, 1700.0)] == ["m", "cmu", "in", "cm", "mm"]


def test_units_and_up_overrides(tmp_path):
    path = tmp_path / "mixamo.bvh"
    path.write_text(skeleton_bvh(FAMILIES["mixamo"]))
    auto = read_bvh(path).key_body_positions
    np.testing.assert_allclose(read_bvh(path, units="m").key_body_positions, 100 * auto)
    np.testing.assert_allclose(read_bvh(path, units=0.02).key_body_positions, 2 * auto)
    as_z_up = read_bvh(path, up="z").key_body_positions  # file axes kept: the skeleton lies along world y
    np.testing.assert_allclose(as_z_up[..., 1], auto[..., 2])


def test_many_frames_are_read(tmp_path):
    """Their cost is a benchmark's (`python -m hotu_drake.bench readers --input FILE`), not a timed test's."""
    frames = 3000
    angles = np.random.default_rng(1).uniform(-30, 30, (frames, 6 + 3 * (len(FAMILIES["cmu_3dsmax"]) - 1)))
    path = tmp_path / "long.bvh"
    path.write_text(skeleton_bvh(FAMILIES["cmu_3dsmax"], frames=frames, angles=angles))
    clip = read_bvh(path)
    assert clip.num_frames == frames and np.all(np.isfinite(clip.key_body_positions))


def test_cmu_clip():
    if not CMU_CLIP.is_file():
        pytest.skip("the CMU sample is not available")
    clip = read_bvh(CMU_CLIP)
    assert clip.num_frames == 2752 and clip.fps == 120.0
    landmarks = landmarks_of(clip)
    # Bone-chain height (head top to ankles, pose-independent) and the head top over the floor.
    bvh = parse_bvh(CMU_CLIP)
    family, targets = best_family(JointNames(bvh.names, bvh.has_end_site))
    assert family == "cmu_motionbuilder"
    assert 1.5 < skeleton_height(bvh, targets) * UNIT_SCALES["cmu"] < 1.9
    floor = min(landmarks["left_toe"][:, 2].min(), landmarks["right_toe"][:, 2].min())
    assert 1.45 < landmarks["head_top"][:, 2].max() - floor < 1.9
    ankles = np.minimum(landmarks["left_ankle"][:, 2], landmarks["right_ankle"][:, 2])
    assert -0.02 < ankles.min() < 0.15
    assert np.all(landmarks["head"][:, 2] > landmarks["pelvis"][:, 2])
    lateral = landmarks["left_hip"] - landmarks["right_hip"]
    forward = landmarks["left_toe"] - landmarks["left_ankle"]
    assert np.mean(np.cross(forward, lateral)[:, 2]) > 0  # forward x left = up: a right-handed, z-up body


# --- user maps ------------------------------------------------------------------------------------------------

YAML_MAP = """# landmark: joint (or Joint:end for its End Site)
pelvis: bone_hips
spine: bone_spine
chest: bone_chest
neck: bone_neck
head: bone_head
head_top: "bone_head:end"
left_shoulder: bone_l_shoulder
left_elbow: bone_l_elbow
left_wrist: bone_l_wrist
left_hip: bone_l_hip
left_knee: bone_l_knee
left_ankle: bone_l_ankle
left_toe: bone_l_toe
right_shoulder: bone_r_shoulder
right_elbow: bone_r_elbow
right_wrist: bone_r_wrist
right_hip: bone_r_hip
right_knee: bone_r_knee
right_ankle: bone_r_ankle
right_toe: bone_r_toe
"""


def test_yaml_map_for_an_unknown_skeleton(tmp_path):
    path = tmp_path / "custom.bvh"
    path.write_text(skeleton_bvh(CUSTOM))
    with pytest.raises(ClipFormatError, match="unknown skeleton") as error:
        read_bvh(path)
    assert str(error.value).startswith(str(path))
    map_path = tmp_path / "custom.yaml"
    map_path.write_text(YAML_MAP)
    clip = read_bvh(path, skeleton_map=map_path)
    np.testing.assert_allclose(clip.key_body("left_shoulder")[0], [0.0, 0.18, 1.45], atol=1e-4)
    np.testing.assert_allclose(clip.key_body("head_top")[0], [0.0, 0.0, 1.78], atol=1e-4)


def test_user_map_overrides_a_family_entry(tmp_path):
    path = tmp_path / "max.bvh"
    path.write_text(skeleton_bvh(FAMILIES["cmu_3dsmax"]))
    chest = read_bvh(path, skeleton_map={"chest": "Chest", "spine": None})
    np.testing.assert_allclose(chest.key_body("chest")[0], [0.0, 0.0, 1.05], atol=1e-4)
    assert "spine" not in chest.key_body_names
    with pytest.raises(ClipFormatError, match="NoSuchJoint"):
        read_bvh(path, skeleton_map={"chest": "NoSuchJoint"})
    with pytest.raises(ClipFormatError, match="unknown landmark"):
        read_bvh(path, skeleton_map={"belly": "Chest"})


# --- bad input ------------------------------------------------------------------------------------------------

GOOD = skeleton_bvh(FAMILIES["cmu_3dsmax"])
HIERARCHY_END = GOOD.index("MOTION")
FIRST_FRAME = GOOD.index("Frame Time: 0.0083333\n") + len("Frame Time: 0.0083333\n")
BAD = {
    "empty": ("", "empty"),
    "no_hierarchy": ("hello world\n", "HIERARCHY"),
    "truncated_hierarchy": (GOOD[: HIERARCHY_END // 2], "truncated"),
    "no_motion": (GOOD[:HIERARCHY_END], "MOTION"),
    "zero_frames": (GOOD[:HIERARCHY_END] + "MOTION\nFrames: 0\nFrame Time: 0.01\n", "zero frames"),
    "truncated_motion": (GOOD.rsplit("\n", 2)[0] + "\n", "truncated"),
    "cut_frame_line": (GOOD[: len(GOOD) - 40], "line"),
    "wrong_count": (GOOD[:FIRST_FRAME] + "0 " + GOOD[FIRST_FRAME:], "expected"),
    "malformed_number": (GOOD[:FIRST_FRAME] + "abc" + GOOD[FIRST_FRAME + 7 :], "'abc' is not a number"),
    "nan": (GOOD[:FIRST_FRAME] + "nan" + GOOD[FIRST_FRAME + 7 :], "NaN"),
    "bad_frame_time": (GOOD.replace("Frame Time: 0.0083333", "Frame Time: -1"), "Frame Time"),
    "bad_channel": (GOOD.replace("Zrotation Xrotation Yrotation", "Zrotation Wrotation Yrotation", 1), "Wrotation"),
    "unknown_skeleton": (skeleton_bvh(CUSTOM), "unknown skeleton"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_raises_a_one_line_error_naming_the_file(tmp_path, case):
    text, words = BAD[case]
    path = tmp_path / f"{case}.bvh"
    path.write_text(text)
    with pytest.raises(ClipFormatError) as error:
        read_bvh(path)
    message = str(error.value)
    assert message.startswith(str(path)) and "\n" not in message
    assert words in message


def test_missing_file(tmp_path):
    with pytest.raises(ClipFormatError, match="no such file") as error:
        read_bvh(tmp_path / "absent.bvh")
    assert str(error.value).startswith(str(tmp_path / "absent.bvh"))
