"""The `.npz` clip format: round trip, and clear errors for what it does not understand."""

import numpy as np
import pytest

from hotu_drake.motion.clip import ClipFormatError, MotionClip
from tests.clips import udh_test_clip


def _same(a: MotionClip, b: MotionClip) -> None:
    assert (a.embodiment, a.source, a.fps, a.joint_names, a.key_body_names) == (
        b.embodiment,
        b.source,
        b.fps,
        b.joint_names,
        b.key_body_names,
    )
    for name in ("joint_positions", "joint_velocities", "root_position", "root_quaternion", "key_body_positions"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.part_index == b.part_index


def test_round_trip(tmp_path):
    clip = udh_test_clip("none", frames=20)
    clip.contact_names, clip.contacts = ["left_foot"], np.ones((20, 1), dtype=bool)
    clip.object_names, clip.object_poses = ["box"], np.tile([0, 0, 0.15, 1, 0, 0, 0], (20, 1, 1)).astype(float)
    path = clip.save(tmp_path / "clip.npz")
    loaded = MotionClip.load(path)
    _same(clip, loaded)
    assert loaded.contact("left_foot").all() and loaded.object_pose("box").shape == (20, 7)
    assert [p.name for p in tmp_path.iterdir()] == ["clip.npz"]  # no temporary file left


def _write(path, **arrays):
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize(
    "case,message",
    [
        ("not_npz", "not a readable .npz clip"),
        ("missing_keys", "not a hotu_drake clip"),
        ("future_version", "format version 2 is not supported"),
        ("nan", "contains NaN"),
        ("zero_frames", "zero frames"),
        ("bad_shape", "has shape"),
    ],
)
def test_loader_rejects_what_it_does_not_understand(tmp_path, case, message):
    path = tmp_path / f"{case}.npz"
    clip = udh_test_clip("none", frames=5)
    if case == "not_npz":
        path.write_text("not a zip file")
    elif case == "missing_keys":
        _write(path, fps=np.array(30.0))
    else:
        clip.save(path)
        data = dict(np.load(path))
        if case == "future_version":
            data["format_version"] = np.array(2)
        elif case == "nan":
            data["joint_positions"] = data["joint_positions"].copy()
            data["joint_positions"][2, 3] = np.nan
        elif case == "zero_frames":
            for key in (
                "joint_positions",
                "joint_velocities",
                "root_position",
                "root_quaternion",
                "root_linear_velocity",
                "root_angular_velocity",
                "key_body_positions",
            ):
                data[key] = data[key][:0]
        elif case == "bad_shape":
            data["root_quaternion"] = data["root_quaternion"][:, :3]
        _write(path, **data)
    with pytest.raises(ClipFormatError, match=message) as error:
        MotionClip.load(path)
    assert str(error.value).startswith(str(path)) and "\n" not in str(error.value)


def test_a_clip_held_at_its_first_frame_waits_at_rest_then_plays_unchanged():
    clip = udh_test_clip()
    held = clip.held_first(0.5)
    frames = int(round(0.5 * clip.fps))
    assert held.num_frames == clip.num_frames + frames
    assert np.array_equal(held.joint_positions[:frames], np.repeat(clip.joint_positions[:1], frames, axis=0))
    for velocities in (held.joint_velocities, held.root_linear_velocity, held.root_angular_velocity):
        assert not velocities[:frames].any()
    _same(held.slice(frames, held.num_frames), clip)
    _same(clip, udh_test_clip())  # the clip it holds is left as it was
    assert clip.held_first(0.0) is clip
