"""Per-part DoF, hands variants, joint naming and key bodies of the six embodiments."""

import re

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.embodiment.spec import PARTS

# HOTU Table I, as counted in the facts sheet (H1 with its torso yaw joint).
EXPECTED = {
    "udh": dict(neck=3, torso=3, shoulder=6, elbow=2, wrist=6, finger=58, hip=6, knee=2, ankle=6, total=92),
    "naviai": dict(neck=2, torso=1, shoulder=6, elbow=2, wrist=6, finger=58, hip=6, knee=2, ankle=4, total=87),
    "h1": dict(neck=0, torso=1, shoulder=6, elbow=2, wrist=6, finger=58, hip=6, knee=2, ankle=2, total=83),
    "bruce": dict(neck=0, torso=0, shoulder=4, elbow=2, wrist=0, finger=0, hip=6, knee=2, ankle=2, total=16),
    "walker": dict(neck=2, torso=0, shoulder=6, elbow=2, wrist=6, finger=20, hip=6, knee=2, ankle=4, total=48),
    "curi": dict(neck=2, torso=3, shoulder=6, elbow=2, wrist=6, finger=58, hip=0, knee=0, ankle=0, total=77),
}
FINGER_NAMES = ("thumb", "index", "middle", "ring", "little")
_SIDED = "|".join((*PARTS, *FINGER_NAMES))
JOINT_NAME = re.compile(rf"^(?:(?:left|right)_(?:{_SIDED})_\w+|(?:neck|torso)_\w+|base_(?:x|y|yaw))$")


@pytest.mark.parametrize("name", embodiment.EMBODIMENT_NAMES)
def test_per_part_dof_matches_table(name):
    assert embodiment.load(name, "full").part_dof == EXPECTED[name]


@pytest.mark.parametrize("name", embodiment.EMBODIMENT_NAMES)
def test_hands_none_removes_exactly_the_fingers(name):
    full, none = embodiment.load(name, "full"), embodiment.load(name, "none")
    removed = set(full.joint_names) - set(none.joint_names)
    assert removed == set(full.finger_joints)
    assert set(none.joint_names) <= set(full.joint_names)
    assert none.part_dof["finger"] == 0
    assert none.part_dof["total"] == EXPECTED[name]["total"] - EXPECTED[name]["finger"]
    # Same names, same order for the joints both variants share.
    assert [n for n in full.joint_names if n not in removed] == none.joint_names


@pytest.mark.parametrize("name", embodiment.EMBODIMENT_NAMES)
def test_joint_names_follow_the_convention(name):
    emb = embodiment.load(name, "full")
    for joint in emb.joint_names:
        assert JOINT_NAME.match(joint), joint
    for part, joints in emb.parts.items():
        for joint in joints:
            side_or_part = joint.split("_")[0]
            assert side_or_part in ("left", "right", part), (part, joint)
            if side_or_part != part and part != "finger":
                assert joint.split("_")[1] == part, (part, joint)


def test_shared_parts_have_the_same_names_across_embodiments():
    """Retargeting matches parts by name: a hip is `<side>_hip_<axis>` everywhere."""
    for name in ("udh", "naviai", "h1", "walker", "bruce"):
        emb = embodiment.load(name, "none")
        for side in ("left", "right"):
            assert f"{side}_hip_y" in emb.parts["hip"]
            assert f"{side}_knee_y" in emb.parts["knee"]
            assert f"{side}_ankle_y" in emb.parts["ankle"]


@pytest.mark.parametrize("name", embodiment.EMBODIMENT_NAMES)
def test_key_bodies_limits_and_pose(name):
    emb = embodiment.load(name, "full")
    links = {link.name for link in emb.spec.links}
    for role in ("pelvis", "torso", "head", "left_hand", "right_hand"):
        assert emb.key_bodies[role] in links
    if emb.floating_base:
        assert emb.key_bodies["left_foot"] in links and emb.key_bodies["right_foot"] in links
    assert np.all(emb.position_lower < emb.position_upper)
    assert np.all(emb.effort_limits > 0) and np.all(emb.velocity_limits > 0)
    assert np.all(emb.kp > 0) and np.all(emb.kd > 0)
    assert np.all(emb.standing_pose >= emb.position_lower)
    assert np.all(emb.standing_pose <= emb.position_upper)


def test_curi_base_is_actuated_but_not_counted():
    curi = embodiment.load("curi", "none")
    assert curi.base_joints == ["base_x", "base_y", "base_yaw"]
    assert len(curi.joint_names) == curi.part_dof["total"] + 3
    assert not curi.floating_base


def test_masses_and_heights_follow_the_facts():
    """Whole-body masses (no hands) and standing heights from the facts sheet."""
    masses = {n: sum(link.mass for link in embodiment.load(n, "none").spec.links) for n in embodiment.EMBODIMENT_NAMES}
    assert masses["udh"] == pytest.approx(48.9, abs=0.05)  # R1 densities x volumes
    assert masses["h1"] == pytest.approx(51.4 + 2 * 0.3, abs=0.1)  # H1a, plus two rubber hands (est.)
    assert masses["bruce"] == pytest.approx(4.65, abs=0.05)
    assert masses["walker"] == pytest.approx(74.4, abs=0.1)
    assert masses["naviai"] == pytest.approx(25.93, abs=0.05)
    assert masses["curi"] == pytest.approx(285, abs=3)
    # Pelvis (or root) heights with straight legs at q = 0, from the sheet.
    zero_height = {"udh": 0.881, "h1": 1.044, "walker": 1.1425}
    for name, height in zero_height.items():
        emb = embodiment.load(name, "none")
        from hotu_drake.embodiment.kinematics import lowest_collision_point

        feet = [emb.key_bodies["left_foot"], emb.key_bodies["right_foot"]]
        assert -lowest_collision_point(emb.spec, {}, feet) == pytest.approx(height, abs=0.005)


def test_udh_takes_a_height():
    short, tall = embodiment.load("udh", "none", height=1.5), embodiment.load("udh", "none", height=1.9)
    ratio = tall.standing_pelvis_height / short.standing_pelvis_height
    assert ratio == pytest.approx(1.9 / 1.5, rel=0.01)
    assert sum(link.mass for link in tall.spec.links) > sum(link.mass for link in short.spec.links)
    with pytest.raises(ValueError, match="height"):
        embodiment.load("udh", height=4.0)
    with pytest.raises(ValueError, match="only the UDH"):
        embodiment.load("h1", height=1.5)


def test_unknown_names_are_rejected():
    with pytest.raises(ValueError, match="unknown embodiment"):
        embodiment.load("atlas")
    with pytest.raises(ValueError, match="hands"):
        embodiment.load("h1", hands="left")


def test_udh_segments_are_close_to_published_anthropometry():
    """UDH segment lengths and masses against Winter's fractions of height and mass."""
    udh = embodiment.load("udh", "none")
    height = 1.61

    def length(a: str, b: str) -> float:
        return np.linalg.norm(np.subtract(udh.spec.link(b).origin, udh.spec.link(a).origin)) / height

    lengths = {
        "upper arm": length("left_upper_arm", "left_forearm"),  # shoulder to elbow
        "forearm": length("left_forearm", "left_hand"),  # elbow to wrist
        "thigh": length("left_thigh", "left_shin"),
        "shank": length("left_shin", "left_foot"),
    }
    winter = {"upper arm": 0.186, "forearm": 0.146, "thigh": 0.245, "shank": 0.246}
    for segment, fraction in winter.items():
        assert lengths[segment] == pytest.approx(fraction, rel=0.12), segment
    body = sum(link.mass for link in udh.spec.links)
    thigh = udh.spec.link("left_thigh").mass / body
    assert thigh == pytest.approx(0.100, rel=0.15)
