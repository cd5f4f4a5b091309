"""Run a scenario.

    python -m hotu_drake.simulate SCENARIO [--name NAME] [--duration S] [--seed N] [--html OUT.html] [--json]
    python -m hotu_drake.simulate SCENARIO --seeds 20 [--seed FIRST] [--json]

SCENARIO is the name of a shipped scenario (`stand_h1`, see `--list`) or
a scenario file (one scenario, or a catalogue with `--name`).

Builds the scenario's diagram, simulates it (`diagrams.run_scenario`) and prints `realtime_factor`,
`fell` (a body other than a foot touched the floor, or the pelvis dropped
below half its standing height), `min_pelvis_height`, `max_torque_ratio`
(largest |torque| over its effort limit) and `checksum` (of the final state:
the same on one machine run after run; another machine's floating-point
last bits may change it, so regression tests pin the state itself and
compare it with a tolerance). A scenario with a
reference motion also gets `tracking_rms` (rad, joint positions against the
reference, sampled every 50 ms); every run `root_travel_m` (the pelvis'
horizontal displacement), and one that follows a clip (under the
whole-body controller, `!WholeBodyTracking`, or a clone asked for a
motion, `!PolicyCheckpoint {latents: walk}`) `reference_travel_m` (its
clip's, looping with its root motion, over the same time). A scenario
that varies (`vary`: drop height, reference start, push speed, task
instance; a policy's latents) runs the member its seed draws (`--seed
N`), and the figures say which (`seed`, `drawn`). `--seeds N` runs N
members, from `--seed` (default: the scenario's own seed), and sums them
up: how many fell and which, the robot's travel (mean, least, most), and
following a clip the clip's and `travel_ratio` (as a training report's:
the mean of each run's ratio, runs whose clip moves under 5 cm left out;
over the whole run, so a fallen robot's travel stops where it fell). A
run the simulator fails on is listed with its error and the command
exits 1: one scenario evaluated over many seeds.
"""

import json
import sys
from pathlib import Path

import numpy as np

from hotu_drake.cli import ArgumentParser, positive_float, positive_int, run_cli
from hotu_drake.diagrams import run_scenario
from hotu_drake.io import check_output_path, write_text_atomic
from hotu_drake.learning.evaluation import travel_ratio
from hotu_drake.scenario import load_scenario, shipped_scenarios


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.simulate", description="Build and run a scenario file.")
    parser.add_argument(
        "scenario", nargs="?", help="the name of a shipped scenario (e.g. stand_h1) or a scenario YAML file"
    )
    parser.add_argument("--name", help="the scenario to run from a catalogue file (several named scenarios)")
    parser.add_argument("--list", action="store_true", help="list the shipped scenarios and exit")
    parser.add_argument("--duration", type=positive_float, help="simulated seconds (default: the scenario's)")
    parser.add_argument(
        "--seed", type=int, help="the member of the scenario's family to run: what its `vary` draws (default: its seed)"
    )
    parser.add_argument("--seeds", type=positive_int, help="run this many members, from --seed (default 0), and sum up")
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
    if args.seeds and args.html:
        parser.error("--html replays one run: give --seed N, not --seeds")
    scenario = load_scenario(args.scenario, args.name)
    if args.duration is not None:  # the scenario's own bounds, on the duration asked for
        scenario.duration = args.duration
        scenario.validate("--duration")
    if args.seed is not None:
        scenario.seed = args.seed
        scenario.validate("--seed")
    name = args.name or Path(args.scenario).stem
    if args.seeds:
        return _over_seeds(scenario, name, args.seeds, args.duration, args.json)
    meshcat = None
    if args.html:
        from pydrake.geometry import StartMeshcat

        meshcat = StartMeshcat()
    figures = run_scenario(scenario, args.duration, meshcat)
    figures["scenario"] = name
    if args.html:
        write_text_atomic(args.html, meshcat.StaticHtml())
    _print(figures, args.json)
    return 0


def _over_seeds(scenario, name: str, seeds: int, duration: float | None, as_json: bool) -> int:
    """Run `seeds` members of `scenario` from its seed; print each one's
    figures and their summary; 1 if the simulator failed on any."""
    first, runs = scenario.seed, []
    if not scenario.drawn()[1]:
        print(f"warning: {name} varies nothing (no vary:): its {seeds} runs are one run repeated", file=sys.stderr)
    for seed in range(first, first + seeds):
        scenario.seed = seed
        scenario.validate("--seeds")
        try:
            figures = run_scenario(scenario, duration) | {"scenario": name, "seed": seed}
        except RuntimeError as error:  # Drake's solver failures: this run, not the others
            figures = {"scenario": name, "seed": seed, "error": str(error).strip().splitlines()[0]}
        runs.append(figures)
        if not as_json:
            print(" ".join(f"{key} {figures[key]}" for key in SHOWN if key in figures), flush=True)
    summary = over_seeds(runs)
    _print(
        {"scenario": name, "seeds": [first, first + seeds - 1], "summary": summary}
        | ({"runs": runs} if as_json else {}),
        as_json,
    )
    return 1 if summary["failed"] else 0


SHOWN = ("seed", "drawn", "fell", "root_travel_m", "reference_travel_m", "error")  # each run's line under --seeds


def over_seeds(runs: list[dict]) -> dict:
    """Several runs' figures summed up (`--seeds`; runs with an `error` counted apart)."""
    done = [run for run in runs if "error" not in run]
    summary = {"runs": len(runs), "failed": len(runs) - len(done)}
    summary["falls"] = sum(bool(run["fell"]) for run in done)
    summary["fell_seeds"] = [run["seed"] for run in done if run["fell"]]
    if done:
        travel = [run["root_travel_m"] for run in done]
        summary["mean_root_travel_m"] = round(float(np.mean(travel)), 4)
        summary["root_travel_range_m"] = [min(travel), max(travel)]
    if done and all("reference_travel_m" in run for run in done):
        references = [run["reference_travel_m"] for run in done]
        summary["mean_reference_travel_m"] = round(float(np.mean(references)), 4)
        ratio = travel_ratio([run["root_travel_m"] for run in done], references)
        summary["travel_ratio"] = None if ratio is None else round(ratio, 4)
    return summary


def _print(figures: dict, as_json: bool) -> None:
    if as_json:
        print(json.dumps(figures, indent=2))
        return
    for key, value in figures.items():
        print(f"{key:18s} {value}")


if __name__ == "__main__":
    sys.exit(run_cli(main))
