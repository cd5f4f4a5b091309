"""A clip's swing foot lands beside where the capture point will be, on its own side."""

import numpy as np
import pytest

from hotu_drake.control.clip_plan import GRAVITY
from hotu_drake.control.footsteps import beside_capture, predicted_capture


def test_the_capture_point_runs_away_from_the_pressure_as_the_pendulum_says():
    """Simulated with the linear inverted pendulum (pressure held), the
    capture point after 0.3 s is where `predicted_capture` puts it."""
    height, dt = 0.4, 1e-4
    frequency = np.sqrt(GRAVITY / height)
    com, velocity, pressure = np.array([0.0, 0.02]), np.array([0.1, 0.05]), np.array([0.01, -0.05])
    expected = predicted_capture(com + velocity / frequency, pressure, frequency, 0.3)
    for _ in range(3000):
        velocity = velocity + dt * frequency**2 * (com - pressure)
        com = com + dt * velocity
    np.testing.assert_allclose(com + velocity / frequency, expected, atol=1e-3)
    np.testing.assert_allclose(predicted_capture(expected, expected, frequency, 1.0), expected)  # at rest, stays


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_foot_landing_inward_of_the_capture_point_is_moved_out_just_far_enough(side):
    left = np.array([0.0, 1.0])
    capture = np.array([0.3, 0.02 * side])
    inward = np.array([0.35, -0.04 * side])  # across the capture point from its own side
    moved = beside_capture(inward, capture, left, side, 0.01)
    np.testing.assert_allclose(moved, [0.35, 0.03 * side])  # 1 cm beyond it, on its own side; not moved along
    outward = np.array([0.35, 0.12 * side])
    np.testing.assert_allclose(beside_capture(outward, capture, left, side, 0.01), outward)  # unmoved
    # A margin below zero lets it land that much short of the capture point.
    np.testing.assert_allclose(beside_capture(inward, capture, left, side, -0.03), [0.35, -0.01 * side])


def test_beside_is_measured_across_the_stance_foots_heading():
    """A stance foot turned 90 degrees (its left along -x): the foot moves along that left only."""
    left = np.array([-1.0, 0.0])
    moved = beside_capture(np.array([0.0, 0.0]), np.array([-0.05, 0.3]), left, 1.0, 0.01)
    np.testing.assert_allclose(moved, [-0.06, 0.0])
