"""The whole-body controller as a teacher: what it costs.

The real-time factor of a robot walking under the controller (QP and
simulation together, one core), the controller's and its QP's share of
that time, and the cost of one label query (`DiagramEnv.teacher_action`)
in the environment a learner steps.
"""

from __future__ import annotations

import time

import numpy as np


def walking_cost(robot: str, seconds: float, repeats: int = 1) -> dict:
    """`robot`'s shipped `whole_body_walk_<robot>` for `seconds`, `repeats`
    times (each on a new diagram): the middle run by real-time factor (the
    faster of the middle two of an even count) with its controller's and
    QP's shares of the wall time and whether it fell, and every run's
    real-time factor. On a shared machine one run's factor moves by a
    tenth from run to run."""
    runs = sorted((_walking_once(robot, seconds) for _ in range(repeats)), key=lambda run: run["realtime_factor"])
    return {**runs[len(runs) // 2], "realtime_factors": [run["realtime_factor"] for run in runs]}


def _walking_once(robot: str, seconds: float) -> dict:
    """One walk of `walking_cost`, timed from the diagram built."""
    from hotu_drake.diagrams import build_simulation
    from hotu_drake.scenario import load_scenario

    sim = build_simulation(load_scenario(f"whole_body_walk_{robot}"))
    controller = sim.systems["whole_body_controller"]
    controller.timings.update(act=0.0, qp=0.0, calls=0)
    fall, context = sim.fall_check(), sim.plant_context()
    start, fell, t = time.perf_counter(), False, 0.0
    while t < seconds - 1e-9 and not fell:
        t = min(seconds, t + 0.5)
        sim.simulator.AdvanceTo(t)
        fell = fall(context)
    wall = time.perf_counter() - start
    calls = max(controller.timings["calls"], 1)
    return {
        "robot": robot,
        "simulated_s": round(t, 3),
        "fell": bool(fell),
        "realtime_factor": round(t / wall, 2),
        "controller_share": round(controller.timings["act"] / wall, 3),
        "qp_share": round(controller.timings["qp"] / wall, 3),
        "controller_ms_per_step": round(1000 * controller.timings["act"] / calls, 3),
        "qp_ms_per_step": round(1000 * controller.timings["qp"] / calls, 3),
    }


def label_cost(robot: str, steps: int, hands: str = "none", motion: str = "walk") -> dict:
    """Milliseconds per `teacher_action` query in Imitation-v0 (`motion`,
    from a reference start at its first frame, stepped with the teacher's
    own actions), asked once a step (made without `teacher=True`, whose
    `info` would ask again and advance the controller's warm start and
    footing twice a step). With fingers (`hands="full"`) the teacher is the
    environments' `FingerlessTeacher`."""
    import gymnasium as gym

    import hotu_drake.envs  # noqa: F401 (registers the environments)

    env = gym.make("hotu_drake/Imitation-v0", robot=robot, hands=hands, motions=[motion])
    inner = env.unwrapped
    env.reset(seed=0, options={"init": "reference", "clip": 0, "time": 0.0})
    seconds, queries = [], 0
    for _ in range(steps):
        tick = time.perf_counter()
        action = inner.teacher_action()
        seconds.append(time.perf_counter() - tick)
        queries += 1
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    env.close()
    return {
        "robot": robot,
        "hands": hands,
        "motion": motion,
        "queries": queries,
        "ms_per_query_median": round(1000 * float(np.median(seconds)), 3),
        "ms_per_query_mean": round(1000 * float(np.mean(seconds)), 3),
    }
