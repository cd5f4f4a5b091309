"""The steering vocabulary: what a controller needs to go anywhere.

A fast walk, walks turning a quarter turn left and right over a few steps,
quarter turns in place, sidesteps both ways, a walk backwards, and a
start from and stop to standing. Every one places its footsteps and plans
its pelvis path to keep the centre of pressure on the feet
(`plan_base(..., balanced=True)`, Drake's `ZmpPlanner`), as the walk does.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hotu_drake.motion.library.planning import Scene, stepping, walk_along
from hotu_drake.motion.synthesis import Plan, Step, path_steps, stance_pose

QUARTER = np.pi / 2
# rad: how far the fast walk's heels rise as each foot pushes off (the other walks' 0.3). A person's foot
# leaves the floor steeper the faster they walk; at 0.3 the fast walk's trailing ankle was 0.11 m up while
# 0.54 m behind the pelvis, and the legs' reach held the pelvis 6-13 cm below standing, knees bent past
# what the robots' knees hold (BENCHMARKS.md, issue 28's fifth session).
FAST_PUSH_OFF = 0.9


def walk_fast(sc: Scene) -> Plan:
    """A straight walk with longer, quicker steps (about 1.1 m/s for a 1.75 m person, the walk's 0.8)."""
    step = 0.55 * sc.s * sc.jitter(0.05)
    step_time = 0.5 * sc.jitter(0.05)
    count = max(4, int((sc.duration - 1.0) / step_time + 0.22))
    path = np.array([[0.0, 0.0, 0.0], [(count - 1) * step, 0.0, 0.0]])
    return walk_along(sc, path, step, step_time, count, heel=FAST_PUSH_OFF)


def _arc(radius: float, turn: float, points: int = 24) -> np.ndarray:
    """Poses (x, y, heading) along a circular arc from the origin facing +x, turning by `turn` (rad)."""
    angle = np.linspace(0.0, turn, points)
    sign = np.sign(turn)
    return np.column_stack([radius * np.sin(np.abs(angle)), sign * radius * (1.0 - np.cos(angle)), angle])


def _walk_turning(sc: Scene, turn: float) -> Plan:
    step = 0.4 * sc.s * sc.jitter(0.05)
    step_time = 0.55 * sc.jitter(0.05)
    radius = 1.0 * sc.s
    count = max(4, int(round(abs(turn) * radius / step)) + 1)
    first = "right" if turn > 0 else "left"  # the outer foot leads into a turn
    return walk_along(sc, _arc(radius, turn), step, step_time, count, first)


def walk_turn_left(sc: Scene) -> Plan:
    """A walk turning a quarter turn to the left on a 1 m radius (about five steps)."""
    return _walk_turning(sc, QUARTER)


def walk_turn_right(sc: Scene) -> Plan:
    """A walk turning a quarter turn to the right on a 1 m radius."""
    return _walk_turning(sc, -QUARTER)


def _turn_in_place(sc: Scene, turn: float) -> Plan:
    """Steps about the spot between the feet, a quarter turn in four steps:
    the foot on the side of the turn opens, the other closes, and so on."""
    step_time = 0.6 * sc.jitter(0.05)
    count = 4
    side = "left" if turn > 0 else "right"
    steps = []
    for i in range(count):
        heading = turn * (i + 1) / count if i < count - 1 else turn
        start = 0.4 + i * step_time
        pose = stance_pose(0.0, 0.0, heading, sc.width)[side]
        steps.append(Step(side, start, start + 0.78 * step_time, pose, height=0.05))
        side = "right" if side == "left" else "left"
    steps.append(
        Step(
            side,
            0.4 + count * step_time,
            0.4 + (count + 0.78) * step_time,
            stance_pose(0.0, 0.0, turn, sc.width)[side],
            height=0.05,
        )
    )
    return stepping(sc, steps, 0.1 * sc.s, step_time, swing=False)


def turn_in_place_left(sc: Scene) -> Plan:
    """A quarter turn to the left on the spot."""
    return _turn_in_place(sc, QUARTER)


def turn_in_place_right(sc: Scene) -> Plan:
    """A quarter turn to the right on the spot."""
    return _turn_in_place(sc, -QUARTER)


def _sidestep(sc: Scene, direction: float) -> Plan:
    """Steps sideways, facing +x: the leading foot opens, the other closes up (four times)."""
    step = 0.25 * sc.s * sc.jitter(0.05)
    step_time = 0.6 * sc.jitter(0.05)
    lead, trail = ("left", "right") if direction > 0 else ("right", "left")
    steps = []
    for i in range(4):
        y = direction * step * (i + 1)
        start = 0.4 + 2 * i * step_time
        opened = stance_pose(0.0, y - direction * step / 2, 0.0, sc.width + step / 2)[lead]
        closed = stance_pose(0.0, y, 0.0, sc.width)[trail]
        steps.append(Step(lead, start, start + 0.78 * step_time, opened, height=0.05))
        steps.append(Step(trail, start + step_time, start + 1.78 * step_time, closed, height=0.05))
    return stepping(sc, steps, 0.1 * sc.s, step_time, swing=False)


def sidestep_left(sc: Scene) -> Plan:
    """Four sidesteps to the left."""
    return _sidestep(sc, 1.0)


def sidestep_right(sc: Scene) -> Plan:
    """Four sidesteps to the right."""
    return _sidestep(sc, -1.0)


def walk_backward(sc: Scene) -> Plan:
    """A walk backwards, facing +x, with short steps."""
    step = 0.3 * sc.s * sc.jitter(0.05)
    step_time = 0.6 * sc.jitter(0.05)
    count = max(4, int((sc.duration - 1.0) / step_time + 0.22))
    path = np.array([[0.0, 0.0, 0.0], [-(count - 1) * step, 0.0, 0.0]])
    return walk_along(sc, path, step, step_time, count)


def start_stop(sc: Scene) -> Plan:
    """Standing, a walk of four steps, standing again."""
    step = 0.45 * sc.s * sc.jitter(0.05)
    step_time = 0.55 * sc.jitter(0.05)
    steps, _ = path_steps(
        np.array([[0.0, 0.0, 0.0], [3 * step, 0.0, 0.0]]), "right", 1.5, step_time, 0.78 * step_time, 4, sc.width
    )
    return stepping(sc, steps, step, step_time)


# The vocabulary by name, in the order the library lists it.
VOCABULARY: dict[str, Callable[[Scene], Plan]] = {
    "walk_fast": walk_fast,
    "walk_turn_left": walk_turn_left,
    "walk_turn_right": walk_turn_right,
    "turn_in_place_left": turn_in_place_left,
    "turn_in_place_right": turn_in_place_right,
    "sidestep_left": sidestep_left,
    "sidestep_right": sidestep_right,
    "walk_backward": walk_backward,
    "start_stop": start_stop,
}
