"""Move a UDH skill to a robot: retarget what it did, fine-tune the robot's layer (`train finetune`).

    python -m hotu_drake.train finetune --robot h1 --skill runs/udh_box_ours --llc runs/h1_dail \\
        --steps 300000 --out runs/h1_box
    python -m hotu_drake.train finetune --out runs/h1_box --steps 600000 --resume

Section II-D of the method. The command

1. runs the UDH skill (`--skill`, a two-level `train skill` run) on
   `--references` seeded task instances (seeds 0, 1, ...) and on
   `--eval-references` held-out ones (seeds 1000, ...), records each
   episode and retargets it to `--robot`, objects and targets scaled to the
   robot (`hotu_drake.envs.transfer`; the clips go to the run's `references/`);
2. trains the fine-tuning layer (`learning.skill_config.finetune_preset`: a
   small MLP choosing the latents of the robot's frozen behavior controller
   `--llc` at every control step) with PPO on the transfer environment
   (`hotu_drake/BoxCarryTransfer-v0`: the task, the reference's start and
   target, the reference in the observation, reward = tracking), plus the
   controller's own style reward;
3. evaluates it on the held-out references: the task's success and
   normalised return on the robot (and the tracking return), next to the
   robot standing on the same instances.

The run folder has the `train skill` layout plus `references/`; `run.json`
records the seconds the references took (`transfer_seconds`), which count
toward the transfer's wall-clock with the training's.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from hotu_drake.commands.run_options import add_run_arguments, check_run_arguments, controller_robot
from hotu_drake.commands.train_skill import resumed_skill_run, train_skill_run
from hotu_drake.embodiment import EMBODIMENT_NAMES
from hotu_drake.envs.transfer import make_references, skill_controller, skill_summary
from hotu_drake.errors import InputError, check_number
from hotu_drake.learning.skill_config import TWO_LEVEL, finetune_preset, load_skill_config
from hotu_drake.learning.trainer import RunFolder

EVALUATION_SEED = 1000  # the held-out references' first seed


def add_parser(sub) -> None:
    fine = sub.add_parser("finetune", help="transfer a UDH skill to a robot: retarget its episodes, fine-tune")
    fine.add_argument("--robot", help=f"the robot ({', '.join(EMBODIMENT_NAMES)}; default: the --llc's)")
    fine.add_argument("--hands", help="full or none (default: the --llc's)")
    fine.add_argument("--skill", help="the UDH skill run to transfer (a two-level train skill run folder)")
    fine.add_argument("--llc", help="the robot's behavior controller (a DAIL train pretrain run folder)")
    fine.add_argument("--references", type=int, default=8, help="UDH episodes to record and track (default 8)")
    fine.add_argument("--eval-references", type=int, default=8, help="held-out episodes for the evaluation")
    add_run_arguments(fine, "the fine-tune preset (learning.skill_config.finetune_preset)", eval_episodes=16)


def finetune_command(args) -> int:
    folder = check_run_arguments(args)
    if args.resume:
        settings, config = resumed_skill_run(args, folder, "finetune", ("robot", "hands"))
        return train_skill_run(settings, config, args, folder)
    settings, config = _new_run(args, folder)
    out = folder.path
    created = not out.exists()
    staging = out / "references.partial"
    try:
        settings |= _record_references(settings, staging)
        staging.rename(out / "references")
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        if created:
            shutil.rmtree(out, ignore_errors=True)
        raise
    references = (out / "references").resolve()
    for key in ("references", "eval_references"):
        settings[key] = [str(references / Path(p).name) for p in settings[key]]
    settings["motions"] = settings["references"]
    return train_skill_run(settings, config, args, folder)


def _new_run(args, folder: RunFolder) -> tuple[dict, object]:
    folder.check_new()
    if not args.skill or not args.llc:
        raise InputError("finetune needs --skill (the UDH skill run) and --llc (the robot's behavior run)")
    for name in ("references", "eval_references"):
        check_number(getattr(args, name), f"--{name.replace('_', '-')}", "finetune", low=1, high=1000, integer=True)
    skill = Path(args.skill)
    skill_settings = _skill_settings(skill)
    robot, hands = controller_robot(args, "dail", "the fine-tune")
    config = load_skill_config(args.config, "ours", base=finetune_preset()) if args.config else finetune_preset()
    settings = {
        "command": "finetune",
        "task": skill_settings["task"],
        "robot": robot,
        "hands": hands,
        "algo": "ours",
        "llc": str(Path(args.llc).resolve()),
        "skill": str(skill.resolve()),
        "reference_count": args.references,
        "eval_reference_count": args.eval_references,
        "seed": args.seed,
        "workers": args.workers or 2,
    }
    return settings, config


def _skill_settings(skill: Path) -> dict:
    """The UDH skill run's settings, checked: a two-level run with what recording needs."""
    try:
        settings = json.loads((skill / "run.json").read_text())
    except (OSError, ValueError) as error:
        raise InputError(f"--skill {skill}: not a skill run folder ({str(error).splitlines()[0][:120]})") from None
    if not isinstance(settings, dict) or settings.get("command") != "skill" or settings.get("algo") not in TWO_LEVEL:
        raise InputError(f"--skill {skill}: not a two-level train skill run (ours or ase)")
    for name in ("policy.pt", "config.yaml"):
        if not (skill / name).is_file():
            raise InputError(f"--skill {skill}: no {name} (the run's high level and its task's curriculum)")
    skill_controller(skill)  # its behavior controller is there to record with
    return settings


def _record_references(settings: dict, folder: Path) -> dict:
    """The training and held-out references of the run, and what they took."""
    robot, hands, skill = settings["robot"], settings["hands"], settings["skill"]
    train = range(settings["reference_count"])
    held_out = range(EVALUATION_SEED, EVALUATION_SEED + settings["eval_reference_count"])
    references, seconds = make_references(skill, robot, hands, train, folder)
    evaluation, eval_seconds = make_references(skill, robot, hands, held_out, folder, prefix="eval")
    return {
        "references": [str(p) for p in references],
        "eval_references": [str(p) for p in evaluation],
        "transfer_seconds": round(seconds, 1),
        "eval_reference_seconds": round(eval_seconds, 1),
        "skill_summary": skill_summary(skill),
    }
