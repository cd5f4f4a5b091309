"""Run a scenario.

    python -m hotu_drake.simulate SCENARIO [--name NAME] [--duration S] [--html OUT.html] [--json]

SCENARIO is the name of a shipped scenario (`stand_h1`, see `--list`) or
a scenario file (one scenario, or a catalogue with `--name`).

Builds the scenario's diagram, simulates it and prints `realtime_factor`,
`fell` (a body other than a foot touched the floor, or the pelvis dropped
below half its standing height), `min_pelvis_height`, `max_torque_ratio`
(largest |torque| over its effort limit) and `checksum` (of the final state:
the same on one machine run after run; another machine's floating-point
last bits may change it, so regression tests pin the state itself and
compare it with a tolerance). A scenario with a
reference motion also gets `tracking_rms` (rad, joint positions against the
reference, sampled every 50 ms).
"""

import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from hotu_drake.cli import ArgumentParser, positive_float, run_cli
from hotu_drake.diagrams import build_simulation
from hotu_drake.io import check_output_path, write_text_atomic
from hotu_drake.scenario import Scenario, load_scenario, shipped_scenarios

CHUNK = 0.05  # s between checks of falls and torques


def state_checksum(values: np.ndarray) -> str:
    """A short digest of a state, rounded so it is stable on one machine
    (not across machines: a value near a rounding boundary may round the
    other way; compare `run(..., state=True)`'s positions and velocities with a tolerance)."""
    rounded = np.round(np.asarray(values, dtype=float), 6) + 0.0  # no negative zeros
    return hashlib.sha256(rounded.tobytes()).hexdigest()[:16]


def run(scenario: Scenario, duration: float | None = None, meshcat=None, state: bool = False) -> dict:
    """Simulate a scenario; the figures `simulate` prints (and with `state`,
    the final `positions` and `velocities`)."""
    sim = build_simulation(scenario, meshcat=meshcat)
    emb, plant, context = sim.embodiment, sim.plant, sim.plant_context()
    fall = sim.fall_check()
    floating = fall.can_fall
    tracking = sim.diagram.HasOutputPort("reference_joint_positions")
    end = duration if duration is not None else scenario.duration
    fell, lowest, torque_ratio, wall, errors = False, np.inf, 0.0, 0.0, []
    if meshcat is not None:
        meshcat.StartRecording(set_visualizations_while_recording=False)
    t = 0.0
    while t < end - 1e-9:
        t = min(end, t + CHUNK)
        start = time.perf_counter()
        sim.simulator.AdvanceTo(t)
        wall += time.perf_counter() - start
        torques = plant.get_net_actuation_output_port(sim.model).Eval(context)
        torque_ratio = max(torque_ratio, float(np.max(np.abs(torques) / emb.effort_limits)))
        if floating:
            lowest = min(lowest, fall.pelvis_height(context))
            fell = fell or fall(context)
        if tracking:
            reference = sim.output("reference_joint_positions")
            errors.append(np.fromiter(sim.joint_positions().values(), float) - reference)
    if meshcat is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
    figures = {
        "scenario": scenario.embodiment,
        "duration": end,
        "realtime_factor": round(end / wall, 2) if wall > 0 else None,
        "fell": bool(fell),
        "min_pelvis_height": round(float(lowest), 4) if floating else None,
        "max_torque_ratio": round(torque_ratio, 4),
        "checksum": state_checksum(plant.GetPositionsAndVelocities(context)),
    }
    if state:
        figures["positions"] = plant.GetPositions(context).tolist()
        figures["velocities"] = plant.GetVelocities(context).tolist()
    if errors:
        figures["tracking_rms"] = round(float(np.sqrt(np.mean(np.square(errors)))), 4)
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.simulate", description="Build and run a scenario file.")
    parser.add_argument(
        "scenario", nargs="?", help="the name of a shipped scenario (e.g. stand_h1) or a scenario YAML file"
    )
    parser.add_argument("--name", help="the scenario to run from a catalogue file (several named scenarios)")
    parser.add_argument("--list", action="store_true", help="list the shipped scenarios and exit")
    parser.add_argument("--duration", type=positive_float, help="simulated seconds (default: the scenario's)")
    parser.add_argument("--html", help="write a Meshcat replay of the run")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    if args.list:
        for name, path in shipped_scenarios().items():
            print(f"{name:22s} {path.name}")
        return 0
    if not args.scenario:
        parser.error("give a scenario (a shipped name or a file)")
    if args.html:
        check_output_path(args.html)
    scenario = load_scenario(args.scenario, args.name)
    if args.duration is not None:  # the scenario's own bounds, on the duration asked for
        scenario.duration = args.duration
        scenario.validate("--duration")
    meshcat = None
    if args.html:
        from pydrake.geometry import StartMeshcat

        meshcat = StartMeshcat()
    figures = run(scenario, args.duration, meshcat)
    figures["scenario"] = args.name or Path(args.scenario).stem
    if args.html:
        write_text_atomic(args.html, meshcat.StaticHtml())
    if args.json:
        print(json.dumps(figures, indent=2))
    else:
        for key, value in figures.items():
            print(f"{key:18s} {value}")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
