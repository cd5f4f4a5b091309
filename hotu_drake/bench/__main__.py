"""Benchmarks; each prints JSON.

python -m hotu_drake.bench standing [--robot NAME|all] [--hands full|none|both]
                                    [--seconds S] [--time-step DT] [--no-self-collision]
python -m hotu_drake.bench retarget [--input FILE] [--hands full|none|both] [--seconds S]
                                    [--peer mink [--pairs N]] [--per-frame]
python -m hotu_drake.bench diagram  [--robot NAME|all] [--hands full|none|both] [--seconds S] [--markdown]
python -m hotu_drake.bench env      [--robot NAME] [--hands full|none] [--envs N] [--seconds S]
                                    [--motions M ...] [--backend local|ray] [--fidelity] [--peer mujoco] [--json]
python -m hotu_drake.bench fidelity [--robot NAME|all] [--rates HZ ...] [--thresholds T ...]
                                    [--reference-rate HZ] [--markdown]
python -m hotu_drake.bench train    [--robot NAME] [--motions M ...] [--workers N ...] [--iterations K]
                                    [--algo dail|amp|ase|pmp]
python -m hotu_drake.bench readers  [--input FILE ...] [--repeats N]
python -m hotu_drake.bench clips    [--motions M ...] [--input FILE ...] [--robots NAME ...] [--markdown]
python -m hotu_drake.bench teacher  [--robot NAME] [--seconds S] [--repeats N] [--queries N] [--hands H] [--motion M]
python -m hotu_drake.bench pushes   [--robots NAME ...] [--momenta KG_M_S ...] [--markdown]
python -m hotu_drake.bench grasps   [--grasps N] [--first SEED] [--time-steps DT ...]
python -m hotu_drake.bench performs [--robots NAME ...] [--motions M ...] [--input FILE ...] [--seeds N]
                                    [--starts N] [--hands full|none] [--markdown]
"""

import json
import sys
from pathlib import Path

from hotu_drake import embodiment
from hotu_drake.bench.clips import LEGGED, clip_rows, markdown, source
from hotu_drake.bench.clips import LIBRARY as LIBRARY_CLIPS
from hotu_drake.bench.standing import machine, one_core, pin_to_one_core, standing_realtime_factor
from hotu_drake.cli import ArgumentParser, positive_float, run_cli
from hotu_drake.errors import InputError, check_choice, check_number
from hotu_drake.retarget.retargeter import PACES
from hotu_drake.scenario import DEFAULT_TIME_STEP, LIMITS, MAX_PLANT_STEPS, default_plant_config

BASELINE_PLANT = (1.0 / 180.0, 1.0)  # hotu_drake 0.2's environments: 1/180 s, Drake's default near-rigid threshold


def bench_env_settings() -> dict:
    config = default_plant_config()
    return {"time_step": config.time_step, "near_rigid_threshold": config.sap_near_rigid_threshold}


def _retarget(args) -> int:
    from hotu_drake.bench import mink_peer
    from hotu_drake.bench.retarget import end_to_end_frames_per_second, retarget_throughput, source_clip
    from hotu_drake.motion.clip import ClipFormatError

    check_number(args.pairs, "--pairs", low=0, high=20, integer=True)
    try:
        source = source_clip(args.input, args.seconds)
    except ClipFormatError as error:
        raise InputError(str(error)) from None
    peer = args.peer == "mink"
    if peer and not mink_peer.mink_available():
        print(f"bench retarget: --peer mink skipped: {mink_peer.SKIP_MESSAGE}", file=sys.stderr, flush=True)
        peer = False
    if peer and source.embodiment != "human":
        print("bench retarget: --peer mink skipped: it retargets a human demonstration", file=sys.stderr, flush=True)
        peer = False
    pin_to_one_core()
    variants = ("full", "none") if args.hands == "both" else (args.hands,)
    results = []
    for hands in variants:
        for row in retarget_throughput(source, hands):
            print(json.dumps(row), file=sys.stderr, flush=True)
            results.append(row)
    report = {
        "benchmark": "retarget",
        "machine": machine(),
        "source": {"clip": source.source, "frames": source.num_frames, "fps": source.fps},
        "results": results,
    }
    if args.per_frame:  # today's streaming solve, one frame at a time, in the same run
        from hotu_drake.retarget.retargeter import RetargetOptions

        per_frame = RetargetOptions(whole_clip=False, calibrate=False)
        report["per_frame"], report["speedup_over_per_frame"] = [], {}
        for hands in variants:
            for row in retarget_throughput(source, hands, options=per_frame):
                print(json.dumps({"per_frame": True, **row}), file=sys.stderr, flush=True)
                report["per_frame"].append(row)
        ours = end_to_end_frames_per_second(results)
        for row in report["per_frame"]:
            mine = ours[row["robot"], row["hands"]]
            report["speedup_over_per_frame"].setdefault(row["robot"], {})[row["hands"]] = round(
                mine / row["end_to_end_frames_per_second"], 3
            )
    if peer:  # the same clip straight onto each robot; ours goes human -> UDH -> robot
        ours = end_to_end_frames_per_second(results)
        report["peer"], report["speedup"] = [], {}
        for row in results:
            peer_row = mink_peer.mink_throughput(source, row["robot"], row["hands"])
            fps = peer_row["ours_end_to_end_frames_per_second"] = ours[row["robot"], row["hands"]]
            peer_row["speedup"] = None if fps is None else round(fps / peer_row["frames_per_second"], 3)
            print(json.dumps(peer_row), file=sys.stderr, flush=True)
            report["peer"].append(peer_row)
            report["speedup"].setdefault(row["robot"], {})[row["hands"]] = peer_row["speedup"]
        if args.pairs:  # alternate ours and the peer per robot, so a slow spell of the machine hits both
            report["pairs"] = _alternating_pairs(source, variants, args.pairs)
    print(json.dumps(report, indent=2))
    return 0


def _alternating_pairs(source, variants: tuple[str, ...], count: int) -> dict:
    """Per robot and hands: `count` runs of ours (human -> UDH -> robot, as
    `pipeline.retarget_onto` does it) each followed by one of the peer;
    frames/s of each and the median ratio. Model set-up is not timed on
    either side (`Stage.setup_seconds`: ours, reported apart)."""
    import statistics

    from hotu_drake.bench import mink_peer
    from hotu_drake.retarget.pipeline import ROBOTS, retarget_onto

    out: dict = {}
    for hands in variants:
        for robot in ("udh", *ROBOTS):
            ours, peer, setup = [], [], []
            for _ in range(count):
                stage = retarget_onto(source, [robot], hands)[robot]
                ours.append(round(source.num_frames / stage.total_seconds, 1))
                setup.append(round(stage.total_setup_seconds, 4))
                peer.append(mink_peer.mink_throughput(source, robot, hands)["frames_per_second"])
            ratios = [a / b for a, b in zip(ours, peer)]
            row = {"ours": ours, "peer": peer, "median_speedup": round(statistics.median(ratios), 3)}
            row["setup_seconds"] = setup
            print(json.dumps({"pairs": robot, "hands": hands, **row}), file=sys.stderr, flush=True)
            out.setdefault(robot, {})[hands] = row
    return out


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
        "settings": {**bench_env_settings(), "control_rate": 30.0, "seconds": args.seconds, "cores": 1},
        "results": results,
    }
    print(json.dumps(report, indent=2))
    if args.markdown:
        print("\n".join(summary(results)), file=sys.stderr)
    return 0


def _median_run(runs: list[dict]) -> dict:
    """The run with the median steps per second."""
    return sorted(runs, key=lambda r: r["env_steps_per_second"])[len(runs) // 2]


def _env(args) -> int:
    from hotu_drake.bench import env as bench_env
    from hotu_drake.retarget.references import reference_clips

    if args.envs < 1 or args.envs > 64:
        raise InputError("--envs must be between 1 and 64")
    if args.seconds > 3600:
        raise InputError("--seconds must be at most 3600")
    check_number(args.rounds, "--rounds", low=1, high=20, integer=True)
    emb = embodiment.load(args.robot, args.hands)
    reference_clips(emb, args.motions)  # retarget (or load from the cache) once, before timing
    report: dict = {"benchmark": "env", "machine": machine(), "robot": args.robot, "hands": args.hands}
    report["settings"] = {
        **bench_env.plant_settings(None),
        "control_rate": 30.0,
        "seconds": args.seconds,
        "motions": args.motions,
        "backend": args.backend,
    }
    counts = sorted({1, args.envs})
    rounds: dict[str, list[dict]] = {}

    def measure(key: str, run) -> None:
        rounds.setdefault(key, []).append(run())
        print(json.dumps({"round": len(rounds[key]), key: rounds[key][-1]}), file=sys.stderr, flush=True)

    for _ in range(args.rounds):  # alternating, so a slow hour of the machine slows every configuration alike
        for n in counts:
            measure(
                f"workers_{n}",
                lambda n=n: bench_env.vectorised(
                    args.robot, args.hands, args.seconds, args.motions, n, backend=args.backend
                ),
            )
        with one_core():
            measure("in_process", lambda: bench_env.in_process(args.robot, args.hands, args.seconds, args.motions))
            measure(
                "baseline_0_2",
                lambda: bench_env.in_process(args.robot, args.hands, args.seconds, args.motions, plant=BASELINE_PLANT),
            )
    best = {key: _median_run(runs) for key, runs in rounds.items()}
    report["rounds"] = args.rounds
    report["vectorised"] = best[f"workers_{counts[-1]}"]
    if len(counts) > 1:
        report["one_worker"] = best["workers_1"]
        report["workers_speedup"] = round(
            report["vectorised"]["env_steps_per_second"] / report["one_worker"]["env_steps_per_second"], 2
        )
    report["in_process"], report["baseline_0_2"] = best["in_process"], best["baseline_0_2"]
    report["speedup_over_0_2"] = round(
        report["in_process"]["env_steps_per_second"] / report["baseline_0_2"]["env_steps_per_second"], 2
    )
    report["all_rounds"] = {key: [r["env_steps_per_second"] for r in runs] for key, runs in rounds.items()}
    report["env_steps_per_second"] = report["vectorised"]["env_steps_per_second"]
    report["sim_seconds_per_wall_second"] = report["vectorised"]["sim_seconds_per_wall_second"]
    report["ms_per_step"] = report["in_process"]["ms_per_step"]
    if args.fidelity or args.peer:
        report["in_process"]["trajectory_error_mm"] = bench_env.drake_fidelity(args.robot, args.hands)
    if args.peer == "mujoco":
        try:
            with one_core():
                peer = bench_env.mujoco_peer(args.robot, args.hands, args.seconds)
        except RuntimeError as error:
            raise InputError(str(error)) from None
        report["peer"] = peer
        report["drake_to_mujoco_ratio"] = round(
            report["in_process"]["env_steps_per_second"] / peer["env_steps_per_second"], 3
        )
    report["peak_memory_mb"] = bench_env.peak_memory_mb()
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        keys = (
            "env_steps_per_second",
            "sim_seconds_per_wall_second",
            "ms_per_step",
            "speedup_over_0_2",
            "workers_speedup",
        )
        for key in (*keys, "drake_to_mujoco_ratio"):
            if key in report:
                print(f"{key:28s} {report[key]}")
    return 0


def _fidelity(args) -> int:
    from hotu_drake.bench import fidelity

    robots = fidelity.legged_robots() if args.robot == "all" else (args.robot,)
    if any(r not in fidelity.legged_robots() for r in robots):
        raise InputError(
            f"--robot: {args.robot!r} is not a legged robot ({', '.join(fidelity.legged_robots())}) or all"
        )
    for rate in [*args.rates, args.reference_rate]:
        check_number(1.0 / rate, "--rates", low=LIMITS["time_step"]["low"], high=LIMITS["time_step"]["high"], unit="s")
    for threshold in args.thresholds:
        check_number(threshold, "--thresholds", **LIMITS["sap_near_rigid_threshold"])
    settings = [fidelity.Setting(1.0 / rate, t) for t in args.thresholds for rate in args.rates]
    reference = fidelity.Setting(1.0 / args.reference_rate, min(args.thresholds))
    pin_to_one_core()
    rows = fidelity.fidelity(robots, settings, reference, report=lambda row: print(json.dumps(row), file=sys.stderr))
    report = {
        "benchmark": "fidelity",
        "machine": machine(),
        "reference": {"time_step": reference.time_step, "near_rigid_threshold": reference.near_rigid_threshold},
        "error_bound_mm": fidelity.ERROR_BOUND_MM,
        "results": rows,
    }
    print(json.dumps(report, indent=2))
    if args.markdown:
        print("\n".join(fidelity.summary(rows)), file=sys.stderr)
    return 0


def _train(args) -> int:
    from hotu_drake.bench.train import train_throughput
    from hotu_drake.learning.config import ALGORITHMS

    if args.algo not in ALGORITHMS:
        raise InputError(f"--algo {args.algo!r}: choose from {', '.join(ALGORITHMS)}")
    check_number(args.iterations, "--iterations", low=1, high=1000, integer=True)
    for count in args.workers:
        check_number(count, "--workers", low=1, high=64, integer=True)
    results = []
    for count in args.workers:
        row = train_throughput(args.robot, args.motions, count, args.iterations, algo=args.algo)
        print(json.dumps(row), file=sys.stderr, flush=True)
        results.append(row)
    one = next((r for r in results if r["workers"] == 1), None)
    if one is not None:
        for row in results:
            row["speedup_over_one_worker"] = round(row["samples_per_second"] / one["samples_per_second"], 2)
    print(json.dumps({"benchmark": "train", "machine": machine(), "results": results}, indent=2))
    return 0


def _readers(args) -> int:
    from hotu_drake.bench.readers import library_seconds, read_seconds

    check_number(args.repeats, "--repeats", low=1, high=100, integer=True)
    for path in args.input:
        if not Path(path).is_file():
            raise InputError(f"{path}: no such file")
    pin_to_one_core()
    library = library_seconds()
    print(json.dumps(library), file=sys.stderr, flush=True)
    files = [read_seconds(path, args.repeats) for path in args.input]
    print(json.dumps({"benchmark": "readers", "machine": machine(), "library": library, "files": files}, indent=2))
    return 0


def _clips(args) -> int:
    from hotu_drake.motion.library import is_library_motion

    for name in args.motions:
        if not is_library_motion(name):
            raise InputError(f"--motions: {name!r} is not a library motion")
    for path in args.input:
        if not Path(path).is_file():
            raise InputError(f"{path}: no such file")
    for robot in args.robots:
        if robot not in LEGGED:
            raise InputError(f"--robots: {robot!r} is not a legged embodiment ({', '.join(LEGGED)})")
    pin_to_one_core()
    rows = []
    for name in [*args.motions, *args.input]:
        for row in clip_rows(name, source(name), tuple(args.robots), args.pace):
            print(json.dumps(row), file=sys.stderr, flush=True)
            rows.append(row)
    if args.markdown:
        print(markdown(rows), file=sys.stderr, flush=True)
    print(json.dumps({"benchmark": "clips", "machine": machine(), "rows": rows}, indent=2))
    return 0


def _performs(args) -> int:
    from hotu_drake.bench.performs import looped_walk_row, perform_row
    from hotu_drake.bench.performs import markdown as performs_markdown
    from hotu_drake.motion.library import MOTIONS
    from hotu_drake.motion.load import load_motion
    from hotu_drake.retarget.pipeline import library_clip, retarget_onto
    from hotu_drake.retarget.retargeter import RetargetOptions

    for robot in args.robots:
        check_choice(robot, "--robots", embodiment.EMBODIMENT_NAMES)
    for motion in args.motions:
        check_choice(motion, "--motions", MOTIONS)
    check_number(args.seeds, "--seeds", low=0, high=100, integer=True)
    check_number(args.starts, "--starts", low=1, high=30, integer=True)
    options = RetargetOptions(pace=args.pace)
    captures = {
        Path(path).stem: retarget_onto(load_motion(path), args.robots, args.hands, options) for path in args.input
    }
    pin_to_one_core()
    rows = []
    for robot in args.robots:
        clips = {motion: library_clip(motion, robot, args.hands, args.pace) for motion in args.motions}
        clips |= {stem: stages[robot].clip for stem, stages in captures.items()}
        for motion, clip in clips.items():
            rows.append(perform_row(robot, motion, clip, args.starts))
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
        if args.seeds and embodiment.load(robot, "none").floating_base:
            walk = None if args.pace == "auto" else library_clip("walk", robot, args.hands, args.pace)
            rows.append(looped_walk_row(robot, args.seeds, walk, args.hands))
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    if args.markdown:
        print(performs_markdown(rows, args.robots), file=sys.stderr, flush=True)
    print(json.dumps({"benchmark": "performs", "machine": machine(), "rows": rows}, indent=2))
    return 0


def _pushes(args) -> int:
    from hotu_drake.bench.pushes import push_table
    from hotu_drake.scenario import shipped_scenarios

    for robot in args.robots:
        if f"whole_body_walk_{robot}" not in shipped_scenarios():
            raise InputError(f"--robots: {robot} has no shipped whole_body_walk_{robot} scenario")
    for momentum in args.momenta:
        check_number(momentum, "--momenta", low=0.0, high=200.0, unit="kg m/s")
    rows = push_table(args.robots, args.momenta)
    if args.markdown:
        lines = ["| robot | motion | " + " | ".join(f"{m:g} kg m/s" if m else "no cube" for m in args.momenta) + " |"]
        lines.append("|---|---|" + "---|" * len(args.momenta))
        for robot in args.robots:
            for motion in ("standing", "walking"):
                cells = [f"{r['fell']}/{r['trials']}" for r in rows if r["robot"] == robot and r["motion"] == motion]
                lines.append(f"| {robot} | {motion} | " + " | ".join(cells) + " |")
        print("\n".join(lines), file=sys.stderr, flush=True)
    print(json.dumps({"benchmark": "pushes", "machine": machine(), "rows": rows}, indent=2))
    return 0


def _teacher(args) -> int:
    from hotu_drake.bench.teacher import label_cost, walking_cost
    from hotu_drake.scenario import shipped_scenarios

    if f"whole_body_walk_{args.robot}" not in shipped_scenarios():
        walking = sorted(n[len("whole_body_walk_") :] for n in shipped_scenarios() if n.startswith("whole_body_walk_"))
        raise InputError(f"--robot: no whole_body_walk_{args.robot} scenario (shipped: {', '.join(walking)})")
    check_number(args.seconds, "--seconds", low=0.1, high=600.0, unit="s")
    check_number(args.queries, "--queries", low=1, high=10000, integer=True)
    check_number(args.repeats, "--repeats", low=1, high=100, integer=True)
    check_choice(args.hands, "--hands", embodiment.HANDS_VARIANTS)
    pin_to_one_core()
    walking = walking_cost(args.robot, args.seconds, args.repeats)
    print(json.dumps(walking), file=sys.stderr, flush=True)
    labels = label_cost(args.robot, args.queries, args.hands, args.motion)
    print(json.dumps(labels), file=sys.stderr, flush=True)
    print(json.dumps({"benchmark": "teacher", "machine": machine(), "walking": walking, "labels": labels}, indent=2))
    return 0


def _grasps(args) -> int:
    from hotu_drake.bench.grasps import grasp_table

    check_number(args.grasps, "--grasps", low=1, high=1000, integer=True)
    check_number(args.first, "--first", low=0, high=10**9, integer=True)
    for step in args.time_steps:
        check_number(step, "--time-steps", low=1e-4, high=0.05, unit="s")
    pin_to_one_core()
    tables = []
    for step in args.time_steps:
        tables.append(grasp_table(list(range(args.first, args.first + args.grasps)), step))
        table = tables[-1]
        print(
            f"step {step:g} s: held {table['held']}/{table['grasps']} {table['per_object']}",
            file=sys.stderr,
            flush=True,
        )
    print(json.dumps({"benchmark": "grasps", "machine": machine(), "tables": tables}, indent=2))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.bench", description="Benchmarks that print JSON.")
    sub = parser.add_subparsers(dest="command", required=True)
    standing = sub.add_parser("standing", help="real-time factor of each embodiment standing after a 0.1 m drop")
    standing.add_argument("--robot", default="all", help="an embodiment name or 'all'")
    standing.add_argument("--hands", choices=["full", "none", "both"], default="both")
    standing.add_argument("--seconds", type=positive_float, default=5.0, help="simulated seconds per run")
    standing.add_argument(
        "--time-step", type=positive_float, default=DEFAULT_TIME_STEP, help="plant step (s, default 1/60), at most 0.05"
    )
    standing.add_argument("--no-self-collision", action="store_true")
    standing.add_argument("--json", action="store_true", help="accepted for symmetry; output is always JSON")
    retarget = sub.add_parser("retarget", help="retargeting frames per second per robot (human -> UDH -> robot)")
    retarget.add_argument("--input", help="a BVH, C3D or .npz demonstration (default: the generated walk at 120 fps)")
    retarget.add_argument("--hands", choices=["full", "none", "both"], default="both")
    retarget.add_argument("--seconds", type=positive_float, help="use only the first S seconds")
    retarget.add_argument(
        "--peer", choices=["mink"], help="also run mink's differential IK, set up as GMR does (the mink extra)"
    )
    retarget.add_argument(
        "--pairs",
        type=int,
        default=0,
        metavar="N",
        help="with --peer: also time N alternating pairs (ours, then the peer) per robot; the median ratio",
    )
    retarget.add_argument(
        "--per-frame", action="store_true", help="also time the per-frame solve (the stream's), uncalibrated, as before"
    )
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
    env.add_argument("--backend", choices=["local", "ray"], default="local", help="worker processes or Ray actors")
    env.add_argument("--fidelity", action="store_true", help="also measure the trajectory error against 1/1440 s")
    env.add_argument("--rounds", type=int, default=3, help="alternating rounds; the median of each is reported")
    env.add_argument("--json", action="store_true", help="print the full report as JSON")
    fid = sub.add_parser("fidelity", help="stand, squat, push and drop at candidate steps against a fine reference")
    fid.add_argument("--robot", default="all", help="a legged robot or 'all'")
    fid.add_argument("--rates", type=positive_float, nargs="+", default=[180, 90, 60, 30], help="plant rates (Hz)")
    fid.add_argument("--thresholds", type=float, nargs="+", default=[1.0, 0.1], help="SAP near-rigid thresholds")
    fid.add_argument("--reference-rate", type=positive_float, default=1440.0, help="the reference's plant rate (Hz)")
    fid.add_argument("--markdown", action="store_true", help="also print a Markdown table on stderr")
    fid.add_argument("--json", action="store_true", help="accepted for symmetry; output is always JSON")
    train = sub.add_parser("train", help="training iterations per second with 1 and N workers; the learner's share")
    train.add_argument("--robot", default="h1", choices=embodiment.EMBODIMENT_NAMES)
    train.add_argument("--motions", nargs="+", default=["wave", "boxing", "handshake"])
    train.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker counts to measure (default 1 2)")
    train.add_argument("--iterations", type=int, default=8, help="measured iterations per worker count (default 8)")
    train.add_argument("--algo", default="dail", help="dail | amp | ase | pmp")
    readers = sub.add_parser("readers", help="seconds to generate the motion library and to read motion files")
    readers.add_argument("--input", nargs="*", default=[], help="motion files to read (BVH, C3D, CSV, .npz)")
    readers.add_argument("--repeats", type=int, default=3, help="reads per file; the median is reported (default 3)")
    clips = sub.add_parser("clips", help="stance, legs apart, balance and torques of retargeted clips per robot")
    clips.add_argument("--motions", nargs="*", default=list(LIBRARY_CLIPS), help="library motions (issue 27's)")
    clips.add_argument("--input", nargs="*", default=[], help="motion files (BVH, C3D, .npz) to retarget too")
    clips.add_argument("--robots", nargs="+", default=list(LEGGED), help="legged embodiments (default: all of them)")
    clips.add_argument("--pace", choices=PACES, default="auto", help="the clips' timing (`RetargetOptions.pace`)")
    clips.add_argument("--markdown", action="store_true", help="also print a Markdown table on stderr")
    teacher = sub.add_parser("teacher", help="the whole-body controller walking a robot, and one label query's cost")
    teacher.add_argument("--robot", default="h1", help="a robot with a shipped whole_body_walk_<robot> scenario")
    teacher.add_argument("--seconds", type=float, default=10.0, help="simulated seconds of walking")
    teacher.add_argument("--repeats", type=int, default=5, help="walks timed (the middle one reported)")
    teacher.add_argument("--queries", type=int, default=100, help="teacher_action queries timed in Imitation-v0")
    teacher.add_argument("--hands", default="none", help="the label queries' hands (full: the fingerless teacher)")
    teacher.add_argument("--motion", default="walk", help="the label queries' library motion (e.g. hand_grasp@0)")
    grasps = sub.add_parser("grasps", help="the whole-body controller taking the grasp set's objects off a table")
    grasps.add_argument("--grasps", type=int, default=20, help="grasps of the set (hand_grasp@<seed>)")
    grasps.add_argument("--first", type=int, default=0, help="the first grasp's seed")
    grasps.add_argument(
        "--time-steps", type=float, nargs="+", default=[1.0 / 240.0], help="plant steps (s), one table each"
    )
    pushes = sub.add_parser("pushes", help="cubes thrown at robots standing and walking under the controller")
    pushes.add_argument("--robots", nargs="+", default=["udh", "naviai", "h1", "walker", "bruce"])
    pushes.add_argument(
        "--momenta", type=float, nargs="+", default=[0.0, 2.0, 5.0, 10.0, 20.0], help="kg m/s (0: no cube)"
    )
    pushes.add_argument("--markdown", action="store_true", help="also print a Markdown table (falls/trials) on stderr")
    performs = sub.add_parser("performs", help="each robot performing each motion under the whole-body controller")
    performs.add_argument("--robots", nargs="+", default=["udh", "naviai", "h1", "walker", "bruce", "curi"])
    performs.add_argument(
        "--motions",
        nargs="+",
        default=[
            "walk",
            "squat",
            "wave",
            "boxing",
            "handshake",
            "leg_stretch",
            "box_carry",
            "walk_fast",
            "walk_turn_left",
            "walk_turn_right",
            "turn_in_place_left",
            "turn_in_place_right",
            "sidestep_left",
            "sidestep_right",
            "walk_backward",
            "start_stop",
        ],
    )
    performs.add_argument("--input", nargs="*", default=[], help="captures (BVH, C3D) retargeted and performed too")
    performs.add_argument("--seeds", type=int, default=6, help="seeds of the 10 s looped walk (0: none)")
    performs.add_argument(
        "--starts", type=int, default=1, help="perform each motion from its first N frames (the table: up of N)"
    )
    performs.add_argument("--pace", choices=PACES, default="auto", help="the clips' timing (`RetargetOptions.pace`)")
    performs.add_argument(
        "--hands", choices=embodiment.HANDS_VARIANTS, default="none", help="the robots' hands (`retarget --hands`)"
    )
    performs.add_argument("--markdown", action="store_true", help="also print a Markdown table on stderr")
    args = parser.parse_args(argv)
    if args.command == "performs":
        return _performs(args)
    if args.command == "pushes":
        return _pushes(args)
    if args.command == "grasps":
        return _grasps(args)
    if args.command == "teacher":
        return _teacher(args)
    if args.command == "clips":
        return _clips(args)
    if args.command == "readers":
        return _readers(args)
    if args.command == "train":
        return _train(args)
    if args.command == "fidelity":
        return _fidelity(args)
    if args.command == "env":
        return _env(args)
    if args.command == "retarget":
        return _retarget(args)

    names = embodiment.EMBODIMENT_NAMES if args.robot == "all" else (args.robot,)
    if any(n not in embodiment.EMBODIMENT_NAMES for n in names):
        raise InputError(f"unknown robot '{args.robot}'; choose from {', '.join(embodiment.EMBODIMENT_NAMES)} or all")
    if args.seconds > 3600:
        raise InputError("--seconds must be at most 3600")
    if args.command == "diagram":
        return _diagram(args, names)
    check_number(
        args.time_step, "--time-step", low=LIMITS["time_step"]["low"], high=LIMITS["time_step"]["high"], unit="s"
    )
    if args.seconds / args.time_step > MAX_PLANT_STEPS:
        raise InputError(
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
        "settings": {**bench_env_settings(), "time_step": args.time_step, "self_collision": self_collision, "cores": 1},
        "results": results,
    }
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
