"""The whole-body controller taking the grasp set's objects: how many it holds up.

Each `hand_grasp@<seed>` (`motion.library.grasps`) on the UDH with its
hands, in a scene of the clip's first frame (the table welded, the object
free where it stands), performed by the whole-body controller from the
clip's first frame. An object is held when, halfway through the clip's
hold, it is at least `HELD_LIFT` above where it stood with a body of the
right hand touching it. The plant's step is a row's setting (the fingers'
links weigh 3-10 g).
"""

from __future__ import annotations

import time

HELD_LIFT = 0.05  # m above its start, halfway through the hold
LEAD_IN = 0.5  # s the controller holds the clip's first frame before it moves


def grasp_scenario(seed: int, time_step: float, control_rate: float = 60.0):
    """The scene and driver of one grasp of the set (see the module), run
    until halfway through its hold; returns (scenario, object kind, time)."""
    from hotu_drake import embodiment
    from hotu_drake.motion.library import grasps
    from hotu_drake.objects import clip_scene_objects
    from hotu_drake.retarget.references import reference_clip
    from hotu_drake.scenario import InitialCondition, Scenario, WholeBodyTracking

    name = f"hand_grasp@{seed}"
    clip = reference_clip(name, embodiment.load("udh", "full"))  # the clip the controller performs (cached)
    kind = next(track for track in clip.object_names if track != "table")
    at = LEAD_IN + 0.5 * (grasps.HOLD + grasps.LOWER)  # (the clip at its nominal duration)
    scenario = Scenario(
        embodiment="udh",
        hands="full",
        driver=WholeBodyTracking(motion=name, loop=False, lead_in=LEAD_IN),
        initial=InitialCondition(reference_time=0.0),
        control_rate=control_rate,
        objects=clip_scene_objects(clip.object_names, clip.object_poses[0]),
        duration=at,
    )
    scenario.plant_config.time_step = time_step
    return scenario, kind, at


def grasp_trial(seed: int, time_step: float) -> dict:
    """One grasp (see the module): the object, how far it rose, whether the
    right hand touches it, whether it is held, and the wall time."""
    from hotu_drake.diagrams import build_simulation

    start = time.perf_counter()
    scenario, kind, at = grasp_scenario(seed, time_step)
    sim = build_simulation(scenario)
    plant, context = sim.plant, sim.plant_context()
    body = plant.GetBodyByName(kind)
    rest = plant.EvalBodyPoseInWorld(context, body).translation()[2]
    sim.simulator.AdvanceTo(at)
    lift = float(plant.EvalBodyPoseInWorld(context, body).translation()[2] - rest)
    results = plant.get_contact_results_output_port().Eval(context)
    touching = False
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        names = {plant.get_body(info.bodyA_index()).name(), plant.get_body(info.bodyB_index()).name()}
        touching |= kind in names and any(name.startswith("right_") for name in names)
    return {
        "seed": seed,
        "object": kind,
        "lift_m": round(lift, 4),
        "touching": touching,
        "held": bool(touching and lift >= HELD_LIFT),
        "wall_s": round(time.perf_counter() - start, 2),
    }


def grasp_table(seeds: list[int], time_step: float) -> dict:
    """Every grasp of `seeds` at a plant step of `time_step`: the rows, the
    number held, and per object the held of the tried."""
    rows = [grasp_trial(seed, time_step) for seed in seeds]
    per_object: dict[str, list[int]] = {}
    for row in rows:
        held, tried = per_object.setdefault(row["object"], [0, 0])
        per_object[row["object"]] = [held + row["held"], tried + 1]
    return {
        "time_step": time_step,
        "held": sum(row["held"] for row in rows),
        "grasps": len(rows),
        "per_object": per_object,
        "rows": rows,
    }
