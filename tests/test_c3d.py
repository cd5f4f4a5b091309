"""C3D markers: round trip through a file with gaps, landmarks, the UDH marker fit, bad input."""

import struct

import numpy as np
import pytest

from hotu_drake.embodiment import load
from hotu_drake.motion.c3d import load_c3d_clip, read_c3d, write_c3d
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.human import REQUIRED_LANDMARKS
from hotu_drake.motion.marker_sets import PLUG_IN_GAIT_MARKERS, load_marker_set, markers_to_landmarks, udh_markers
from hotu_drake.motion.udh_skeleton import udh_landmarks
from hotu_drake.retarget.marker_fit import fit_udh_to_markers, marker_residuals
from hotu_drake.rotations import angular_velocity, finite_difference, quat_multiply, up_rotation

FPS = 30.0
FRAMES = 40
GAP = ("LKNE", 12, 20)  # an interior gap: frames [12, 20)
EDGE_GAP = ("RWRA", 0, 5)  # a gap at the start of the take


def make_udh_clip(udh, frames: int = FRAMES, fps: float = FPS, seed: int = 0) -> MotionClip:
    """Standing pose plus smooth sinusoids within the joint limits, the root walking and turning."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    q0 = udh.standing_pose
    margin = np.minimum(q0 - udh.position_lower, udh.position_upper - q0) - 0.05
    amplitude = np.minimum(0.3, margin)
    phase = rng.uniform(0.0, 2 * np.pi, len(q0))
    frequency = rng.uniform(0.3, 1.0, len(q0))
    q = q0 + amplitude * np.sin(2 * np.pi * frequency * t[:, None] + phase)
    yaw, pitch = 0.3 * np.sin(t), 0.1 * np.sin(2 * t)
    zeros = np.zeros_like(t)
    quaternion = quat_multiply(
        np.stack([np.cos(yaw / 2), zeros, zeros, np.sin(yaw / 2)], 1),
        np.stack([np.cos(pitch / 2), zeros, np.sin(pitch / 2), zeros], 1),
    )
    root = np.stack([0.3 * t, 0.05 * np.sin(t), udh.standing_root_height + 0.02 * np.sin(2 * t)], 1)
    return MotionClip.from_positions(
        "udh", "test", fps, list(udh.joint_names), q, root, quaternion, part_index=udh.parts
    )


@pytest.fixture(scope="module")
def udh():
    return load("udh", hands="none")


@pytest.fixture(scope="module")
def clip(udh):
    return make_udh_clip(udh)


@pytest.fixture(scope="module")
def markers(udh, clip):
    return udh_markers(udh, clip)


@pytest.fixture(scope="module")
def c3d_file(tmp_path_factory, markers):
    """The markers in a C3D file, with an interior gap, an edge gap and a marker never seen."""
    gapped = {name: value.copy() for name, value in markers.items()}
    for name, start, stop in (GAP, EDGE_GAP):
        gapped[name][start:stop] = np.nan
    gapped["LOST"] = np.full((FRAMES, 3), np.nan)
    return write_c3d(tmp_path_factory.mktemp("c3d") / "take.c3d", gapped, FPS)


@pytest.fixture(scope="module")
def read_back(c3d_file):
    return read_c3d(c3d_file)


@pytest.fixture(scope="module")
def fitted(read_back):
    measured, fps, _ = read_back
    return fit_udh_to_markers(measured, fps, source="take.c3d")


def test_udh_markers_are_the_plug_in_gait_set(markers):
    assert set(markers) == set(PLUG_IN_GAIT_MARKERS)
    for side in "LR":
        for name in ("FHD", "BHD", "SHO", "ELB", "WRA", "WRB", "FIN", "ASI", "PSI", "THI", "KNE", "TIB", "ANK"):
            assert f"{side}{name}" in markers
    assert {"C7", "T10", "CLAV", "STRN", "RBAK", "LHEE", "LTOE", "RHEE", "RTOE"} <= set(markers)


def test_skin_markers_sit_outside_the_bones(udh, clip, markers):
    landmarks = udh_landmarks(udh, clip)
    # LASI at the front of the pelvis, LKNE lateral of the knee centre (left = +y in the pelvis frame).
    pelvis_x = np.einsum("tij,tj->ti", np.swapaxes(_root_rotation(clip), 1, 2), markers["LASI"] - clip.root_position)
    assert np.all(pelvis_x[:, 0] > 0.03)
    knee_offset = np.linalg.norm(markers["LKNE"] - landmarks["left_knee"], axis=1)
    np.testing.assert_allclose(knee_offset, 0.055, atol=1e-9)


def _root_rotation(clip):
    from hotu_drake.rotations import quat_to_matrix

    return quat_to_matrix(clip.root_quaternion)


def test_c3d_round_trip_fills_gaps(markers, read_back):
    measured, fps, info = read_back
    assert fps == FPS
    assert info["units"] == "mm" and info["up_axis"] == "+z" and info["up_axis_source"].startswith("data (the head")
    assert "LOST" in info["dropped"] and "LOST" not in measured
    assert info["gap_samples"] == {GAP[0]: GAP[2] - GAP[1], EDGE_GAP[0]: EDGE_GAP[2] - EDGE_GAP[1]}
    assert set(measured) == set(markers)
    for name, truth in markers.items():
        present = np.ones(FRAMES, dtype=bool)
        for gap_name, start, stop in (GAP, EDGE_GAP):
            if name == gap_name:
                present[start:stop] = False
        np.testing.assert_allclose(measured[name][present], truth[present], atol=1e-3)  # 1 mm
    name, start, stop = GAP
    filled = measured[name]
    # Cubic Hermite through the gap: close to the truth and no jump at its ends.
    assert np.abs(filled[start:stop] - markers[name][start:stop]).max() < 0.02
    steps = np.linalg.norm(np.diff(filled[start - 3 : stop + 3], axis=0), axis=1)
    assert steps.max() < 3.0 * np.median(steps) + 1e-3
    name, start, stop = EDGE_GAP
    np.testing.assert_allclose(measured[name][:stop], np.repeat(measured[name][stop : stop + 1], stop, 0))


def test_read_detects_y_up_and_metres(tmp_path, markers):
    """A file in metres with y up and no screen axes: units from POINT:UNITS, up from the data."""
    import ezc3d

    names = list(markers)
    z_up = np.stack([markers[n] for n in names])  # (n, T, 3)
    y_up = z_up @ up_rotation("+y")  # rows: the inverse of the reader's turn
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [FPS]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = tuple(f"Subject:{n}" for n in names)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["m"]
    points = np.ones((4, len(names), FRAMES))
    points[:3] = y_up.transpose(2, 0, 1)
    c3d["data"]["points"] = points
    path = tmp_path / "yup.c3d"
    c3d.write(str(path))
    measured, _, info = read_c3d(path)
    assert info["up_axis"] == "+y" and info["up_axis_source"].startswith("data")
    assert set(measured) == set(names)  # subject prefixes stripped
    for n in names:
        np.testing.assert_allclose(measured[n], markers[n], atol=1e-5)


def test_landmarks_from_markers_match_the_udh(udh, clip, markers):
    landmarks = markers_to_landmarks(markers)
    truth = udh_landmarks(udh, clip)
    assert set(REQUIRED_LANDMARKS) <= set(landmarks)
    for name, value in landmarks.items():
        error = np.linalg.norm(value - truth[name], axis=1).max()
        assert error < 0.03, f"{name}: {error:.4f} m"
    joint_centres = [f"{s}_{j}" for s in ("left", "right") for j in ("hip", "knee", "ankle", "shoulder", "elbow")]
    assert max(np.linalg.norm(landmarks[n] - truth[n], axis=1).max() for n in joint_centres) < 0.005


def test_bell_regression_and_user_yaml_map(tmp_path, markers):
    text = (
        "extends: plug_in_gait\n"
        "landmarks:\n"
        "  left_hip: {rule: hip_joint_centre, side: left, method: bell}\n"
        "  left_wrist: {LWRA: 0.5, LWRB: 0.5}\n"
    )
    path = tmp_path / "set.yaml"
    path.write_text(text)
    harrington = markers_to_landmarks(markers)
    bell = markers_to_landmarks(markers, path)
    np.testing.assert_allclose(bell["left_wrist"], harrington["left_wrist"], atol=1e-12)
    assert 0.0 < np.linalg.norm(bell["left_hip"] - harrington["left_hip"], axis=1).max() < 0.03
    minimal = {"landmarks": {"pelvis": ["LASI", "RASI", "LPSI", "RPSI"], "head": {"LFHD": 1.0, "RFHD": 1.0}}}
    out = markers_to_landmarks(markers, minimal)
    np.testing.assert_allclose(out["head"], 0.5 * (markers["LFHD"] + markers["RFHD"]))


def test_load_c3d_clip_is_a_human_clip(c3d_file, udh, clip):
    human = load_c3d_clip(c3d_file)
    assert human.embodiment == "human" and human.fps == FPS and human.num_frames == FRAMES
    truth = udh_landmarks(udh, clip)
    seen = slice(EDGE_GAP[2], None)  # RWRA is held at its first sample before that
    for name in ("pelvis", "left_ankle", "right_wrist", "head"):
        assert np.linalg.norm(human.key_body(name)[seen] - truth[name][seen], axis=1).max() < 0.03


def test_marker_fit_recovers_the_joint_trajectory(udh, clip, read_back, fitted):
    error = np.degrees(fitted.joint_positions - clip.joint_positions)
    rms = float(np.sqrt(np.mean(error**2)))
    assert rms < 3.0, f"joint RMS error {rms:.3f} deg"
    # Past the held edge gap of RWRA, every joint on its own.
    worst = np.sqrt(np.mean(error[EDGE_GAP[2] :] ** 2, axis=0)).max()
    assert worst < 3.0, f"worst joint RMS {worst:.3f} deg"
    np.testing.assert_allclose(fitted.root_position, clip.root_position, atol=0.005)
    assert np.all(fitted.joint_positions >= udh.position_lower - 1e-9)
    assert np.all(fitted.joint_positions <= udh.position_upper + 1e-9)
    seen = {name: value[EDGE_GAP[2] :] for name, value in read_back[0].items()}
    residuals = marker_residuals(udh, fitted.slice(EDGE_GAP[2], FRAMES), seen)
    assert max(residuals.values()) < 0.002


def test_marker_fit_clip_is_complete(fitted, udh):
    assert fitted.embodiment == "udh" and fitted.source == "take.c3d" and fitted.fps == FPS
    assert fitted.part_index == udh.parts
    assert set(fitted.key_body_names) == set(udh.key_bodies.values())
    np.testing.assert_allclose(fitted.joint_velocities, finite_difference(fitted.joint_positions, FPS))
    np.testing.assert_allclose(fitted.root_angular_velocity, angular_velocity(fitted.root_quaternion, FPS))
    pelvis = fitted.key_body("pelvis")
    np.testing.assert_allclose(pelvis, fitted.root_position, atol=1e-9)


def test_marker_fit_with_noise_and_missing_markers(udh, clip, markers):
    rng = np.random.default_rng(1)
    noisy = {name: value[:15] + rng.normal(0.0, 0.002, (15, 3)) for name, value in markers.items()}
    noisy["RFIN"][5:9] = np.nan  # unfilled gaps are left out of their frames
    fit = fit_udh_to_markers(noisy, FPS, udh=udh)
    error = np.degrees(fit.joint_positions - clip.joint_positions[:15])
    assert np.sqrt(np.mean(error**2)) < 3.0


# --- bad input ---------------------------------------------------------------


def _assert_one_line_error(path, call):
    with pytest.raises(ClipFormatError) as caught:
        call()
    message = str(caught.value)
    assert message.startswith(str(path)) and "\n" not in message
    return message


def test_missing_file(tmp_path):
    path = tmp_path / "absent.c3d"
    assert "no such file" in _assert_one_line_error(path, lambda: read_c3d(path))


def test_not_a_c3d(tmp_path):
    path = tmp_path / "text.c3d"
    path.write_text("this is not a C3D file\n" * 40)
    assert "not a C3D" in _assert_one_line_error(path, lambda: load_c3d_clip(path))


def test_truncated_c3d(tmp_path, c3d_file):
    path = tmp_path / "truncated.c3d"
    path.write_bytes(c3d_file.read_bytes()[:1100])
    _assert_one_line_error(path, lambda: read_c3d(path))


def test_c3d_without_frames(tmp_path, c3d_file):
    data = bytearray(c3d_file.read_bytes())
    data[6:10] = struct.pack("<HH", 2, 1)  # header: first frame 2, last frame 1
    path = tmp_path / "empty.c3d"
    path.write_bytes(bytes(data))
    assert "no frames" in _assert_one_line_error(path, lambda: read_c3d(path))


def test_c3d_without_usable_markers(tmp_path):
    path = write_c3d(tmp_path / "blank.c3d", {"LASI": np.full((5, 3), np.nan)}, FPS)
    assert "no usable markers" in _assert_one_line_error(path, lambda: read_c3d(path))


def test_landmark_without_markers(tmp_path, markers):
    partial = {name: value for name, value in markers.items() if name != "LKNE"}
    path = write_c3d(tmp_path / "noknee.c3d", partial, FPS)
    message = _assert_one_line_error(path, lambda: load_c3d_clip(path))
    assert "left_knee" in message and "LKNE" in message
    marker_set = tmp_path / "empty_landmark.yaml"
    marker_set.write_text("landmarks:\n  left_knee: []\n")
    _assert_one_line_error(marker_set, lambda: load_c3d_clip(path, marker_set))
    _assert_one_line_error(marker_set, lambda: load_marker_set(marker_set))


def test_write_is_atomic(tmp_path, markers):
    write_c3d(tmp_path / "ok.c3d", {"LASI": markers["LASI"]}, FPS)
    with pytest.raises(ValueError):
        write_c3d(tmp_path / "bad.c3d", {"LASI": np.zeros((0, 3))}, FPS)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ok.c3d"]
