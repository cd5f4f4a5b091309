"""Spec building blocks: shapes, inertias, mirroring, collision filter groups."""

import numpy as np
import pytest

from hotu_drake import embodiment
from hotu_drake.embodiment.builder import mirror_axis, mirror_point
from hotu_drake.embodiment.collision import filter_groups
from hotu_drake.embodiment.kinematics import link_poses
from hotu_drake.embodiment.spec import Geometry, LinkSpec, box, capsule, rotation_from_rpy, sphere


def test_primitive_inertias_match_textbook_formulas():
    assert np.diag(sphere(0.1).unit_inertia_local()) == pytest.approx([0.004] * 3)
    assert np.diag(box((0.1, 0.2, 0.3)).unit_inertia_local()) == pytest.approx(
        [(0.04 + 0.09) / 12, (0.01 + 0.09) / 12, (0.01 + 0.04) / 12]
    )
    from pydrake.multibody.tree import UnitInertia

    for radius, length in [(0.05, 0.3), (0.02, 0.1), (0.06, 0.6)]:
        ours = np.diag(Geometry("capsule", (radius, length)).unit_inertia_local())
        drake = np.diag(UnitInertia.SolidCapsule(radius, length, [0, 0, 1]).CopyToFullMatrix3())
        assert ours == pytest.approx(drake, rel=1e-9)
    # A capsule of zero length is a sphere.
    tiny = Geometry("capsule", (0.1, 1e-9))
    assert np.diag(tiny.unit_inertia_local()) == pytest.approx([0.004] * 3, rel=1e-6)


def test_capsule_between_points_is_oriented_along_the_segment():
    g = capsule(0.02, (0, 0, 0), (0.3, 0.4, 0.0))
    assert g.size[1] == pytest.approx(0.5)
    assert rotation_from_rpy(g.rpy) @ [0, 0, 1] == pytest.approx([0.6, 0.8, 0.0])
    assert g.position == pytest.approx((0.15, 0.2, 0.0))


def test_link_mass_properties_combine_shapes():
    link = LinkSpec("l", 2.0, "torso", visuals=[sphere(0.1, (0, 0, 0)), sphere(0.1, (0, 0, 1))])
    com, inertia = link.mass_properties()
    assert com == pytest.approx([0, 0, 0.5])
    assert inertia[0, 0] == pytest.approx(2 * 0.004 + 2 * 0.25)
    assert np.all(np.linalg.eigvalsh(inertia) > 0)


def test_mirroring_a_joint_mirrors_its_motion():
    axis, point = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8]), np.array([0.1, 0.2, -0.3])
    from hotu_drake.embodiment.kinematics import _axis_angle

    moved = _axis_angle(axis, 0.7) @ point
    mirrored = _axis_angle(mirror_axis(axis), 0.7) @ mirror_point(point)
    assert mirrored == pytest.approx(mirror_point(moved))


@pytest.mark.parametrize("name", ["udh", "h1", "walker", "curi"])
def test_standing_pose_is_left_right_symmetric(name):
    emb = embodiment.load(name, "full")
    poses = link_poses(emb.spec, emb.standing_pose_dict())
    for link in emb.spec.links:
        if link.name.startswith("left_"):
            right = "right_" + link.name[len("left_") :]
            assert poses[right][1] == pytest.approx(mirror_point(poses[link.name][1]), abs=0.02), link.name


def test_collision_filters_cover_adjacent_links_and_parts():
    groups = filter_groups(embodiment.load("udh", "full").spec)
    assert groups["adjacent_torso"] == ["pelvis", "torso"]  # across the 3-axis waist
    assert groups["adjacent_left_thigh"] == ["pelvis", "left_thigh"]
    hand = set(groups["part_left_arm"])
    assert "left_hand" in hand and "left_index_0_link" in hand
