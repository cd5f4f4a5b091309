"""Pushes against the whole-body controller: which thrown cubes a robot survives.

A cube (10 cm, 4 m/s, its mass setting the momentum) is thrown at the
torso from 1 m ahead and 1 m to the left (as `perturb_<robot>` throws its
cubes) and from 1 m behind, aimed at where the torso is as it is thrown (a
cube that misses a walking robot counts as survived): at a robot standing
under the controller (tracking its standing clip; the cube at 0.5 s, 3 s
in all) and at one walking (`whole_body_walk_<robot>`, seed 0; the cube
at 2.0 s, 6 s in all). A trial falls when the robot does (`FallCheck`)
before its end.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

SPEED = 4.0  # m/s: the cube's
# Where a cube is thrown from, in the robot's start frame: `perturb_<robot>`'s two (ahead, the left) and behind.
DIRECTIONS = {"ahead": (1.0, 0.0), "left": (0.0, 1.0), "behind": (-1.0, 0.0)}


def push_trial(robot: str, momentum: float, direction: str, walking: bool, folder: Path) -> float | None:
    """Throw a cube of `momentum` (kg m/s) at `robot` from `direction`,
    standing or `walking`; when it fell (s), or None."""
    from hotu_drake import embodiment
    from hotu_drake.control.clip_plan import standing_clip
    from hotu_drake.diagrams import build_simulation
    from hotu_drake.scenario import InitialCondition, Scenario, WholeBodyTracking, load_scenario
    from hotu_drake.systems.perturbation import CubeLaunch

    emb = embodiment.load(robot, "none")
    height = emb.standing_root_height + 0.2
    x, y = DIRECTIONS[direction]
    if walking:
        scenario, at, end = load_scenario(f"whole_body_walk_{robot}"), 2.0, 6.0
        x += 0.7  # where the walk has taken it by then, near enough for a cube aimed as it flies
    else:
        path = standing_clip(emb, 3.0).save(folder / f"standing_{robot}.npz")
        scenario = Scenario(
            embodiment=robot,
            driver=WholeBodyTracking(motion=str(path), loop=False, lead_in=0.0),
            initial=InitialCondition(reference_time=0.0),
            control_rate=60.0,
        )
        at, end = 0.5, 3.0
    scenario.duration = end
    scenario.perturbations = [
        CubeLaunch(time=at, start=[x, y, height], speed=SPEED, mass=momentum / SPEED, size=0.1, aim_height=0.2)
    ][: int(momentum > 0)]  # momentum 0: no cube, the robot's own fall rate
    sim = build_simulation(scenario)
    fall, context = sim.fall_check(), sim.plant_context()
    for t in np.arange(0.25, end + 1e-9, 0.25):
        sim.simulator.AdvanceTo(float(t))
        if fall(context):
            return round(float(t), 2)
    return None


def push_table(robots: list[str], momenta: list[float]) -> list[dict]:
    """One row per robot, motion (standing, walking) and momentum (0: no
    cube): the directions it fell from, and when."""
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for robot in robots:
            for walking in (False, True):
                for momentum in momenta:
                    directions = list(DIRECTIONS) if momentum > 0 else ["behind"]  # no cube: one run
                    falls = {d: push_trial(robot, momentum, d, walking, Path(folder)) for d in directions}
                    rows.append(
                        {
                            "robot": robot,
                            "motion": "walking" if walking else "standing",
                            "momentum_kg_m_s": momentum,
                            "fell": sum(t is not None for t in falls.values()),
                            "trials": len(falls),
                            "fell_at_s": {d: t for d, t in falls.items() if t is not None},
                        }
                    )
    return rows
