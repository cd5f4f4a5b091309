"""The steering vocabulary: each motion goes where its name says, balanced, on every robot."""

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.motion.library import generate_udh
from hotu_drake.motion.library.steering import VOCABULARY
from hotu_drake.retarget.pipeline import to_robot
from hotu_drake.retarget.stance import LegContacts
from hotu_drake.rotations import heading_yaw, quat_to_matrix

STEERING = tuple(VOCABULARY)


@pytest.fixture(scope="module")
def clips():
    udh = embodiment.load("udh", "none")
    return {name: generate_udh(name, udh=udh) for name in STEERING}


def _travel(clip) -> tuple[np.ndarray, float]:
    """Where the pelvis ends up relative to its start (in the start's heading frame), and how far it turned (deg)."""
    yaw = heading_yaw(quat_to_matrix(clip.root_quaternion))
    turned = np.degrees(np.unwrap(yaw)[-1] - yaw[0])
    c, s = np.cos(yaw[0]), np.sin(yaw[0])
    d = clip.root_position[-1, :2] - clip.root_position[0, :2]
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]), float(turned)


@pytest.mark.parametrize(
    "name, forward, sideways, turn",
    [
        ("walk_fast", (1.5, 4.0), (-0.2, 0.2), (-10, 10)),
        ("walk_turn_left", (0.6, 1.6), (0.6, 1.6), (75, 105)),
        ("walk_turn_right", (0.6, 1.6), (-1.6, -0.6), (-105, -75)),
        ("turn_in_place_left", (-0.15, 0.15), (-0.15, 0.15), (75, 105)),
        ("turn_in_place_right", (-0.15, 0.15), (-0.15, 0.15), (-105, -75)),
        ("sidestep_left", (-0.15, 0.15), (0.6, 1.4), (-10, 10)),
        ("sidestep_right", (-0.15, 0.15), (-1.4, -0.6), (-10, 10)),
        ("walk_backward", (-1.6, -0.6), (-0.2, 0.2), (-10, 10)),
        ("start_stop", (0.9, 1.8), (-0.2, 0.2), (-10, 10)),
    ],
)
def test_each_motion_goes_where_its_name_says(clips, name, forward, sideways, turn):
    moved, turned = _travel(clips[name])
    assert forward[0] <= moved[0] <= forward[1] and sideways[0] <= moved[1] <= sideways[1], (name, moved)
    assert turn[0] <= turned <= turn[1], (name, turned)


def test_start_stop_starts_and_ends_standing_on_both_feet(clips):
    clip = clips["start_stop"]
    both = clip.contact("left_foot").astype(bool) & clip.contact("right_foot").astype(bool)
    second = int(clip.fps)
    assert both[:second].all() and both[-second:].all() and not both.all()


def test_every_walk_has_a_foot_down_on_every_frame(clips):
    """A walk is not a run: the fast walk's heels rise quickly enough that the
    contact test let the pushing foot go a frame before the other landed."""
    for name, clip in clips.items():
        down = clip.contact("left_foot").astype(bool) | clip.contact("right_foot").astype(bool)
        assert down.all(), (name, np.flatnonzero(~down))


def test_grounded_contacts_keep_the_pushing_foot_down_through_a_gap():
    from hotu_drake.motion.library.generate import _grounded

    left = np.array([1, 1, 1, 0, 0, 0, 0, 1], bool)
    right = np.array([1, 0, 0, 0, 1, 1, 1, 1], bool)
    filled = _grounded(left, right)
    np.testing.assert_array_equal(filled["left_foot"], [1, 1, 1, 1, 0, 0, 0, 1])
    np.testing.assert_array_equal(filled["right_foot"], right)


@pytest.mark.parametrize("robot", ["h1", "naviai", "walker", "bruce"])
def test_the_vocabulary_retargets_to_every_robot_within_limits_and_legs_apart(clips, robot):
    emb = embodiment.load(robot, "none")
    contacts = LegContacts(emb)
    for name, clip in clips.items():
        stage = to_robot(clip, robot, "none")
        q = stage.clip.joint_positions
        assert np.all(q >= emb.position_lower - 1e-9) and np.all(q <= emb.position_upper + 1e-9), (robot, name)
        assert contacts.depths(stage.clip).max() <= 0.005, (robot, name)
        before, after = (stage.margins[k][~np.isnan(stage.margins[k])] for k in ("before", "after"))
        inside, was = np.mean(after >= 0.0), np.mean(before >= 0.0)
        # After the pass: 0.967-1.0 on every motion and robot (BRUCE's walk_fast the least); a clip's
        # share can move by a few hundredths with the last bits of the arithmetic (see test_balance).
        assert inside >= 0.92 and (inside > was + 0.1 or inside > 0.95), (robot, name, was, inside)
