"""Catch steps: where a robot whose capture point has left its feet steps, and the swing there."""

import numpy as np
import pytest

from hotu_drake.control.catch_step import (
    CATCH_BEYOND,
    CATCH_LIFT,
    CATCH_SWING,
    CATCH_WIDTH,
    CatchStep,
    capture_point,
    catch_landing,
    outside,
)
from hotu_drake.control.clip_plan import GRAVITY

SOLE = np.array([[-0.05, -0.03], [-0.05, 0.03], [0.15, -0.03], [0.15, 0.03]])  # a sole 20 cm by 6 cm, ankle at 0


def test_the_capture_point_is_the_com_ahead_by_its_velocity_over_the_pendulums_frequency():
    com, velocity = np.array([0.1, -0.2, 1.0]), np.array([0.5, 0.0, 0.3])
    np.testing.assert_allclose(capture_point(com, velocity), [0.1 + 0.5 / np.sqrt(GRAVITY), -0.2])


def test_outside_is_the_distance_to_the_soles_hull():
    assert outside(np.array([0.0, 0.0]), SOLE) == 0.0
    assert outside(np.array([0.25, 0.0]), SOLE) == pytest.approx(0.10)
    assert outside(np.array([-0.05, 0.07]), SOLE) == pytest.approx(0.04)


def test_the_swing_goes_from_liftoff_to_the_landing_lifted_midway_and_still_at_both_ends():
    origin, goal = np.array([0.0, 0.2, 0.07]), np.array([0.3, 0.25, 0.065])
    step = CatchStep("left_foot", 1.0, 0.4, origin, goal, None)
    start, end, middle = step.target(1.0), step.target(1.4), step.target(1.2)
    np.testing.assert_allclose(start[0], origin, atol=1e-12)
    np.testing.assert_allclose(end[0], goal, atol=1e-12)
    np.testing.assert_allclose(start[1], 0.0, atol=1e-12)
    np.testing.assert_allclose(end[1], 0.0, atol=1e-12)
    np.testing.assert_allclose(middle[0], (origin + goal) / 2 + [0.0, 0.0, CATCH_LIFT], atol=1e-12)
    np.testing.assert_allclose(step.target(2.0)[0], goal)  # held there after it
    # Its velocity and acceleration are the derivatives of its path (a task's feed-forward).
    for time in (1.05, 1.13, 1.31):
        h = 1e-5
        before, after = step.target(time - h), step.target(time + h)
        np.testing.assert_allclose(step.target(time)[1], (after[0] - before[0]) / (2 * h), atol=1e-6)
        np.testing.assert_allclose(step.target(time)[2], (after[1] - before[1]) / (2 * h), atol=1e-4)


def test_a_catch_lands_where_the_capture_point_will_be_on_its_own_side_within_reach():
    frequency = np.sqrt(GRAVITY / 1.0)
    anchor, heading = np.zeros(2), np.array([1.0, 0.0])
    # A capture point 5 cm ahead of the right stance sole's toe, 12 cm to its left: the left foot steps there,
    # where it will have gone (from the toe's edge, growing as exp(frequency t)), and a little beyond.
    capture = np.array([0.20, 0.12])
    landing = catch_landing(capture, frequency, SOLE, anchor, heading, 1.0, 0.4, 0.6)
    pressure = np.array([0.15, 0.03])
    grown = pressure + (capture - pressure) * np.exp(frequency * CATCH_SWING)
    expected = grown + CATCH_BEYOND * (capture - pressure) / np.linalg.norm(capture - pressure)
    assert CATCH_WIDTH[0] * 0.4 < expected[1] < CATCH_WIDTH[1] * 0.4 and expected[0] < 0.6  # within its bounds
    np.testing.assert_allclose(landing, expected)
    # Far to the side: no wider than its widest, and never across the stance foot.
    wide = catch_landing(np.array([0.0, 0.6]), frequency, SOLE, anchor, heading, 1.0, 0.4, 0.6)
    assert wide[1] == pytest.approx(CATCH_WIDTH[1] * 0.4)
    crossing = catch_landing(np.array([0.0, -0.3]), frequency, SOLE, anchor, heading, 1.0, 0.4, 0.6)
    assert crossing[1] == pytest.approx(CATCH_WIDTH[0] * 0.4)
    # Far ahead: within reach.
    assert catch_landing(np.array([0.5, 0.2]), frequency, SOLE, anchor, heading, 1.0, 0.4, 0.6)[0] == 0.6
    # The stance foot turned a quarter to the left: ahead is +y, its left is -x.
    turned = catch_landing(np.array([0.0, 0.5]), frequency, SOLE[:, ::-1] * [-1, 1], anchor, [0.0, 1.0], 1.0, 0.4, 0.6)
    assert turned[1] == pytest.approx(0.6) and turned[0] < 0.0
