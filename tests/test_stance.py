"""Each robot keeps its own stance, and its legs do not pass through each other."""

import dataclasses

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.landmarks import landmark_placements
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.library import generate
from hotu_drake.motion.udh_skeleton import points_on_clip, udh_landmarks
from hotu_drake.retarget import retargeter as retargeting
from hotu_drake.retarget.metrics import report
from hotu_drake.retarget.pipeline import to_robot, to_udh
from hotu_drake.retarget.retargeter import Retargeter, RetargetOptions
from hotu_drake.retarget.stance import LegContacts, leg_clearance, sideways, stance, standing_width

LEGGED = ("udh", "h1", "naviai", "walker", "bruce")


@pytest.fixture(scope="module")
def udh_walk() -> MotionClip:
    return to_udh(generate("walk"), "none").clip


def _wide_hipped(extra: float = 0.1, splay: float = 0.15) -> Embodiment:
    """The UDH with its hips `extra` metres further apart on each side and
    standing with its legs splayed out by `splay` rad, soles flat (as H1
    and NAVIAI stand): a robot whose own stance is far wider, for its leg
    length, than the human's."""
    spec = embodiment.load("udh", "none").spec
    legs = {link.name for link in spec.links if link.part in ("hip", "knee", "ankle")}
    sign = {"left": 1.0, "right": -1.0}
    links = [
        dataclasses.replace(link, origin=(link.origin[0], link.origin[1] + sign[link.side] * extra, link.origin[2]))
        if link.name in legs
        else link
        for link in spec.links
    ]
    joints = [
        dataclasses.replace(j, offset=(j.offset[0], j.offset[1] + sign[j.name.split("_")[0]] * extra, j.offset[2]))
        if j.parent == spec.root.name and j.part == "hip"
        else j
        for j in spec.joints
    ]
    pose = dict(spec.standing_pose)
    for joint, angle in (("hip_x", splay), ("ankle_x", -splay)):
        pose[f"left_{joint}"], pose[f"right_{joint}"] = angle, -angle
    return Embodiment(dataclasses.replace(spec, name="wide_udh", links=links, joints=joints, standing_pose=pose))


def _retarget(emb: Embodiment, udh_clip: MotionClip, whole_clip: bool = True) -> MotionClip:
    landmarks = udh_landmarks(embodiment.load("udh", "none"), udh_clip)
    options = RetargetOptions(whole_clip=whole_clip)
    return Retargeter(emb, set(landmarks), options).retarget_landmarks(landmarks, udh_clip.fps, udh_clip)


def _stance(emb: Embodiment, clip: MotionClip) -> dict:
    return stance(emb, points_on_clip(emb, clip, landmark_placements(emb.spec)))


@pytest.mark.parametrize("whole_clip", [True, False], ids=["whole_clip", "per_frame"])
def test_a_wide_hipped_robot_keeps_its_own_width(udh_walk, whole_clip, monkeypatch):
    wide = _wide_hipped()
    assert standing_width(wide) > 2.2 * standing_width(embodiment.load("udh", "none"))
    kept = _stance(wide, _retarget(wide, udh_walk, whole_clip))
    assert kept["median"] > 0.9 and kept["least"] > 0.8 and kept["crossed_share"] == 0.0, kept
    # Without the legs' sideways targets they take the UDH's limb directions from the wider hips: feet together.
    monkeypatch.setattr(retargeting, "SIDEWAYS_WEIGHT", 0.0)
    lost = _stance(wide, _retarget(wide, udh_walk, whole_clip))
    assert lost["median"] < kept["median"] - 0.2, (kept, lost)


@pytest.mark.parametrize("robot", ["h1", "naviai", "walker", "bruce"])
def test_library_walk_on_each_robot_keeps_its_stance_and_legs_apart(udh_walk, robot):
    emb = embodiment.load(robot, "none")
    clip = to_robot(udh_walk, robot, "none").clip
    figures = _stance(emb, clip)
    udh = _stance(embodiment.load("udh", "none"), udh_walk)
    assert figures["median"] >= 0.8 * udh["median"] and figures["least"] >= 0.3, figures
    assert LegContacts(emb).depths(clip).max() <= 0.005


def test_the_balance_pass_keeps_a_swinging_foot_at_its_width(monkeypatch):
    """Nothing anchors a swinging foot as the pass sways the pelvis over the
    planted one: its sideways target, weighted over while it swings
    (`PASS_SWING_SIDEWAYS_FACTOR`), keeps the legs' directions from drawing
    it in as it passes the other (BRUCE's library walk)."""
    from hotu_drake.retarget import clip_programs
    from hotu_drake.retarget.pipeline import retarget_onto

    bruce = embodiment.load("bruce", "none")
    width = standing_width(bruce)

    def least() -> float:
        options = RetargetOptions(pace="auto")
        clip = retarget_onto(generate("walk"), ["bruce"], "none", options, bridge_hands="none")["bruce"].clip
        return float(sideways(points_on_clip(bruce, clip, landmark_placements(bruce.spec))).min() / width)

    held = least()
    monkeypatch.setattr(clip_programs, "PASS_SWING_SIDEWAYS_FACTOR", 1.0)
    drawn = least()
    assert held >= 0.998 and drawn < held - 0.002, (held, drawn)


@pytest.mark.parametrize("robot", ["h1", "naviai", "walker", "bruce"])
def test_a_planted_foot_is_flat_on_the_floor(udh_walk, robot):
    """The library walk's planted soles lie flat (a median within 2 degrees):
    the foot's neutral direction is the robot's own foot flat at rest, not
    where its neutral pose left it (NAVIAI's toes stood 6.8 degrees up,
    Walker's 12.9: on their heels)."""
    from hotu_drake.retarget.metrics import planted_sole_tilt
    from hotu_drake.retarget.tree import Tree

    emb = embodiment.load(robot, "none")
    clip = to_robot(udh_walk, robot, "none").clip
    contacts = {side: clip.contact(f"{side}_foot").astype(bool) for side in ("left", "right")}
    tilt = planted_sole_tilt(emb, Tree(emb.spec), clip, contacts)
    assert tilt["median"] < 2.0, tilt
    # and the figure sees a tilted sole: the same clip with its ankles pitched 0.2 rad
    pitched = dataclasses.replace(clip, joint_positions=clip.joint_positions.copy())
    for name in ("left_ankle_y", "right_ankle_y"):
        pitched.joint_positions[:, clip.joint_names.index(name)] += 0.2
    assert planted_sole_tilt(emb, Tree(emb.spec), pitched, contacts)["median"] > 9.0


def test_a_planted_foot_above_the_floor_is_caught_by_the_report(udh_walk):
    """`planted_sole_height_m`: the library walk's planted soles on H1 lie on
    the floor (median within 2 mm); the same clip raised 3 cm has every
    planted frame high."""
    from hotu_drake.retarget.metrics import PLANTED_HIGH, planted_sole_height
    from hotu_drake.retarget.tree import Tree

    emb = embodiment.load("h1", "none")
    clip = to_robot(udh_walk, "h1", "none").clip
    contacts = {side: clip.contact(f"{side}_foot").astype(bool) for side in ("left", "right")}
    height = planted_sole_height(emb, Tree(emb.spec), clip, contacts)
    assert height["median"] < 0.002, height
    raised = dataclasses.replace(clip, root_position=clip.root_position + [0.0, 0.0, 0.03])
    high = planted_sole_height(emb, Tree(emb.spec), raised, contacts)
    assert high["high_share"] == 1.0 and high["median"] > PLANTED_HIGH, high


def test_crossed_legs_are_caught_by_the_report():
    """A standing clip with the legs swung across each other: the report says crossed, and how deep they meet."""
    h1 = embodiment.load("h1", "none")
    frames = 10
    q = np.tile(h1.standing_pose, (frames, 1))
    cross = np.linspace(0.0, 0.6, frames)
    q[:, h1.joint_names.index("left_hip_x")] -= cross  # each thigh rolled towards the other
    q[:, h1.joint_names.index("right_hip_x")] += cross
    root = np.tile([0.0, 0.0, h1.standing_root_height], (frames, 1))
    quaternions = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    clip = MotionClip.from_positions("h1", "crossed", 30.0, list(h1.joint_names), q, root, quaternions)
    human = generate("squat").slice(0, frames)  # standing still: the source the robot clip is judged against
    figures = report(human, clip, h1, 1.0)
    assert figures["stance_ratio"]["least"] < 0.0 < figures["stance_ratio"]["crossed_share"]
    assert figures["leg_penetration_m"] > 0.02 and figures["leg_penetration_share"] > 0.0
    standing = report(human, dataclasses.replace(clip, joint_positions=np.tile(h1.standing_pose, (frames, 1))), h1, 1.0)
    assert standing["stance_ratio"]["least"] == pytest.approx(1.0, abs=1e-3) and standing["leg_penetration_m"] == 0.0


def test_leg_clearance_covers_the_legs_geometry():
    for robot in LEGGED:
        clearance = leg_clearance(embodiment.load(robot, "none").spec)
        assert 0.04 < clearance["ankle"] < 0.3 and 0.04 < clearance["knee"] < 0.3, (robot, clearance)
    walker = leg_clearance(embodiment.load("walker", "none").spec)
    assert walker["knee"] == pytest.approx(2 * (0.07 + 0.03075) + 0.01)  # the thigh capsule's radius and offset
