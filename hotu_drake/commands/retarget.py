"""Retarget demonstrations onto the UDH and the robots.

    python -m hotu_drake.retarget INPUT [INPUT ...] --robot udh|naviai|h1|bruce|walker|curi|all
                                  --out DIR [--hands full|none] [--skeleton-map FILE] [--marker-set SET]
                                  [--up AXIS] [--allow-implausible] [--physics] [--report FILE.json]
                                  [--html FILE.html]

Writes DIR/<clip>_<robot>.npz for every input and robot (human -> UDH ->
robot). An INPUT that is no file but a library motion's name (`walk`,
`box_carry_task@7`) retargets that generated demonstration. Every output
path (the clips, the report, the replays) is checked before any work. A
bad input is reported in one line and skipped; the others are still
processed, and the exit code is 2 if any input failed. A run whose every
input failed writes nothing (no report either), and a write that fails
removes the run's other outputs. What the readers decided (the up axis,
the marker set, body parts a capture lacks) is said in `note:` lines. With
`--physics` each robot's clip is also performed in the simulator by the
whole-body controller (`hotu_drake.physical`; CURI on its wheeled base):
DIR/<clip>_<robot>_physical.npz, its figures under "physics" in the
report, and the performed robots beside the others in the replay.
"""

import functools
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
from hotu_drake.retarget.pipeline import ROBOTS, has_fingers, retarget_onto
from hotu_drake.retarget.retargeter import PACES, RetargetOptions
from hotu_drake.rotations import signed_axis

TARGETS = ("udh", *ROBOTS)


def _parser() -> ArgumentParser:
    parser = ArgumentParser(
        prog="python -m hotu_drake.retarget",
        description="Retarget BVH, C3D or .npz demonstrations onto the UDH and the robots (human -> UDH -> robot).",
    )
    parser.add_argument(
        "inputs", nargs="+", metavar="INPUT", help="BVH, C3D or .npz clip files, or library motions by name (walk)"
    )
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
        help="accept a skeleton of inhuman height, a root that jumps (a cut between takes) "
        "or a body that never stands upright (lying down all along)",
    )
    parser.add_argument(
        "--physics",
        action="store_true",
        help="also perform each robot's clip in the simulator under the whole-body controller: "
        "<clip>_<robot>_physical.npz (states, actions, torques, foot forces), and its figures in the report",
    )
    parser.add_argument(
        "--pace",
        choices=PACES,
        default="auto",
        help="the clips' timing: the person's, or dynamic similarity's (a robot with legs half as long "
        "plays its clip 1.41x as fast, as a pendulum half as long swings); auto: dynamic where that is "
        "more than 1.25x the person's (BRUCE), else the person's",
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


def _axis_values(argv: list[str]) -> list[str]:
    """`argv` with `--up -y` read as `--up=-y` (argparse takes a value that
    starts with a dash for an option, and refuses it)."""
    out: list[str] = []
    for word in argv:
        if out and out[-1] == "--up" and len(word) == 2 and word[0] == "-" and word[1] in "xyzXYZ":
            out[-1] = f"--up={word}"
        else:
            out.append(word)
    return out


def _replay_path(html: Path, stem: str, count: int) -> Path:
    """Where the replay of clip `stem` goes: `html` itself for one clip, else `<html>_<stem>.html`."""
    return html if count == 1 else html.with_name(f"{html.stem}_{stem}{html.suffix}")


def _check_outputs(args, robots: list[str]) -> Path:
    """Check every path the run may write before any work (the output folder,
    each clip, the report, the replays: `check_output_path`), so an
    unwritable one fails the run before anything is written. Returns the folder."""
    out = check_output_path(args.out, folder=True)
    stems = list(dict.fromkeys(Path(path).stem for path in args.inputs))
    for stem in stems:
        for robot in robots:
            check_output_path(out / f"{stem}_{robot}.npz")
            if args.physics:
                check_output_path(out / f"{stem}_{robot}_physical.npz")
    if args.report:
        check_output_path(args.report)
    if args.html:
        html = check_output_path(args.html)
        for stem in stems if len(args.inputs) > 1 else ():  # as many replays as inputs that are read
            check_output_path(_replay_path(html, stem, len(args.inputs)))
    return out


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(_axis_values(sys.argv[1:] if argv is None else argv))
    robots = list(TARGETS) if args.robot == "all" else [args.robot]
    if any(r not in TARGETS for r in robots):
        raise InputError(f"unknown robot '{args.robot}'; choose from {', '.join(TARGETS)} or all")
    out = _check_outputs(args, robots)
    if args.up is not None:
        try:
            signed_axis(args.up)
        except ValueError as error:
            raise InputError(f"--up: {error}") from None
    show_notes()
    physical = len(robots) if args.physics else 0
    # The UDH's own clip where asked for, and in every replay beside the robots.
    solved = [*(["udh"] if "udh" in robots or args.html else []), *(r for r in robots if r != "udh")]
    progress = Progress(len(args.inputs) * (len(solved) + physical))
    figures: dict[str, dict] = {}
    failures: list[str] = []
    replays = []
    for path in args.inputs:
        stem = Path(path).stem
        try:
            source = _source(path, args)
        except InputError as error:  # a bad input is skipped; the others are still retargeted
            print(f"error: {error}", file=sys.stderr)
            failures.append(str(error))
            progress.done += len(solved) + physical
            continue
        done = functools.partial(_step_done, progress, stem)
        results = retarget_onto(source, solved, args.hands, RetargetOptions(pace=args.pace), done=done)
        performed = {}
        if args.physics:
            from hotu_drake.physical import perform

            for robot in robots:
                clip = results[robot].clip
                performed[robot] = perform(clip, "full" if has_fingers(clip) else "none")
                progress.step(f"{stem} -> {robot} performed")
        if args.report:
            figures[stem] = {}
            for robot in robots:
                stage = results[robot]
                emb = embodiment.load(robot, "full" if has_fingers(stage.clip) else "none")
                figures[stem][robot] = report(source, stage.clip, emb, stage.seconds, stage.margins)
                if robot in performed:
                    figures[stem][robot]["physics"] = performed[robot].report
        replays.append((stem, source, results, performed))
    if replays:  # a run whose every input was refused writes nothing, not even the report of its errors
        _write(args, out, robots, figures, failures, replays)
    for stem, _, _, performed in replays:  # the falls, each in a line, once the progress bar is done
        for robot, performance in performed.items():
            if performance.report["fell"]:
                print(f"{stem} -> {robot}: {_outcome(performance.report)}", file=sys.stderr)
    written = len(replays) * len(robots) + sum(len(performed) for *_, performed in replays)
    print(f"retargeted {len(replays)} clip(s) onto {', '.join(robots)}: {written} file(s) in {out}", file=sys.stderr)
    return 2 if failures else 0


def _outcome(report: dict) -> str:
    """A performance's fall in a few words: when, and when and which way it
    lost its balance."""
    text = f"fell at {report['fell_at_s']:.2f} s"
    lost = report.get("lost_balance")
    if lost and lost["outside_m"] is not None:
        sides = [foot.removesuffix("_foot") for foot in lost["standing_on"]]
        soles = f"its {sides[0]} foot" if len(sides) == 1 else "its feet"
        way = {"ahead": "ahead of", "behind": "behind", "left": "to the left of", "right": "to the right of"}
        where = f"{lost['outside_m']:.2f} m {way[lost['toward']]} {soles}"
        text += f" (lost its balance at {lost['at_s']:.2f} s: {where})"
    elif lost:
        text += f" (lost its balance at {lost['at_s']:.2f} s, in the air)"
    return text


def _source(path: str, args):
    """The human demonstration an INPUT names: a motion file, or (no such
    file) a motion of the generated library by name (`walk`, `box_carry_task@7`)."""
    from hotu_drake.motion.library import generate, is_library_motion

    if not Path(path).exists() and is_library_motion(path):
        return generate(path)
    return load_motion(
        path, args.skeleton_map, marker_set=args.marker_set, up=args.up, check_plausible=not args.allow_implausible
    )


def _step_done(progress: Progress, stem: str, robot: str) -> None:
    progress.step(f"{stem} -> {robot}")


def _write(args, out: Path, robots: list[str], figures: dict, failures: list[str], replays: list) -> None:
    """Write the clips, the report and the replays, all or none: a write that
    fails (a full disk, an error in a replay) removes what this run wrote."""
    written: list[Path] = []
    try:
        for stem, _, results, performed in replays:
            for robot in robots:
                written.append(results[robot].clip.save(out / f"{stem}_{robot}.npz"))
            for robot, performance in performed.items():
                written.append(performance.save(out / f"{stem}_{robot}_physical.npz"))
        if args.report:
            report_json = json.dumps({"clips": figures, "errors": failures}, indent=2) + "\n"
            written.append(write_text_atomic(args.report, report_json))
        if args.html:
            from hotu_drake.retarget.replay import write_replay

            for stem, source, results, performed in replays:  # the UDH beside the robots, whether asked for or not
                clips = [results["udh"].clip] + [results[robot].clip for robot in robots if robot != "udh"]
                clips += [performance.clip for performance in performed.values()]  # and as performed
                target = _replay_path(Path(args.html), stem, len(replays))
                write_replay(target, clips, source)
                written.append(target)
    except BaseException:
        for path in written:
            path.unlink(missing_ok=True)
        raise


if __name__ == "__main__":
    sys.exit(run_cli(main))
