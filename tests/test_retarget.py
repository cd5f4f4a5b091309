"""Retargeting human -> UDH -> robots: accuracy, limits, floor contact, CLI."""

import json
import subprocess
import sys

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.motion.bvh import read_bvh, write_udh_bvh
from hotu_drake.motion.c3d import load_c3d_clip, write_c3d
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import human_clip
from hotu_drake.motion.library import generate
from hotu_drake.motion.marker_sets import udh_markers
from hotu_drake.motion.udh_skeleton import udh_landmarks
from hotu_drake.objects import BOX_SIZE
from hotu_drake.retarget.metrics import report
from hotu_drake.retarget.pipeline import ROBOTS, retarget_onto, to_robot, to_udh
from hotu_drake.retarget.retargeter import RetargetOptions, dynamic_pace
from tests.clips import udh_test_clip
from tests.conftest import SHARED

CMU = SHARED / "data" / "cmu" / "01_01.bvh"


def _rms_degrees(a: MotionClip, b: MotionClip) -> float:
    assert a.joint_names == b.joint_names
    return float(np.degrees(np.sqrt(np.mean((a.joint_positions - b.joint_positions) ** 2))))


@pytest.mark.parametrize("hands", ["none", "full"])
def test_bvh_round_trip_recovers_the_udh_joints(tmp_path, hands):
    truth = udh_test_clip(hands)
    udh = embodiment.load("udh", hands)
    path = write_udh_bvh(truth, udh, tmp_path / "udh.bvh")
    recovered = to_udh(read_bvh(path), hands).clip
    error = _rms_degrees(truth, recovered)
    print(f"BVH round trip ({hands} hands): {error:.2f} deg RMS")
    assert error < 2.0


def test_c3d_round_trip_recovers_the_udh_joints(tmp_path):
    truth = udh_test_clip("none", frames=120)
    udh = embodiment.load("udh", "none")
    path = tmp_path / "udh.c3d"
    write_c3d(path, udh_markers(udh, truth), truth.fps)
    recovered = to_udh(load_c3d_clip(path), "none").clip
    error = _rms_degrees(truth, recovered)
    print(f"C3D round trip: {error:.2f} deg RMS")
    assert error < 3.0


@pytest.fixture(scope="module")
def human_walk() -> MotionClip:
    truth = udh_test_clip("full", frames=240)
    return human_clip(udh_landmarks(embodiment.load("udh", "full"), truth), truth.fps, "test")


@pytest.fixture(scope="module")
def udh_walk(human_walk) -> MotionClip:
    return to_udh(human_walk, "full").clip


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("hands", ["full", "none"])
def test_every_robot_stays_within_limits_and_above_the_floor(human_walk, udh_walk, robot, hands):
    result = to_robot(udh_walk, robot, hands)
    emb = embodiment.load(robot, hands)
    assert result.clip.joint_names == emb.joint_names
    figures = report(human_walk, result.clip, emb, result.seconds)
    assert figures["joint_limit_violations"] == 0
    if emb.floating_base:
        assert figures["foot_penetration_m"] <= 0.01
    # Joint velocities agree with the positions.
    assert np.allclose(
        result.clip.joint_velocities[1:-1], np.gradient(result.clip.joint_positions, 1 / result.clip.fps, axis=0)[1:-1]
    )


def test_smaller_robots_take_proportionally_shorter_strides(udh_walk):
    bruce = to_robot(udh_walk, "bruce", "none").clip
    udh_travel = np.linalg.norm(udh_walk.root_position[-1, :2] - udh_walk.root_position[0, :2])
    bruce_travel = np.linalg.norm(bruce.root_position[-1, :2] - bruce.root_position[0, :2])
    ratio = embodiment.load("bruce").standing_pelvis_height / embodiment.load("udh").standing_pelvis_height
    assert bruce_travel / udh_travel == pytest.approx(ratio, rel=0.3)


def test_dynamic_pace_plays_a_smaller_robots_steps_faster(udh_walk):
    """At dynamic similarity's pace BRUCE walks the same steps, each frame
    closer in time: its stride over the UDH's times the square of its pace
    is 1 (the UDH's Froude number kept), its path the person-paced one's
    within 3 cm (the balance pass moves the body over the feet for the
    faster pace's accelerations). "auto" paces BRUCE so (its legs half the
    UDH's), not H1 (as long as the UDH's)."""
    person = to_robot(udh_walk, "bruce", "none", RetargetOptions(pace="person")).clip
    dynamic = to_robot(udh_walk, "bruce", "none", RetargetOptions(pace="dynamic")).clip
    assert person.fps == udh_walk.fps and dynamic.num_frames == person.num_frames
    pace = dynamic.fps / person.fps
    travel = np.linalg.norm(dynamic.root_position[-1, :2] - dynamic.root_position[0, :2])
    udh_travel = np.linalg.norm(udh_walk.root_position[-1, :2] - udh_walk.root_position[0, :2])
    assert 1.3 < pace < 1.6
    assert pace**2 * travel / udh_travel == pytest.approx(1.0, abs=0.05)
    assert np.abs(dynamic.root_position[:, :2] - person.root_position[:, :2]).max() < 0.03
    forward = dynamic.root_linear_velocity[:, 0].mean() / person.root_linear_velocity[:, 0].mean()
    assert forward == pytest.approx(pace, rel=0.05)
    assert to_robot(udh_walk, "bruce", "none").clip.fps == dynamic.fps  # "auto", the default
    assert to_robot(udh_walk, "h1", "none").clip.fps == udh_walk.fps
    assert dynamic_pace(0.25) == pytest.approx(2.0)
    with pytest.raises(ValueError, match="auto, person, dynamic"):
        RetargetOptions(pace="fast")


def test_object_tracks_are_scaled_to_each_robot():
    """The box carry's box: on the floor it stays on the floor, in the hands
    it comes to each robot's own hands; Bruce's track is the UDH's at Bruce's
    size, H1's nearly the UDH's."""
    udh = to_udh(generate("box_carry"), "none").clip
    lifted = int(np.argmax(udh.object_poses[:, 0, 2]))
    for robot, scale in (("h1", (0.9, 1.1)), ("bruce", (0.4, 0.6))):
        clip = to_robot(udh, robot, "none").clip
        assert clip.object_names == udh.object_names
        track, source = clip.object_poses[:, 0], udh.object_poses[:, 0]
        assert track[0, 2] == pytest.approx(source[0, 2]) == pytest.approx(BOX_SIZE / 2)  # resting on the floor
        ratio = np.linalg.norm(track[:, :2], axis=1) / np.linalg.norm(source[:, :2], axis=1)
        assert scale[0] < ratio.min() and ratio.max() - ratio.min() < 1e-9 and ratio.max() < scale[1]
        np.testing.assert_allclose(track[:, 3:], source[:, 3:])
        emb = embodiment.load(robot, "none")
        hands = [clip.key_body_names.index(emb.key_bodies[h]) for h in ("left_hand", "right_hand")]
        between = clip.key_body_positions[lifted, hands].mean(axis=0)
        assert np.linalg.norm(track[lifted, :3] - between) < 0.3
        if robot == "bruce":  # unscaled, the box would float far from Bruce's hands
            assert np.linalg.norm(source[lifted, :3] - between) > 0.6


def test_the_replay_plays_every_lane_on_one_clock(udh_walk):
    """A clip at a faster pace (BRUCE's, "auto") runs ahead of the UDH's in
    the side-by-side replay and holds its last frame, as it would play."""
    from hotu_drake.retarget.replay import _frames_at

    bruce = to_robot(udh_walk, "bruce", "none").clip
    times = np.arange(udh_walk.num_frames) / udh_walk.fps
    np.testing.assert_array_equal(_frames_at(udh_walk, times), np.arange(udh_walk.num_frames))
    frames = _frames_at(bruce, times)
    assert bruce.fps > 1.3 * udh_walk.fps and frames[-1] == bruce.num_frames - 1
    halfway = len(times) // 2
    assert frames[halfway] == pytest.approx(halfway * bruce.fps / udh_walk.fps, abs=1)


def test_the_replay_draws_each_lanes_own_objects():
    from pydrake.geometry import StartMeshcat

    from hotu_drake.retarget.replay import render_replay

    human = generate("box_carry")
    udh = to_udh(human, "none").clip
    bruce = to_robot(udh, "bruce", "none").clip
    meshcat = render_replay([udh, bruce], source=human, meshcat=StartMeshcat())
    for lane in range(3):  # the human's landmarks, the UDH, Bruce: each with its box
        assert meshcat.HasPath(f"/objects/box_{lane}/body")
    assert not meshcat.HasPath("/objects/box_3")


def test_curi_base_follows_the_pelvis(udh_walk):
    curi = to_robot(udh_walk, "curi", "none").clip
    path = np.stack([curi.joint("base_x"), curi.joint("base_y")], axis=1)
    pelvis = udh_landmarks(embodiment.load("udh", "full"), udh_walk)["pelvis"][:, :2]
    assert np.max(np.linalg.norm(path - pelvis, axis=1)) < 1e-6


@pytest.mark.skipif(not CMU.exists(), reason="the shared CMU clip is not here")
def test_cmu_clip_on_every_robot(tmp_path):
    source = read_bvh(CMU)
    udh = to_udh(source, "full")
    udh_emb = embodiment.load("udh", "full")  # no finger landmarks: the fingers stay open
    assert report(source, udh.clip, udh_emb, udh.seconds)["joint_limit_violations"] == 0
    for robot in ROBOTS:
        result = to_robot(udh.clip, robot, "full")
        emb = embodiment.load(robot, "full")
        figures = report(source, result.clip, emb, result.seconds)
        assert figures["joint_limit_violations"] == 0, robot
        assert figures["frames"] == source.num_frames
        if emb.floating_base:
            assert figures["foot_penetration_m"] <= 0.01, robot


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "hotu_drake.retarget", *args], capture_output=True, text=True, timeout=600
    )


def test_cli_writes_clips_report_and_replay(tmp_path):
    truth = udh_test_clip("none", frames=60)
    source = tmp_path / "sway.bvh"
    write_udh_bvh(truth, embodiment.load("udh", "none"), source)
    out = tmp_path / "out"
    result = _cli(
        str(source),
        "--robot",
        "all",
        "--out",
        str(out),
        "--report",
        str(tmp_path / "r.json"),
        "--html",
        str(tmp_path / "replay.html"),
    )
    assert result.returncode == 0, result.stderr
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(f"sway_{r}.npz" for r in ("udh", *ROBOTS))
    figures = json.loads((tmp_path / "r.json").read_text())["clips"]["sway"]
    for values in figures.values():
        assert values["joint_limit_violations"] == 0
        assert values["frames"] == 60 and values["frames_per_second"] > 0
        assert set(values) >= {"part_direction_error_deg", "key_body_error", "foot_skate_m_per_s", "foot_penetration_m"}
    loaded = MotionClip.load(out / "sway_h1.npz")
    assert loaded.embodiment == "h1" and loaded.num_frames == 60
    assert (tmp_path / "replay.html").stat().st_size > 100_000


def test_cli_retargets_a_library_motion_by_name(tmp_path):
    """An INPUT that is no file but a library motion's name retargets the
    generated demonstration; a name that is neither is one error line."""
    out = tmp_path / "out"
    result = _cli("wave", "walkk", "--robot", "curi", "--hands", "none", "--out", str(out))
    assert result.returncode == 2
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "walkk" in errors[0], result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["wave_curi.npz"]
    clip = MotionClip.load(out / "wave_curi.npz")
    assert clip.embodiment == "curi" and clip.num_frames == generate("wave").num_frames


BAD_INPUTS = {
    "truncated.bvh": lambda text: text[: len(text) // 3],
    "malformed.bvh": lambda text: text.replace("Frame Time:", "Frame Time: x", 1),
    "nan.bvh": lambda text: (
        text.rsplit("\n", 2)[0] + "\n" + " ".join(["nan"] * len(text.rsplit("\n", 2)[1].split())) + "\n"
    ),
    "zeroframes.bvh": lambda text: text.split("MOTION")[0] + "MOTION\nFrames: 0\nFrame Time: 0.0083333\n",
    "unknown.bvh": lambda text: (
        text.replace("left_", "gauche_").replace("right_", "droite_").replace("pelvis", "bassin")
    ),
}


@pytest.mark.parametrize("name", sorted(BAD_INPUTS))
def test_cli_bad_input_is_one_line_and_others_still_run(tmp_path, name):
    truth = udh_test_clip("none", frames=30)
    good = write_udh_bvh(truth, embodiment.load("udh", "none"), tmp_path / "good.bvh")
    bad = tmp_path / name
    bad.write_text(BAD_INPUTS[name](good.read_text()))
    out = tmp_path / "out"
    result = _cli(str(bad), str(good), "--robot", "h1", "--out", str(out), "--report", str(tmp_path / "r.json"))
    assert result.returncode == 2
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and str(bad) in errors[0], result.stderr
    assert "Traceback" not in result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["good_h1.npz"]
    report_json = json.loads((tmp_path / "r.json").read_text())
    assert list(report_json["clips"]) == ["good"] and len(report_json["errors"]) == 1


@pytest.mark.parametrize("robot", ["udh", "h1", "curi"])
def test_forward_kinematics_of_every_frame_at_once_matches_frame_by_frame(robot):
    from hotu_drake.retarget.tree import Tree, axis_angles

    emb = embodiment.load(robot, "none")
    tree = Tree(emb.spec)
    rng = np.random.default_rng(3)
    frames = 7
    low, high = np.maximum(emb.position_lower, -3.0), np.minimum(emb.position_upper, 3.0)  # CURI's base is unbounded
    q = rng.uniform(low, high, size=(frames, len(emb.joint_names)))
    axes = rng.normal(size=(frames, 3))
    rotations = axis_angles(axes / np.linalg.norm(axes, axis=1, keepdims=True), rng.uniform(-3, 3, frames))
    positions = rng.normal(size=(frames, 3))
    batch = tree.forward_frames(q, rotations, positions)
    for t in range(frames):
        one = tree.forward(q[t], rotations[t], positions[t])
        for field in ("rotations", "positions", "joint_axes", "joint_positions"):
            np.testing.assert_allclose(getattr(batch, field)[t], getattr(one, field), atol=1e-12, err_msg=field)


def test_landmark_jacobians_of_every_frame_match_frame_by_frame():
    from hotu_drake.embodiment.landmarks import landmark_placements
    from hotu_drake.retarget.targets import Landmarks
    from hotu_drake.retarget.tree import Tree

    emb = embodiment.load("h1", "none")
    tree = Tree(emb.spec)
    marks = Landmarks(tree, landmark_placements(emb.spec))
    rng = np.random.default_rng(5)
    q = rng.uniform(emb.position_lower, emb.position_upper, size=(5, len(emb.joint_names)))
    positions = rng.normal(size=(5, 3))
    poses = tree.forward_frames(q, np.tile(np.eye(3), (5, 1, 1)), positions)
    joints = list(range(len(emb.joint_names)))
    for name in list(marks.items)[:6]:
        points, jacobians = marks.point_jacobian_frames(poses, name, joints)
        link = marks.items[name][0]
        rotations = marks.rotation_jacobian_frames(link, poses, joints)
        for t in range(5):
            one = tree.forward(q[t], np.eye(3), positions[t])
            point, jacobian = marks.point_jacobian(one, name, joints)
            np.testing.assert_allclose(points[t], point, atol=1e-12)
            np.testing.assert_allclose(jacobians[t], jacobian, atol=1e-12)
            np.testing.assert_allclose(rotations[t], marks.rotation_jacobian(link, one, joints), atol=1e-12)


def test_a_human_clip_is_low_passed_with_each_hand_as_a_rigid_body():
    """Whole-clip retargeting low-passes a capture's landmarks (its jitter
    would read as motion), but a hand's fingers keep their places in its
    frame: a turning hand's shape is the source's."""
    from hotu_drake.motion.udh_skeleton import udh_landmarks as landmarks_of_udh
    from hotu_drake.retarget.source_frames import low_passed, source_frames

    truth = udh_test_clip("full", frames=120)
    src = landmarks_of_udh(embodiment.load("udh", "full"), truth)
    rng = np.random.default_rng(5)
    noisy = {name: points + rng.normal(0.0, 0.004, points.shape) for name, points in src.items()}
    smoothed = low_passed(noisy, truth.fps, 0.02)
    body = [n for n in src if not any(f in n for f in ("thumb", "index", "middle", "ring", "little"))]
    before = np.mean([np.abs(noisy[n] - src[n]).mean() for n in body])
    after = np.mean([np.abs(smoothed[n] - src[n]).mean() for n in body])
    assert after < 0.5 * before  # the jitter is mostly gone
    raw, moved = source_frames(noisy), source_frames(smoothed)
    for side in ("left", "right"):
        hand = f"{side}_hand"
        for name in (f"{side}_index_4", f"{side}_thumb_4", f"{side}_little_1"):
            local = np.einsum("tji,tj->ti", raw[hand], noisy[name] - noisy[hand])
            again = np.einsum("tji,tj->ti", moved[hand], smoothed[name] - smoothed[hand])
            np.testing.assert_allclose(again, local, atol=1e-9)


def test_robots_are_retargeted_through_a_udh_bridge_left_to_their_own_balance():
    """`retarget_onto`: the UDH's own clip has its balance pass, the bridge to
    the robots does not (each robot's pass balances its own body); a robot's
    stage keeps its bridge, and a bridge to robots without fingers has none."""
    source = generate("walk")
    stages = retarget_onto(source, ["udh", "h1", "bruce"], "full")
    bridge = stages["h1"].bridge
    assert stages["udh"].bridge is None and bridge is stages["bruce"].bridge
    assert stages["udh"].margins and not bridge.margins  # the pass ran on the UDH's own clip only
    assert np.abs(stages["udh"].clip.root_position - bridge.clip.root_position).max() > 0.005
    assert stages["h1"].margins  # and on each robot's
    assert stages["h1"].total_seconds == pytest.approx(stages["h1"].seconds + bridge.seconds)
    assert any(name.endswith("_index_0") for name in bridge.clip.joint_names)  # H1's hands take the fingers
    alone = retarget_onto(source, ["bruce"], "full")
    assert set(alone) == {"bruce"}
    assert not any(name.endswith("_index_0") for name in alone["bruce"].bridge.clip.joint_names)


def test_the_balance_pass_starts_from_the_share_the_robots_build_carries(monkeypatch):
    """The first round shifts the body by what the centre of mass needs over
    the share of the shift it follows (legs leaning about their ankles), so
    BRUCE's 120 fps walk is balanced in one round (it took two from a share
    of 1; the 30 fps walk still takes two)."""
    from hotu_drake.retarget import clip_programs
    from hotu_drake.retarget.balance import ClipBalance

    shares = {name: ClipBalance(embodiment.load(name, "none")).carried for name in ("h1", "naviai", "bruce")}
    assert all(0.8 < share < 0.95 for share in shares.values()), shares
    rounds = []
    real = clip_programs.balancing_shift
    monkeypatch.setattr(clip_programs, "balancing_shift", lambda *a, **k: rounds.append(1) or real(*a, **k))
    udh = to_udh(generate("walk", fps=120.0), "none", bridge=True).clip  # the benchmarks' walk
    stage = to_robot(udh, "bruce", "none")
    assert len(rounds) == 1
    after = stage.margins["after"]
    assert np.mean(after[~np.isnan(after)] >= 0.0) >= clip_programs.ENOUGH_INSIDE


def test_the_balance_pass_measures_the_clip_at_its_own_rate():
    """A clip faster than the solve rate is solved on every k-th frame; the
    pass's centre of pressure is that of the clip brought back to its own
    rate, frame by frame as the report measures it (at a capture's 200 fps
    the solved frames' own estimate differed from it by up to 10 cm)."""
    from hotu_drake.retarget.balance import ClipBalance
    from hotu_drake.retarget.retargeter import foot_contacts_of
    from hotu_drake.rotations import quat_to_matrix

    udh = to_udh(generate("walk", fps=120.0), "none", bridge=True).clip
    stage = to_robot(udh, "naviai", "none")
    clip = stage.clip
    dynamics = ClipBalance(embodiment.load("naviai", "none"))
    poses = dynamics.poses(clip.joint_positions, quat_to_matrix(clip.root_quaternion), clip.root_position)
    _, pressure = dynamics.centroidal(poses, clip.fps)
    measured = dynamics.support_margin(poses, pressure, foot_contacts_of(clip, clip.num_frames))
    after = stage.margins["after"]
    assert after.shape == (clip.num_frames,)
    np.testing.assert_array_equal(np.isnan(after), np.isnan(measured))
    np.testing.assert_allclose(after[~np.isnan(after)], measured[~np.isnan(measured)], atol=1e-6)
