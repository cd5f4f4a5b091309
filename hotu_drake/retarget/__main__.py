"""Retarget demonstrations onto the UDH and the robots.

    python -m hotu_drake.retarget INPUT [INPUT ...] --robot udh|naviai|h1|bruce|walker|curi|all
                                  --out DIR [--hands full|none] [--skeleton-map FILE] [--marker-set SET]
                                  [--up AXIS] [--allow-implausible] [--report FILE.json] [--html FILE.html]

Writes DIR/<clip>_<robot>.npz for every input and robot (human -> UDH ->
robot). Output paths are checked before any work. A bad input is reported
in one line and skipped; the others are still processed; the exit code is
2 if any input failed. What the readers decided (the up axis, the marker
set, body parts a capture lacks) is said in `note:` lines.
"""

import json
import sys
import time
from pathlib import Path

from hotu_drake import embodiment
from hotu_drake.cli import ArgumentParser, run_cli, show_notes
from hotu_drake.errors import InputError
from hotu_drake.io import check_output_path, write_text_atomic
from hotu_drake.motion.load import load_motion
from hotu_drake.retarget.metrics import report
from hotu_drake.retarget.pipeline import ROBOTS, has_fingers, to_robot, to_udh
from hotu_drake.rotations import signed_axis

TARGETS = ("udh", *ROBOTS)


def _parser() -> ArgumentParser:
    parser = ArgumentParser(
        prog="python -m hotu_drake.retarget",
        description="Retarget BVH, C3D or .npz demonstrations onto the UDH and the robots (human -> UDH -> robot).",
    )
    parser.add_argument("inputs", nargs="+", metavar="INPUT", help="BVH, C3D or .npz clip files")
    parser.add_argument("--robot", required=True, help=f"one of {', '.join(TARGETS)}, or all")
    parser.add_argument("--out", required=True, help="output folder for <clip>_<robot>.npz")
    parser.add_argument("--hands", choices=embodiment.HANDS_VARIANTS, default="full", help="finger joints")
    parser.add_argument("--skeleton-map", help="BVH: a YAML map of landmarks to the file's joints")
    parser.add_argument(
        "--marker-set",
        help="C3D: a built-in marker set (plug_in_gait, anatomical) or a YAML file of one "
        "(default: the built-in set the file's markers fit best)",
    )
    parser.add_argument("--up", help="the file's up axis (x, y or z, optionally signed), if the data misleads")
    parser.add_argument(
        "--allow-implausible",
        action="store_true",
        help="accept a skeleton of inhuman height or a root that jumps (a cut between takes)",
    )
    parser.add_argument("--report", help="write per-clip, per-robot figures as JSON")
    parser.add_argument("--html", help="write a Meshcat replay (source, UDH and robots side by side)")
    return parser


class Progress:
    """A progress bar on standard error (redrawn in place on a terminal)."""

    def __init__(self, total: int):
        self.total, self.done, self.start = total, 0, time.perf_counter()
        self.live = sys.stderr.isatty()

    def step(self, label: str) -> None:
        self.done += 1
        width = 30
        filled = int(width * self.done / max(self.total, 1))
        elapsed = time.perf_counter() - self.start
        line = f"[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} {label[:40]:40s} {elapsed:6.1f}s"
        if self.live:
            print("\r" + line, end="" if self.done < self.total else "\n", file=sys.stderr, flush=True)
        else:
            print(line, file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    robots = list(TARGETS) if args.robot == "all" else [args.robot]
    if any(r not in TARGETS for r in robots):
        raise InputError(f"unknown robot '{args.robot}'; choose from {', '.join(TARGETS)} or all")
    out = check_output_path(args.out, folder=True)
    for extra in (args.report, args.html):
        if extra:
            check_output_path(extra)
    if args.up is not None:
        try:
            signed_axis(args.up)
        except ValueError as error:
            raise InputError(f"--up: {error}") from None
    show_notes()
    progress = Progress(len(args.inputs) * (1 + len([r for r in robots if r != "udh"])))
    figures: dict[str, dict] = {}
    failures: list[str] = []
    replays = []
    for path in args.inputs:
        stem = Path(path).stem
        try:
            source = load_motion(
                path,
                args.skeleton_map,
                marker_set=args.marker_set,
                up=args.up,
                check_plausible=not args.allow_implausible,
            )
        except InputError as error:  # a bad input is skipped; the others are still retargeted
            print(f"error: {error}", file=sys.stderr)
            failures.append(str(error))
            progress.done += 1 + len([r for r in robots if r != "udh"])
            continue
        udh = to_udh(source, args.hands)
        progress.step(f"{stem} -> udh")
        results = {"udh": udh}
        for robot in robots:
            if robot != "udh":
                results[robot] = to_robot(udh.clip, robot, args.hands)
                progress.step(f"{stem} -> {robot}")
        figures[stem] = {}
        for robot in robots:
            stage = results[robot]
            stage.clip.save(out / f"{stem}_{robot}.npz")
            if args.report:
                emb = embodiment.load(robot, "full" if has_fingers(stage.clip) else "none")
                figures[stem][robot] = report(source, stage.clip, emb, stage.seconds)
        replays.append((stem, source, [results["udh"].clip] + [results[r].clip for r in robots if r != "udh"]))
    if args.report:
        write_text_atomic(args.report, json.dumps({"clips": figures, "errors": failures}, indent=2) + "\n")
    if args.html and replays:
        from hotu_drake.retarget.replay import write_replay

        html = Path(args.html)
        for stem, source, clips in replays:
            target = html if len(replays) == 1 else html.with_name(f"{html.stem}_{stem}{html.suffix}")
            write_replay(target, clips, source)
    written = sum(len(v) for v in figures.values()) if args.report else len(replays) * len(robots)
    print(f"retargeted {len(replays)} clip(s) onto {', '.join(robots)}: {written} file(s) in {out}", file=sys.stderr)
    return 2 if failures else 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
