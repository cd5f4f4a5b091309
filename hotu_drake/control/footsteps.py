"""Where a swing foot of the clip may land: beside the capture point, on its own side.

Standing on one foot, a robot's capture point (its CoM plus its velocity
over the pendulum's frequency) runs away from where it presses on the
floor, its offset growing as exp(frequency t) (the linear inverted
pendulum). The next foot must land on its own side of where the capture
point will then be: a left foot landing to the right of it leaves the
body falling to the left, over and past the foot that just landed. A
sole can still push from its outer edge (the capture point may lie that
far out); a line foot (BRUCE's) cannot push from anywhere but its line,
and nothing but the next step saves it. `WholeBodyController` moves the
clip's footstep (already moved by the capture point's error) so far
across as this asks, no further.
"""

from __future__ import annotations

import numpy as np


def heading_axes(heading: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A sole's forward (its length's direction `heading` (2,), made a unit
    vector) and its left (2,), on the floor."""
    forward = heading / np.linalg.norm(heading)
    return forward, np.array([-forward[1], forward[0]])


def side_of(foot: str) -> float:
    """Which side of the body foot `foot` is on: +1 a left one, -1 a right one."""
    return 1.0 if foot.startswith("left") else -1.0


def predicted_capture(capture: np.ndarray, pressure: np.ndarray, frequency: float, seconds: float) -> np.ndarray:
    """Where a capture point at `capture` (2,) will be in `seconds`, the
    pressure held at `pressure` (2,), for a pendulum of `frequency` (1/s)."""
    return pressure + (capture - pressure) * np.exp(frequency * seconds)


def beside_capture(
    landing: np.ndarray, capture: np.ndarray, left: np.ndarray, side: float, margin: float
) -> np.ndarray:
    """`landing` (2,) moved along `left` (a horizontal unit vector, the
    stance foot's left) just far enough to lie at least `margin` (m; less
    than zero: it may lie that far short) on its own side of `capture`
    (`side`: +1 a left foot, -1 a right one); unmoved if it does."""
    beside = side * float((landing - capture) @ left)
    return landing + side * max(margin - beside, 0.0) * left
