"""Benchmarks; each prints JSON.

python -m hotu_drake.bench standing [--robot NAME|all] [--hands full|none|both]
                                    [--seconds S] [--time-step DT] [--no-self-collision]
python -m hotu_drake.bench retarget [--input FILE] [--hands full|none|both] [--seconds S]
python -m hotu_drake.bench diagram  [--robot NAME|all] [--hands full|none|both] [--seconds S] [--markdown]
python -m hotu_drake.bench env      [--robot NAME] [--hands full|none] [--envs N] [--seconds S]
                                    [--motions M ...] [--peer mujoco] [--json]
"""

import json
import sys

from hotu_drake import embodiment
from hotu_drake.bench.standing import machine, pin_to_one_core, standing_realtime_factor
from hotu_drake.cli import ArgumentParser, UserError, positive_float, run_cli
from hotu_drake.errors import check_number
from hotu_drake.scenario import LIMITS, MAX_PLANT_STEPS


def _retarget(args) -> int:
    from hotu_drake.bench.retarget import retarget_throughput, source_clip
    from hotu_drake.motion.clip import ClipFormatError

    try:
        source = source_clip(args.input, args.seconds)
    except ClipFormatError as error:
        raise UserError(str(error)) from None
    pin_to_one_core()
    results = []
    for hands in ("full", "none") if args.hands == "both" else (args.hands,):
        for row in retarget_throughput(source, hands):
            print(json.dumps(row), file=sys.stderr, flush=True)
            results.append(row)
    report = {
        "benchmark": "retarget",
        "machine": machine(),
        "source": {"clip": source.source, "frames": source.num_frames, "fps": source.fps},
        "results": results,
    }
    print(json.dumps(report, indent=2))
    return 0


def _diagram(args, names) -> int:
    import tempfile
    from pathlib import Path

    import torch

    from hotu_drake.bench.diagram import diagram_costs, summary

    pin_to_one_core()
    torch.set_num_threads(1)
    results = []
    with tempfile.TemporaryDirectory() as workdir:
        for name in names:
            for hands in ("full", "none") if args.hands == "both" else (args.hands,):
                row = diagram_costs(name, hands, args.seconds, Path(workdir))
                print(json.dumps(row), file=sys.stderr, flush=True)
                results.append(row)
    report = {
        "benchmark": "diagram",
        "machine": machine(),
        "settings": {"time_step": 0.005, "control_rate": 30.0, "seconds": args.seconds, "cores": 1},
        "results": results,
    }
    print(json.dumps(report, indent=2))
    if args.markdown:
        print("\n".join(summary(results)), file=sys.stderr)
    return 0


def _env(args) -> int:
    from hotu_drake.bench import env as bench_env
    from hotu_drake.retarget.references import reference_clips

    if args.envs < 1 or args.envs > 64:
        raise UserError("--envs must be between 1 and 64")
    if args.seconds > 3600:
        raise UserError("--seconds must be at most 3600")
    emb = embodiment.load(args.robot, args.hands)
    reference_clips(emb, args.motions)  # retarget (or load from the cache) once, before timing
    report: dict = {"benchmark": "env", "machine": machine(), "robot": args.robot, "hands": args.hands}
    report["settings"] = {
        "time_step": 1.0 / 180.0,
        "control_rate": 30.0,
        "seconds": args.seconds,
        "motions": args.motions,
    }
    report["vectorised"] = bench_env.vectorised(args.robot, args.hands, args.seconds, args.motions, args.envs)
    pin_to_one_core()
    report["in_process"] = bench_env.in_process(args.robot, args.hands, args.seconds, args.motions)
    report["env_steps_per_second"] = report["vectorised"]["env_steps_per_second"]
    report["sim_seconds_per_wall_second"] = report["vectorised"]["sim_seconds_per_wall_second"]
    report["ms_per_step"] = report["in_process"]["ms_per_step"]
    if args.peer == "mujoco":
        try:
            peer = bench_env.mujoco_peer(args.robot, args.hands, args.seconds)
        except RuntimeError as error:
            raise UserError(str(error)) from None
        report["peer"] = peer
        report["drake_to_mujoco_ratio"] = round(
            report["in_process"]["env_steps_per_second"] / peer["env_steps_per_second"], 3
        )
    report["peak_memory_mb"] = bench_env.peak_memory_mb()
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        for key in ("env_steps_per_second", "sim_seconds_per_wall_second", "ms_per_step", "drake_to_mujoco_ratio"):
            if key in report:
                print(f"{key:28s} {report[key]}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.bench", description="Benchmarks that print JSON.")
    sub = parser.add_subparsers(dest="command", required=True)
    standing = sub.add_parser("standing", help="real-time factor of each embodiment standing after a 0.1 m drop")
    standing.add_argument("--robot", default="all", help="an embodiment name or 'all'")
    standing.add_argument("--hands", choices=["full", "none", "both"], default="both")
    standing.add_argument("--seconds", type=positive_float, default=5.0, help="simulated seconds per run")
    standing.add_argument("--time-step", type=positive_float, default=0.005, help="plant step (s), at most 0.05")
    standing.add_argument("--no-self-collision", action="store_true")
    standing.add_argument("--json", action="store_true", help="accepted for symmetry; output is always JSON")
    retarget = sub.add_parser("retarget", help="retargeting frames per second per robot (human -> UDH -> robot)")
    retarget.add_argument("--input", help="a BVH, C3D or .npz demonstration (default: the generated walk at 120 fps)")
    retarget.add_argument("--hands", choices=["full", "none", "both"], default="both")
    retarget.add_argument("--seconds", type=positive_float, help="use only the first S seconds")
    retarget.add_argument("--json", action="store_true", help="accepted for symmetry; output is always JSON")
    diagram = sub.add_parser("diagram", help="real-time factors of the scenario diagrams and cost per added system")
    diagram.add_argument("--robot", default="all", help="an embodiment name or 'all'")
    diagram.add_argument("--hands", choices=["full", "none", "both"], default="both")
    diagram.add_argument("--seconds", type=positive_float, default=3.0, help="simulated seconds per diagram")
    diagram.add_argument("--markdown", action="store_true", help="also print a Markdown table on stderr")
    diagram.add_argument("--json", action="store_true", help="accepted for symmetry; output is always JSON")
    env = sub.add_parser("env", help="Imitation-v0 steps per second, in process and in N workers; MuJoCo peer")
    env.add_argument("--robot", default="h1", choices=embodiment.EMBODIMENT_NAMES)
    env.add_argument("--hands", choices=["full", "none"], default="none")
    env.add_argument("--envs", type=int, default=1, help="worker processes (default 1)")
    env.add_argument("--seconds", type=positive_float, default=10.0, help="wall-clock seconds per measurement")
    env.add_argument("--motions", nargs="+", default=["walk"], help="reference motions (default: walk)")
    env.add_argument("--peer", choices=["mujoco"], help="also run the embodiment's MJCF under this engine")
    env.add_argument("--json", action="store_true", help="print the full report as JSON")
    args = parser.parse_args(argv)
    if args.command == "env":
        return _env(args)
    if args.command == "retarget":
        return _retarget(args)

    names = embodiment.EMBODIMENT_NAMES if args.robot == "all" else (args.robot,)
    if any(n not in embodiment.EMBODIMENT_NAMES for n in names):
        raise UserError(f"unknown robot '{args.robot}'; choose from {', '.join(embodiment.EMBODIMENT_NAMES)} or all")
    if args.seconds > 3600:
        raise UserError("--seconds must be at most 3600")
    if args.command == "diagram":
        return _diagram(args, names)
    check_number(
        args.time_step, "--time-step", low=LIMITS["time_step"]["low"], high=LIMITS["time_step"]["high"], unit="s"
    )
    if args.seconds / args.time_step > MAX_PLANT_STEPS:
        raise UserError(
            f"--seconds {args.seconds:g} at --time-step {args.time_step:g} is more than {MAX_PLANT_STEPS:.0e} steps"
        )
    hands = ("full", "none") if args.hands == "both" else (args.hands,)
    self_collision = not args.no_self_collision
    pin_to_one_core()
    results = []
    for name in names:
        for variant in hands:
            result = standing_realtime_factor(name, variant, args.seconds, args.time_step, self_collision)
            print(json.dumps(result), file=sys.stderr, flush=True)
            results.append(result)
    report = {
        "benchmark": "standing",
        "machine": machine(),
        "settings": {"time_step": args.time_step, "self_collision": self_collision, "cores": 1},
        "results": results,
    }
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
