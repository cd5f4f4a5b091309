"""Real captures read right: the Qualisys walk (../shared/data/c3d), as
recorded and turned to other up axes with POINT:Y_SCREEN agreeing or not,
retargets upright, with the built-in anatomical set and with a marker set
a user wrote from the documentation. Skips without ../shared."""

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.motion.c3d import read_c3d
from hotu_drake.motion.load import load_motion
from hotu_drake.retarget.pipeline import to_robot, to_udh
from hotu_drake.rotations import quat_to_matrix, up_rotation
from tests.conftest import REPO, SHARED

QUALISYS = SHARED / "data" / "c3d" / "qualisys_walk.c3d"
USER_SET = REPO / "tests" / "data" / "qualisys_markers.yaml"
pytestmark = pytest.mark.skipif(not QUALISYS.is_file(), reason="needs ../shared/data/c3d/qualisys_walk.c3d")


def _turned(tmp_path, up: str, screen: str):
    """The capture with its data turned so that `up` is the up axis, and POINT:Y_SCREEN set to `screen`."""
    import ezc3d

    c3d = ezc3d.c3d(str(QUALISYS))
    points = c3d["data"]["points"]
    turn = up_rotation(up).T  # z up -> the file's `up`
    points[:3] = np.einsum("ij,jnt->int", turn, points[:3])
    c3d["data"]["points"] = points
    c3d["parameters"]["POINT"]["Y_SCREEN"]["value"] = [screen]
    path = tmp_path / f"walk_{up[1]}{'up' if up[0] == '+' else 'down'}_{screen.strip('+-').lower()}.c3d"
    c3d.write(str(path))
    return path


def _assert_upright(clip):
    """Standing on z: head over pelvis over ankles, the pelvis z axis up, walking along the floor."""
    head, pelvis = clip.key_body("head")[:, 2], clip.key_body("pelvis")[:, 2]
    ankles = 0.5 * (clip.key_body("left_ankle")[:, 2] + clip.key_body("right_ankle")[:, 2])
    assert np.all(head > pelvis + 0.3) and np.all(pelvis > ankles + 0.4)
    up = quat_to_matrix(clip.root_quaternion)[:, :, 2]
    assert np.median(up[:, 2]) > 0.9
    travel = clip.root_position[-1] - clip.root_position[0]
    assert np.linalg.norm(travel[:2]) > 1.0 and abs(travel[2]) < 0.2  # a walk along the floor


@pytest.mark.parametrize(
    "up, screen",
    [("+z", "-Z"), ("+y", "+Y"), ("+y", "+Z"), ("-x", "-X"), ("-x", "+Z")],
    ids=["as_recorded", "y_up_agreeing", "y_up_disagreeing", "x_down_agreeing", "x_down_disagreeing"],
)
@pytest.mark.parametrize("marker_set", [None, USER_SET], ids=["built_in", "user_written"])
def test_the_qualisys_walk_reads_upright(tmp_path, up, screen, marker_set):
    path = QUALISYS if up == "+z" else _turned(tmp_path, up, screen)
    _, _, info = read_c3d(path, marker_set=marker_set)
    assert info["up_axis"] == up and info["up_axis_source"].startswith("data")
    clip = load_motion(path, marker_set=marker_set)
    _assert_upright(clip)


def test_the_qualisys_walk_retargets_upright_onto_the_robots():
    clip = load_motion(QUALISYS)
    udh = to_udh(clip, "none").clip
    assert udh.key_body("head")[:, 2].min() > 1.0
    for robot in ("h1", "bruce"):
        result = to_robot(udh, robot, "none").clip
        emb = embodiment.load(robot, "none")
        pelvis = result.key_body(emb.key_bodies["pelvis"])[:, 2]
        assert np.all(pelvis > 0.6 * emb.standing_pelvis_height)
        up = quat_to_matrix(result.root_quaternion)[:, :, 2]
        assert np.median(up[:, 2]) > 0.9, robot


def test_an_upper_body_capture_retargets_the_parts_it_covers(tmp_path):
    """The torso, head and arms only: the legs hold the standing pose."""
    from hotu_drake.motion.c3d import write_c3d

    markers, fps, _ = read_c3d(QUALISYS)
    lower = ("IAS", "IPS", "FTC", "FLE", "FME", "FAX", "TTC", "FAL", "TAM", "FCC", "FM1", "FM5")
    upper = {k: v for k, v in markers.items() if not any(part in k for part in lower)}
    path = write_c3d(tmp_path / "upper.c3d", upper, fps)
    clip = load_motion(path)
    assert "left_knee" not in clip.key_body_names and "left_wrist" in clip.key_body_names
    result = to_udh(clip, "none").clip
    udh = embodiment.load("udh", "none")
    legs = [i for i, name in enumerate(result.joint_names) if any(p in name for p in ("_hip_", "_knee_", "_ankle_"))]
    np.testing.assert_allclose(
        result.joint_positions[:, legs], np.tile(udh.standing_pose[legs], (len(result.joint_positions), 1))
    )
    arms = [i for i, name in enumerate(result.joint_names) if "shoulder" in name or "elbow" in name]
    assert np.ptp(result.joint_positions[:, arms], axis=0).max() > 0.1  # the arms move with the capture
