"""OptiTrack Motive CSV rigid bodies: parsing, axes, gaps, round trip, resampling onto a clip, bad input."""

import numpy as np
import pytest

from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.optitrack import attach_objects, read_optitrack_csv, slerp, write_optitrack_csv

# A Motive 2.x export: a rigid body, one of its markers, a loose marker, a
# Mean Marker Error column, millimetres, an occluded frame (empty cells).
MOTIVE = """\
Format Version,1.23,Take Name,box_carry,Take Notes,,Capture Frame Rate,120.000000,Export Frame Rate,100.000000,\
Capture Start Time,2024-05-01 10.00.00.000 AM,Total Frames in Take,4,Total Exported Frames,4,Rotation Type,Quaternion,\
Length Units,Millimeters,Coordinate Space,Global

,Type,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body Marker,\
Rigid Body Marker,Rigid Body Marker,Marker,Marker,Marker
,Name,box,box,box,box,box,box,box,box,box:Marker1,box:Marker1,box:Marker1,Unlabeled 1000,Unlabeled 1000,Unlabeled 1000
,ID,1,1,1,1,1,1,1,1,1,1,1,1,1,1
,,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,Mean Marker Error,Position,Position,Position,\
Position,Position,Position
Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,,X,Y,Z,X,Y,Z
0,0.000000,0.000000,0.000000,0.000000,1.000000,100.000000,1000.000000,500.000000,0.0002,1,2,3,4,5,6
1,0.010000,0.000000,0.382683,0.000000,0.923880,110.000000,1000.000000,500.000000,0.0002,1,2,3,4,5,6
2,0.020000,,,,,,,,,1,2,3,4,5,6
3,0.030000,0.000000,0.923880,0.000000,0.382683,130.000000,1000.000000,500.000000,0.0002,1,2,3,4,5,6
"""


def _yaw(angle):
    angle = np.asarray(angle, dtype=float)
    zeros = np.zeros_like(angle)
    return np.stack([np.cos(angle / 2), zeros, zeros, np.sin(angle / 2)], axis=-1)


def test_reads_motive_rigid_bodies_z_up(tmp_path):
    path = tmp_path / "take.csv"
    path.write_text(MOTIVE)
    names, poses, fps = read_optitrack_csv(path)
    assert names == ["box"] and poses.shape == (4, 1, 7) and fps == 100.0
    # Motive (x left, y up, z forward) in mm -> z up, x forward, metres.
    np.testing.assert_allclose(poses[0, 0, :3], [0.5, 0.1, 1.0])
    # A turn about Motive's y (up) is a yaw about z.
    np.testing.assert_allclose(poses[[0, 1, 3], 0, 3:], _yaw([0.0, np.pi / 4, 3 * np.pi / 4]), atol=1e-6)
    # The occluded frame: positions linear, orientation halfway.
    np.testing.assert_allclose(poses[2, 0, :3], [0.5, 0.12, 1.0])
    np.testing.assert_allclose(poses[2, 0, 3:], _yaw(np.pi / 2), atol=1e-6)
    assert read_optitrack_csv(path, fps=50.0)[2] == 50.0


def test_round_trip_with_gaps(tmp_path):
    fps, frames = 120.0, 60
    t = np.arange(frames) / fps
    box = np.concatenate([np.stack([0.4 * t, 0.1 * np.sin(t), 0.8 + 0 * t], 1), _yaw(1.5 * t)], 1)
    tilt = np.stack([np.cos(t / 2), np.sin(t / 2) / np.sqrt(2), np.sin(t / 2) / np.sqrt(2), 0 * t], 1)
    drill = np.concatenate([np.stack([1.0 + 0 * t, t, 0.5 + 0.1 * t], 1), tilt], 1)
    poses = np.stack([box, drill], axis=1)
    gapped = poses.copy()
    gapped[20:26, 0] = np.nan  # the box occluded for six frames
    gapped[:3, 1] = np.nan  # the drill not yet seen
    path = write_optitrack_csv(tmp_path / "objects.csv", ["box", "drill"], gapped, fps, units="Millimeters")
    names, read, read_fps = read_optitrack_csv(path)
    assert names == ["box", "drill"] and read_fps == fps
    np.testing.assert_allclose(read[:, 0][:20], poses[:20, 0], atol=1e-5)
    np.testing.assert_allclose(read[3:, 1], poses[3:, 1], atol=1e-5)
    np.testing.assert_allclose(read[20:26, 0], poses[20:26, 0], atol=2e-3)  # interpolated
    np.testing.assert_allclose(read[:3, 1], np.repeat(read[3:4, 1], 3, 0))  # held
    np.testing.assert_allclose(np.linalg.norm(read[..., 3:], axis=-1), 1.0)
    assert [p.name for p in tmp_path.iterdir()] == ["objects.csv"]


def _clip(frames=31, fps=30.0):
    zeros = np.zeros((frames, 3))
    return MotionClip(
        embodiment="human",
        source="test",
        fps=fps,
        joint_names=[],
        joint_positions=np.zeros((frames, 0)),
        joint_velocities=np.zeros((frames, 0)),
        root_position=zeros,
        root_quaternion=np.tile([1.0, 0, 0, 0], (frames, 1)),
        root_linear_velocity=zeros,
        root_angular_velocity=zeros,
        key_body_names=[],
        key_body_positions=np.zeros((frames, 0, 3)),
    )


def test_attach_objects_resamples_to_clip_frames():
    clip = _clip()
    fps, offset = 120.0, 0.1
    k = np.arange(100)
    times = offset + k / fps
    box = np.concatenate([np.stack([times, 2 * times, 0 * times + 0.7], 1), _yaw(times)], 1)
    out = attach_objects(clip, ["box"], box[:, None], fps, time_offset=offset)
    assert out.object_names == ["box"] and out.object_poses.shape == (clip.num_frames, 1, 7)
    inside = (clip.times >= offset) & (clip.times <= times[-1])
    expected = np.concatenate([np.stack([clip.times, 2 * clip.times, 0 * clip.times + 0.7], 1), _yaw(clip.times)], 1)
    np.testing.assert_allclose(out.object_pose("box")[inside], expected[inside], atol=1e-9)
    np.testing.assert_allclose(out.object_pose("box")[clip.times < offset], np.tile(box[0], (3, 1)))
    np.testing.assert_allclose(out.object_pose("box")[clip.times > times[-1]][0], box[-1])
    # A second object is added; naming one again replaces it.
    more = attach_objects(out, ["drill", "box"], np.tile(box[:1, None], (1, 2, 1)), fps)
    assert more.object_names == ["drill", "box"]


def test_slerp_is_constant_speed():
    q = slerp(_yaw(0.0), _yaw(2.0), np.linspace(0, 1, 5))
    np.testing.assert_allclose(q, _yaw(np.linspace(0, 2.0, 5)), atol=1e-12)


# --- bad input ---------------------------------------------------------------


def _bad(tmp_path, text: str, name: str = "bad.csv") -> str:
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ClipFormatError) as caught:
        read_optitrack_csv(path)
    message = str(caught.value)
    assert message.startswith(str(path)) and "\n" not in message
    return message


def test_missing_file(tmp_path):
    path = tmp_path / "absent.csv"
    with pytest.raises(ClipFormatError, match="no such file") as caught:
        read_optitrack_csv(path)
    assert str(caught.value).startswith(str(path))


def test_not_a_motive_export(tmp_path):
    assert "Format Version" in _bad(tmp_path, "a,b,c\n1,2,3\n")


def test_no_rigid_bodies(tmp_path):
    lines = MOTIVE.splitlines()
    text = "\n".join([lines[0], lines[1], lines[2].replace("Rigid Body,", "Marker,"), *lines[3:]])
    assert "no Rigid Body columns" in _bad(tmp_path, text)


def test_zero_frames(tmp_path):
    assert "zero frames" in _bad(tmp_path, "\n".join(MOTIVE.splitlines()[:7]) + "\n")


def test_not_a_number(tmp_path):
    assert "not a number" in _bad(tmp_path, MOTIVE.replace("110.000000", "1l0.0"))


def test_euler_rotations(tmp_path):
    lines = MOTIVE.replace("Rotation Type,Quaternion", "Rotation Type,XYZ").splitlines()
    assert "quaternions" in _bad(tmp_path, "\n".join(lines))


def test_binary_file(tmp_path):
    path = tmp_path / "take.csv"
    path.write_bytes(b"\xff\xfe\x00\x81" * 100)
    with pytest.raises(ClipFormatError) as caught:
        read_optitrack_csv(path)
    assert str(caught.value).startswith(str(path))
