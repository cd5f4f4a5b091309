"""A catch step: where a standing robot steps when its capture point leaves its feet.

A robot on both feet whose capture point (its CoM plus its velocity over
the pendulum's frequency: where it would have to put its centre of
pressure to come to rest) lies outside the soles cannot stop by pushing
on them; a person steps. The controller (`WholeBodyController._start_catch`)
lifts the foot farther from the capture point (the other, nearer, carries
the robot meanwhile); `catch_landing` says where it lands: where the
capture point will be as it lands, with
its centre of pressure held at the stance sole's nearest point (the
linear inverted pendulum), kept within a reach of the stance foot and on
its own side of it. `CatchStep` is the swing itself: a minimum-jerk path
from liftoff to the landing with a lift between, and its velocity and
acceleration for a task's feed-forward. Through a catch and a second
after it the clip is tracked from where the feet stand sooner than after
the clip's own steps (`CATCH_FOOTING_EASING`): the robot has stepped off
the clip's footprint on purpose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.math import RotationMatrix

from hotu_drake.control.clip_plan import into_support, pendulum_frequency
from hotu_drake.control.footsteps import heading_axes, predicted_capture

CATCH_MARGIN = 0.01  # m: a capture point this far outside the soles starts a catch step
CATCH_SWING = 0.3  # s: a catch step's swing (H1 steps in 0.4-0.5 s walking; sooner is a smaller step)
CATCH_LIFT = 0.04  # m: how high a catching foot is lifted midway
CATCH_BEYOND = 0.03  # m: the foot lands this much past where the capture point will be, away from the stance sole
# The landing kept, in the stance foot's heading frame, this many standing widths to its side at least and at
# most, and within `CATCH_REACH` CoM heights ahead or behind it.
CATCH_WIDTH = (0.6, 1.4)
CATCH_REACH = 0.6
# A catching foot's task weight, in swing weights (`TrackingGains.swing_weight`): at one, the QP gave the foot
# up to the falling body's tasks, and H1's catches scraped 5-10 cm along the floor (its turning walk: 0 of 5 up).
CATCH_WEIGHT = 5.0
# s: through a catch and this long after its landing, the clip is tracked from where the feet stand with this
# time constant, not `footing.FOOTING_EASING`'s 0.6 s: at 0.6 the centre of mass was pulled back toward the
# footprint the robot had stepped off, and stepped out again (H1's turning walk from ten starts: 37 catch steps,
# 23 at 0.15 s; all ten up either way).
CATCH_FOOTING_TIME, CATCH_FOOTING_EASING = 1.0, 0.15
CATCH_TOUCHDOWN = 0.6  # a catch ends when the foot touches the floor this far (share of its swing) or later
CATCH_LATE = 2.0  # ... or, touching or not, this far: a foot that has not landed by then is given back to the clip
CATCH_MOVED = 0.02  # m: a catch whose foot landed this near where it lifted is counted as no step


def capture_point(com: np.ndarray, com_velocity: np.ndarray) -> np.ndarray:
    """The instantaneous capture point (2,) of a CoM at `com` moving at `com_velocity` (world)."""
    return com[:2] + com_velocity[:2] / pendulum_frequency(com[2])


def outside(point: np.ndarray, support: np.ndarray) -> float:
    """How far (m) `point` (2,) lies outside the convex hull of `support` (K, 2): 0 inside."""
    return float(np.linalg.norm(point - into_support(point, support)))


def _smooth(share: float) -> tuple[float, float, float]:
    """A minimum-jerk blend and its first and second derivatives (per unit share), at `share` in [0, 1]."""
    s = min(max(share, 0.0), 1.0)
    return (
        10 * s**3 - 15 * s**4 + 6 * s**5,
        30 * s**2 - 60 * s**3 + 30 * s**4,
        60 * s - 180 * s**2 + 120 * s**3,
    )


@dataclass
class CatchStep:
    """Foot `foot` stepping from `origin` to `goal` (its body origin, world)
    over `duration` s from `start`, held at `rotation` (its orientation at
    liftoff: flat as it stood)."""

    foot: str
    start: float
    duration: float
    origin: np.ndarray
    goal: np.ndarray
    rotation: RotationMatrix

    def share(self, time: float) -> float:
        """How far through the swing (0 at liftoff, 1 at the planned landing; more after it) `time` is."""
        return (time - self.start) / self.duration

    def target(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The foot's position, velocity and acceleration (world) at `time`:
        minimum jerk along the ground, lifted by `CATCH_LIFT` midway (a
        bump with no speed at either end); held at `goal` after it."""
        share = self.share(time)
        blend, rate, curvature = _smooth(share)
        span = self.goal - self.origin
        position = self.origin + blend * span
        velocity = rate * span / self.duration
        acceleration = curvature * span / self.duration**2
        if share < 1.0:
            s = max(share, 0.0)
            lift = 16.0 * s**2 * (1.0 - s) ** 2
            lift_rate = 32.0 * s * (1.0 - s) * (1.0 - 2.0 * s)
            lift_curvature = 32.0 * (1.0 - 6.0 * s + 6.0 * s**2)
            position[2] += CATCH_LIFT * lift
            velocity[2] += CATCH_LIFT * lift_rate / self.duration
            acceleration[2] += CATCH_LIFT * lift_curvature / self.duration**2
        return position, velocity, acceleration


def catch_landing(
    capture: np.ndarray,
    frequency: float,
    stance_support: np.ndarray,
    stance_anchor: np.ndarray,
    stance_heading: np.ndarray,
    side: float,
    standing_width: float,
    reach: float,
) -> np.ndarray:
    """Where (2,) the catching foot's anchor lands: where the capture point
    `capture` will be after `CATCH_SWING` s with the pressure held at the
    stance sole's (`stance_support`, (K, 2)) nearest point to it, a little
    past it (`CATCH_BEYOND`); then, in the stance foot's heading frame
    (`stance_heading`, (2,), its length's direction; `stance_anchor` its
    anchor), kept to the swing foot's side (`side`: +1 left, -1 right)
    between `CATCH_WIDTH` standing widths of it and within `reach` of it
    ahead or behind."""
    pressure = into_support(capture, stance_support)
    away = capture - pressure
    landing = predicted_capture(capture, pressure, frequency, CATCH_SWING)
    distance = np.linalg.norm(away)
    if distance > 1e-9:
        landing = landing + CATCH_BEYOND * away / distance
    forward, left = heading_axes(stance_heading)
    offset = landing - stance_anchor
    ahead = float(np.clip(offset @ forward, -reach, reach))
    across = side * float(np.clip(side * (offset @ left), *(share * standing_width for share in CATCH_WIDTH)))
    return stance_anchor + ahead * forward + across * left
