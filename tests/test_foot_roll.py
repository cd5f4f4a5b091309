"""A planted foot that rolls over its sole's edge as the source's does, and
a capture's contacts that last while the toes roll."""

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.motion.load import load_motion
from hotu_drake.retarget.balance import ClipBalance
from hotu_drake.retarget.contacts import RELEASE_SPEED, detect_foot_contacts
from hotu_drake.retarget.foot_roll import FLAT, SoleEdges, foot_rolls
from hotu_drake.retarget.metrics import report
from hotu_drake.retarget.pipeline import retarget_onto
from hotu_drake.retarget.retargeter import foot_contacts_of
from hotu_drake.retarget.tree import axis_angles
from hotu_drake.rotations import quat_to_matrix
from tests.conftest import SHARED

QUALISYS = SHARED / "data" / "c3d" / "qualisys_walk.c3d"
EDGES = SoleEdges(front=0.16, back=-0.06, down=-0.07)


def _headings(frames: int, yaw: float = 0.7) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.tile(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), (frames, 1, 1))


def test_a_rolled_foot_turns_about_its_edge_which_stays_put():
    rolls = np.array([-0.4, -0.1, 0.0, 0.2, 0.6])
    headings = _headings(len(rolls))
    flat = np.array([[0.3, -0.2, 0.07]] * len(rolls))
    ankle = EDGES.rolled(flat, headings, rolls)
    np.testing.assert_allclose(EDGES.unrolled(ankle, headings, rolls), flat, atol=1e-12)
    # The edge is where it was, and the ankle as far from it.
    edge = flat + EDGES.pivots(headings, rolls)
    np.testing.assert_allclose(np.linalg.norm(ankle - edge, axis=1), np.linalg.norm(flat - edge, axis=1), atol=1e-12)
    # A heel up moves the ankle up and forward, toes up up and back; it rises by `rise`.
    forward = np.einsum("ti,ti->t", ankle - flat, headings[:, :, 0])
    assert forward[3] > 0 and forward[4] > 0 and forward[0] < 0 and forward[1] < 0
    np.testing.assert_allclose(ankle[:, 2] - flat[:, 2], EDGES.rise(rolls), atol=1e-12)
    assert np.all(EDGES.rise(rolls[rolls != 0]) > 0) and EDGES.rise(np.zeros(1))[0] == 0


def test_the_roll_that_raises_the_ankle_by_as_much_as_the_source_s():
    rises = np.array([0.0, 0.01, 0.03, 0.05, 0.01])
    ways = np.array([1.0, 1.0, 1.0, 1.0, -1.0])
    rolls = EDGES.rolls_rising(rises, ways)
    assert np.all(np.sign(rolls[1:]) == ways[1:])
    np.testing.assert_allclose(EDGES.rise(rolls), rises, atol=1e-4)
    assert np.all(EDGES.rolls_rising(rises, np.zeros(5)) == 0.0)  # a flat foot does not roll


def test_a_positive_roll_is_toes_down():
    """The rolls turn about the foot's left (its heading's y): positive takes its x (to the toes) down."""
    turn = axis_angles(np.array([[0.0, 1.0, 0.0]]), np.array([0.3]))[0]
    assert (turn @ np.array([1.0, 0.0, 0.0]))[2] < 0


def test_a_short_heel_rolls_no_further_than_raises_its_ankle_most():
    """About H1's short heel the ankle rises at most 8 mm (at 26 degrees):
    a toes-up rise beyond that is the highest roll, not one past it."""
    h1_like = SoleEdges(front=0.16, back=-0.035, down=-0.07)
    peak = np.arctan2(0.035, 0.07)
    rises = np.array([0.002, 0.006, h1_like.rise(np.array([-peak]))[0], 0.02])
    rolls = h1_like.rolls_rising(rises, -np.ones(4))
    assert np.all(np.diff(-rolls) > -1e-12) and -rolls[-1] == pytest.approx(peak)
    np.testing.assert_allclose(h1_like.rise(rolls[:3]), rises[:3], atol=1e-4)


def test_the_source_s_roll_is_read_over_its_planted_frames():
    frames = 60
    pitch = np.full(frames, 0.35)  # a person's ankle-to-toe line slopes down even flat
    pitch[40:] += np.linspace(0.0, 0.5, 20)  # the heel rises
    pitch[:5] -= 0.2  # toes still coming down
    x = np.stack([np.cos(pitch), np.zeros(frames), -np.sin(pitch)], -1)
    y = np.tile([0.0, 1.0, 0.0], (frames, 1))
    frame = np.stack([x, y, np.cross(x, y)], -1)
    ankle = np.zeros((frames, 3))
    ankle[:, 2] = 0.07 + np.r_[np.zeros(40), np.linspace(0.0, 0.06, 20)]
    planted = np.ones(frames, bool)
    planted[55:] = False
    ways, rises = foot_rolls({"left_ankle": ankle}, {"left_foot": frame}, {"left": planted})["left"]
    assert np.all(ways[:5] == -1.0) and np.all(ways[5:40] == 0.0) and np.all(ways[45:55] == 1.0)
    assert np.all(ways[55:] == 0.0) and np.all(rises[55:] == 0.0)  # lifted: not a roll of a planted foot
    np.testing.assert_allclose(rises[:40], 0.0)
    assert rises[54] == pytest.approx(0.06 * 14 / 19)
    assert abs(pitch[41] - 0.35) < FLAT and ways[41] == 0.0  # within FLAT: flat


def test_a_capture_s_foot_stays_planted_while_its_toes_roll():
    """Heel still and down, then the heel rises over toes whose landmark
    moves forward at 0.2 m/s (under `RELEASE_SPEED`), then at 1 m/s."""
    fps, frames = 200.0, 120
    t = np.arange(frames) / fps
    heel, toe = np.zeros((frames, 3)), np.zeros((frames, 3))
    heel[:, 2], toe[:, 2], toe[:, 0] = 0.07, 0.01, 0.15
    heel[60:, 2] += 0.4 * (t[60:] - t[60])
    heel[60:, 0] += 0.6 * (t[60:] - t[60])
    toe[60:90, 0] += 0.2 * (t[60:90] - t[60])
    toe[90:, 0] = toe[89, 0] + 1.0 * (t[90:] - t[89])
    still = {"toe": np.tile([0.0, 0.3, 0.01], (frames, 1)), "ankle": np.tile([-0.15, 0.3, 0.07], (frames, 1))}
    landmarks = {"left_toe": toe, "left_ankle": heel, "right_toe": still["toe"], "right_ankle": still["ankle"]}
    planted = detect_foot_contacts(landmarks, fps)["left"]
    assert 0.2 < RELEASE_SPEED < 1.0
    assert planted[:89].all() and not planted[92:].any()
    # Played backwards: a foot coming down low, still sliding at 0.2 m/s, is planted from then.
    backwards = {name: points[::-1] for name, points in landmarks.items()}
    assert np.array_equal(detect_foot_contacts(backwards, fps)["left"], planted[::-1])


@pytest.mark.skipif(not QUALISYS.exists(), reason="the shared C3D capture is not here")
def test_a_capture_s_planted_feet_stay_on_the_floor_as_their_heels_rise():
    """The Qualisys walk: the planted soles were up to 14.6 cm above the
    floor on H1 (the leg could not reach a flat foot on its landing point as
    the body went on); rolled over their toes, within a few centimetres."""
    source = load_motion(QUALISYS)
    clip = retarget_onto(source, ["h1"], "none")["h1"].clip
    h1 = embodiment.load("h1", "none")
    figures = report(source, clip, h1, 1.0)
    assert figures["planted_sole_height_m"]["most"] < 0.04
    assert figures["planted_sole_height_m"]["high_share"] < 0.15  # 0.20 flat on their landing points
    # The rolled feet stand on their edges: somewhere in each planted frame a sole point is on the floor.
    dynamics = ClipBalance(h1)
    poses = dynamics.poses(clip.joint_positions, quat_to_matrix(clip.root_quaternion), clip.root_position)
    contacts = foot_contacts_of(clip, clip.num_frames)
    for side, planted in contacts.items():
        world, radii = dynamics.soles.points_frames(poses, side)
        lowest = (world[..., 2] - radii).min(axis=1)
        assert np.median(lowest[np.asarray(planted, bool)]) < 0.005


def test_a_landing_foot_is_planted_on_the_floor_not_where_the_other_held_the_body():
    """NAVIAI's walk backwards: as each foot lands, the other (its sole
    still down) holds the body up; planted where it landed, the landing sole
    hovered up to 2.9 cm on 12% of the planted frames. Its anchor has its
    sole on the floor now."""
    from hotu_drake.retarget.metrics import planted_sole_height
    from hotu_drake.retarget.pipeline import library_clip
    from hotu_drake.retarget.tree import Tree

    clip = library_clip("walk_backward", "naviai")
    emb = embodiment.load("naviai", "none")
    contacts = {side: clip.contact(f"{side}_foot").astype(bool) for side in ("left", "right")}
    height = planted_sole_height(emb, Tree(emb.spec), clip, contacts)
    assert height["most"] < 0.015 and height["high_share"] < 0.03, height
