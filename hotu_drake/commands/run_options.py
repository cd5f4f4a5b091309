"""What every training command line shares: its options, their checks, and
the settings a resumed run keeps (`train pretrain`, `skill`, `finetune`)."""

from __future__ import annotations

import functools
import json
import sys
from collections.abc import Callable
from pathlib import Path

from hotu_drake.embodiment import EMBODIMENT_NAMES, HANDS_VARIANTS
from hotu_drake.errors import InputError, check_choice, check_number
from hotu_drake.learning.checkpoint import CheckpointError
from hotu_drake.learning.low_level import LowLevelController
from hotu_drake.learning.trainer import RunFolder


def add_run_arguments(parser, preset_help: str, eval_episodes: int) -> None:
    """The options every training command takes."""
    parser.add_argument("--steps", type=int, required=True, help="samples (control steps) to train for in total")
    parser.add_argument(
        "--workers", type=int, help="environment worker processes (default 2; on --resume, the run's own number)"
    )
    parser.add_argument(
        "--ray", metavar="ADDRESS", help="run the workers as Ray actors on this cluster ('auto', host:port)"
    )
    parser.add_argument("--out", required=True, help="the run folder (runs/NAME)")
    parser.add_argument("--config", help=f"a YAML file overriding {preset_help}")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--resume", action="store_true", help="continue the run in --out from its last checkpoint")
    parser.add_argument(
        "--checkpoint-every", type=int, help="iterations between checkpoints (default: ~3 minutes' worth)"
    )
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=eval_episodes,
        help=f"evaluation episodes at the end (default {eval_episodes}; 0: none)",
    )


def check_run_arguments(args) -> RunFolder:
    """The numbers every training command takes, checked; the run folder."""
    check_number(args.steps, "--steps", low=1, high=10**10, integer=True)
    if args.workers is not None:
        check_number(args.workers, "--workers", low=1, high=64, integer=True)
    check_number(args.seed, "--seed", low=0, high=2**31 - 1, integer=True)
    check_number(args.eval_episodes, "--eval-episodes", low=0, high=100_000, integer=True)
    if args.checkpoint_every is not None:
        check_number(args.checkpoint_every, "--checkpoint-every", low=1, high=10**6, integer=True)
    return RunFolder(args.out)


def resumed_settings(args, folder: RunFolder, names: tuple[str, ...], command: str | None = None) -> tuple[dict, dict]:
    """The settings and last checkpoint of the run to resume in `folder`;
    `InputError` if it is not a `command` run, or if an argument in `names`
    (or `--motions`, `--llc`, `--config`) asks for something else than the
    run has. `--workers` may change."""
    folder.check_resumable()
    settings, checkpoint = folder.settings(), folder.checkpoint()
    if command is not None and settings.get("command") != command:
        raise InputError(
            f"{folder.path}: not a {command} run (resume it with train {settings.get('command', 'pretrain')})"
        )
    for name in names:
        given = getattr(args, name)
        if given is not None and given != settings[name]:
            raise InputError(f"--{name} {given!r}: the run in {folder.path} has {settings[name]!r}")
    if getattr(args, "motions", None) is not None and motion_list(args.motions) != settings["motions"]:
        raise InputError(f"--motions: the run in {folder.path} has {','.join(settings['motions'])}")
    if getattr(args, "llc", None) is not None and str(Path(args.llc).resolve()) != settings["llc"]:
        raise InputError(f"--llc: the run in {folder.path} drives {settings['llc']}")
    if args.config:
        raise InputError(f"--config: the run in {folder.path} keeps its configuration (config.yaml)")
    settings["workers"] = args.workers or settings.get("workers", 2)
    return settings, checkpoint


def motion_list(text: str) -> list[str]:
    """`--motions`: library names as given, clip paths made absolute (worker processes may start elsewhere)."""
    motions = [m.strip() for m in text.split(",") if m.strip()]
    if not motions:
        raise InputError("--motions: give at least one motion")
    return [str(Path(m).resolve()) if m.endswith(".npz") else m for m in motions]


@functools.lru_cache(maxsize=4)
def load_controller(path: str, option: str = "--llc") -> LowLevelController:
    """The frozen behavior controller `option` names, or the error that names it (read once per path)."""
    try:
        return LowLevelController.load(Path(path))
    except CheckpointError as error:
        raise InputError(f"{option}: {error}") from None


def controller_robot(args, wanted: str, who: str) -> tuple[str, str]:
    """The robot and hands of `--llc` (a `wanted` controller, which `who`
    drives), as `--robot` and `--hands` may also say; `InputError` otherwise."""
    controller = load_controller(args.llc)
    if controller.config.algo != wanted:
        raise InputError(f"--llc {args.llc}: a {controller.config.algo} controller; {who} drives a {wanted} one")
    robot = check_choice(args.robot or controller.embodiment, "--robot", EMBODIMENT_NAMES)
    hands = check_choice(args.hands or controller.hands, "--hands", HANDS_VARIANTS)
    if (robot, hands) != (controller.embodiment, controller.hands):
        raise InputError(
            f"--llc {args.llc}: a controller of {controller.embodiment} hands={controller.hands}, "
            f"not of {robot} hands={hands}"
        )
    return robot, hands


def check_workers(workers: int | None) -> None:
    if workers is not None:
        check_number(workers, "--workers", low=1, high=64, integer=True)


def report_at_end(args, folder: RunFolder, workers: int, evaluate: Callable, summary: Callable[[dict], dict]) -> None:
    """A finished training command's evaluation (`--eval-episodes`, 0: none):
    `evaluate` writes the run's report; its headline goes to standard error."""
    if args.eval_episodes:
        report = evaluate(folder, args.eval_episodes, seed=1000, workers=workers)
        figures = {k: report[k] for k in ("samples", "wall_clock_seconds")} | summary(report)
        print(json.dumps(figures), file=sys.stderr)
