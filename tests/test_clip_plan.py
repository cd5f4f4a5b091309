"""The whole-body controller's plan: a ZMP path from the clip's footsteps, kept inside the soles."""

import dataclasses

import numpy as np

from hotu_drake.control.clip_plan import SHIFT_TIME, footstep_zmp, interp_rows, into_support

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def test_a_point_inside_the_support_stays_and_one_outside_moves_to_its_nearest_edge():
    np.testing.assert_allclose(into_support(np.array([0.3, 0.6]), SQUARE), [0.3, 0.6])
    np.testing.assert_allclose(into_support(np.array([1.5, 0.4]), SQUARE), [1.0, 0.4])
    np.testing.assert_allclose(into_support(np.array([-1.0, -2.0]), SQUARE), [0.0, 0.0])
    line = np.array([[0.0, 0.0], [0.0, 1.0]])  # a line foot (BRUCE's): its segment
    np.testing.assert_allclose(into_support(np.array([0.2, 0.5]), line), [0.0, 0.5])


def test_rows_interpolated_at_once_are_np_interp_on_each_column():
    """At a time of the grid, between two, before the first and past the
    last: every column as `np.interp` gives it (uneven times, signed rows)."""
    rng = np.random.default_rng(0)
    times = np.cumsum(rng.uniform(0.01, 0.1, 40))
    rows = rng.normal(size=(40, 5))
    for at in [times[0] - 1.0, times[0], times[7], 0.3 * times[3] + 0.7 * times[4], times[-1], times[-1] + 2.0]:
        expected = [np.interp(at, times, rows[:, k]) for k in range(rows.shape[1])]
        np.testing.assert_allclose(interp_rows(at, times, rows), expected, rtol=1e-12, atol=1e-15)


def test_the_planned_pressure_sits_under_the_stance_foot_and_moves_between_feet_in_double_support():
    """Both feet (1 s), the left (0.5 s), both for 0.2 s, the right (0.5 s):
    the pressure is under each stance foot's anchor while it stands alone,
    crosses straight from one to the other in the short double support, and
    in the long one before the first step keeps the clip's own path, inside
    the soles, until it shifts onto the left foot."""
    fps = 100
    schedule = [("left_foot", "right_foot")] * 100 + [("left_foot",)] * 50
    schedule += [("left_foot", "right_foot")] * 20 + [("right_foot",)] * 50
    times = np.arange(len(schedule)) / fps
    left, right = np.array([0.0, 0.1]), np.array([0.3, -0.1])
    anchors = [{"left_foot": left, "right_foot": right}] * len(schedule)
    clip_zmp = np.tile([0.2, 0.5], (len(schedule), 1))  # the clip's own: off to the side
    sole = np.array([[-0.05, -0.02], [0.05, -0.02], [0.05, 0.02], [-0.05, 0.02]])
    supports = [np.vstack([anchors[0][name] + sole for name in names]) for names in schedule]
    zmp = footstep_zmp(times, schedule, anchors, clip_zmp, supports)
    np.testing.assert_allclose(zmp[100:150], np.tile(left, (50, 1)))
    np.testing.assert_allclose(zmp[170:], np.tile(right, (50, 1)))
    crossing = zmp[150:170]
    assert np.all(np.diff(crossing[:, 0]) > 0) and np.all(np.diff(crossing[:, 1]) < 0)
    np.testing.assert_allclose(zmp[0], into_support(clip_zmp[0], supports[0]))
    assert zmp[0, 1] < 0.13  # the clip's pressure, brought inside the soles
    shift = int(SHIFT_TIME * fps)
    np.testing.assert_allclose(zmp[: 100 - shift], np.tile(zmp[0], (100 - shift, 1)))
    assert np.linalg.norm(zmp[99] - left) < np.linalg.norm(zmp[100 - shift] - left)


def _stepping_plan(right_up: list[slice], loop: bool = True):
    """A UDH standing clip (1 s, 10 fps: frames 0-10) with its right foot up over `right_up`, as a plan."""
    from hotu_drake import embodiment
    from hotu_drake.control.clip_plan import standing_clip

    emb = embodiment.load("udh", "none")
    clip = standing_clip(emb, 1.0, fps=10.0)
    contacts = clip.contacts.copy()
    for frames in right_up:
        contacts[frames, 1] = False
    return _plan(emb, dataclasses.replace(clip, source="a step", contacts=contacts), loop)[0]


def _library_plan(robot: str, motion: str, loop: bool):
    """The plan of a library motion on `robot`: (plan, plant, model, context)."""
    from hotu_drake import embodiment
    from hotu_drake.retarget.pipeline import library_clip

    return _plan(embodiment.load(robot, "none"), library_clip(motion, robot), loop)


def _plan(emb, clip, loop: bool):
    """`clip`'s plan on a plant of its own: (plan, plant, model, context)."""
    from pydrake.multibody.plant import MultibodyPlant

    from hotu_drake.control.clip_plan import ClipPlan

    plant = MultibodyPlant(0.0)
    model = emb.add_to_plant(plant, builtin_pd=False)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    return ClipPlan(clip, plant, model, emb, context, loop=loop), plant, model, context


def test_a_swing_foot_goes_from_its_last_frame_down_to_its_next():
    """`ClipPlan.swing_progress`: 1 while the clip has the foot down, from its
    last frame down (0) to its next (1); a loop's last swing lands in its next
    pass."""
    plan = _stepping_plan([slice(3, 7), slice(9, None)])  # down at 2 and 7
    progress = [plan.swing_progress("right_foot", frame / 10.0) for frame in range(3, 8)]
    assert progress == [0.2, 0.4, 0.6, 0.8, 1.0] and plan.swing_progress("left_foot", 0.5) == 1.0
    assert 0.0 < plan.swing_progress("right_foot", 0.95) < 1.0


def test_a_loops_swing_across_the_seam_between_passes_keeps_going():
    """Up over frames 8-10 and 0-2 of a loop (its frame 10 is its frame 0):
    the swing runs from frame 7 to the next pass's frame 3, six frames, and
    its progress grows across the seam."""
    plan = _stepping_plan([slice(0, 3), slice(8, None)])
    progress = [plan.swing_progress("right_foot", t) for t in (0.8, 0.9, 1.1, 1.2, 1.3)]
    np.testing.assert_allclose(progress, [1 / 6, 2 / 6, 4 / 6, 5 / 6, 1.0])


def test_a_time_halfway_between_frames_takes_the_later_whatever_its_last_bits():
    """A 60 Hz controller on a clip at half its rate asks for every other
    step a time halfway between two frames; computed two ways it differs in
    its last bits. Both take the later frame (Python's round took frame 2 at
    0.25 s and frame 3 a bit above: a foot's contact flipped on a rounding)."""
    plan = _stepping_plan([slice(3, 7)], loop=False)  # 10 fps: right foot down at 2, up at 3
    halfway = [0.25, 0.25 + 1e-16, 0.25 - 5e-17, 15 / 60, (2 + 0.5) * 0.1]
    assert {plan.planted(t)["right_foot"] for t in halfway} == {False}  # all frame 3


def test_until_landing_counts_to_the_next_frame_down():
    """`ClipPlan.until_landing`: 0 while the foot is down, the seconds to its
    next frame down, across a loop's seam."""
    plan = _stepping_plan([slice(0, 3), slice(8, None)])
    assert plan.until_landing("right_foot", 0.5) == 0.0
    np.testing.assert_allclose([plan.until_landing("right_foot", t) for t in (0.8, 0.9, 1.1)], [0.5, 0.4, 0.2])


def test_a_loop_is_planned_from_its_own_first_frame_and_on_across_its_seams():
    """A looped walk's first pass follows the plan from the clip's own first
    frame, where the robot starts (the plan's middle pass, which follows a
    pass before it, had H1's CoM 2.3 cm aside there, moving at 0.1 m/s);
    later passes the middle one; the planned CoM goes on across each seam."""
    plan, plant, model, context = _library_plan("h1", "walk", loop=True)
    plan.set_reference(context, 0.0)
    start = plant.CalcCenterOfMassPositionInWorld(context, [model])[:2]
    assert np.linalg.norm(plan.planned_com(0.0)[0] - start) < 0.005
    for seam in (plan.period, 2 * plan.period):
        before, after = (plan.planned_com(seam + step) for step in (-1e-4, 1e-4))
        np.testing.assert_allclose(before[0], after[0], atol=1e-3)
        np.testing.assert_allclose(before[1], after[1], atol=0.02)


def test_the_plans_velocities_are_those_its_reference_state_has():
    """`velocities` (no context set: the controller's reference accelerations
    take two a step) gives the generalized velocities `set_reference` sets, on
    a looped walk's passes (turned and shifted) and past the end of a clip
    that stops (at rest)."""
    for loop in (True, False):
        plan, plant, _, context = _library_plan("udh", "walk_turn_left", loop)
        for time in np.linspace(0.0, 2.5 * plan.period, 41):
            plan.set_reference(context, time)
            np.testing.assert_allclose(plan.velocities(time), plant.GetVelocities(context), rtol=0, atol=1e-12)
        assert loop or not plan.velocities(plan.period + 0.5).any()


def test_a_loops_root_is_its_clip_pose_placed_by_its_pass():
    """`set_reference` composes the root's pose with its pass's placement
    itself: on a turning walk's first four passes, the pelvis stands where
    Drake's own `SetFreeBodyPose` of the placed clip pose puts it, with the
    same positions (its quaternion's w kept positive)."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform, RotationMatrix

    plan, plant, _, context = _library_plan("udh", "walk_turn_left", loop=True)
    expected = plant.CreateDefaultContext()
    for time in np.linspace(0.0, 3.5 * plan.period, 29):
        plan.set_reference(context, time)
        index, clip_time = plan.pass_at(time)
        plant.SetPositionsAndVelocities(expected, plant.GetPositionsAndVelocities(context))
        quaternion, position = plan.playback.root_pose_at(clip_time)
        placement = plan.placement(index)
        placed = RigidTransform(RotationMatrix(placement.rotation), placement.shift)
        plant.SetFreeBodyPose(expected, plan._root, placed @ RigidTransform(Quaternion(quaternion), position))
        got, want = (plant.EvalBodyPoseInWorld(c, plan._root).GetAsMatrix4() for c in (context, expected))
        np.testing.assert_allclose(got, want, atol=1e-12)
        np.testing.assert_allclose(plant.GetPositions(context), plant.GetPositions(expected), atol=1e-12)
    assert index == 3


def test_the_convex_hull_is_the_corners_qhull_finds_counter_clockwise():
    """The support's hull (monotone chain, in Python floats) against
    scipy's qhull on random point sets and on a grid (repeated points,
    points along its edges): the same corners, counter-clockwise."""
    from scipy.spatial import ConvexHull

    from hotu_drake.control.clip_plan import _convex_hull

    rng = np.random.default_rng(3)
    grid = np.array([[x, y] for x in (0.0, 0.1, 0.2) for y in (-0.1, 0.0, 0.1)])  # collinear runs on every edge
    sets = [rng.uniform(-0.2, 0.2, (count, 2)) for count in (3, 5, 8, 20) for _ in range(20)]
    sets += [grid, np.vstack([grid, grid[::2]]), grid[rng.permutation(9)], np.vstack([grid[:3], grid[6:]])]
    for points in sets:
        hull = _convex_hull(points)
        qhull = points[ConvexHull(points).vertices]  # counter-clockwise in 2-D, no point inside an edge
        assert sorted(map(tuple, np.round(hull, 9))) == sorted(map(tuple, np.round(qhull, 9)))
        edges = np.roll(hull, -1, axis=0) - hull
        turns = edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]
        assert np.all(turns > 0.0)
    np.testing.assert_array_equal(_convex_hull(np.array([[0.1, 0.2], [0.1, 0.2]])), [[0.1, 0.2]])
