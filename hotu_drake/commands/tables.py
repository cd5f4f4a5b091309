"""The method's tables and figures, recomputed from run folders (`python -m hotu_drake.evaluate`).

    python -m hotu_drake.evaluate primitives --runs runs/*_dail --out results/table2
    python -m hotu_drake.evaluate skills --runs runs/udh_box_* runs/h1_box_* --out results/table3
    python -m hotu_drake.evaluate ablation --runs runs/h1_wave_dail runs/h1_wave_amp --out ablation.png
    python -m hotu_drake.evaluate perturbation --runs runs/h1_box_dail runs/bruce_squat_dail --out results/perturb

- `primitives`: Table II, one row per behavior run and motion: the
  normalised style return on that motion's frames, the fall rate, the
  nearest-reference distance and the coverage (degrees), next to the robot
  standing, with each run's samples, wall-clock, machine and date; a
  clone of the whole-body controller (`--algo dagger`), its falls,
  coverage and travel against its clip's, motion by motion.
- `skills`: Table III, one row per skill run (`train skill`, `train
  finetune`): success rate, normalised task return and wall-clock hours.
  A transfer's hours are its share of the UDH skill's training (the skill's
  seconds divided by the number of robots it is transferred to in the
  table) plus recording and retargeting its references plus its fine-tune;
  the table says so, and gives fine-tune / scratch where a robot has both.
- `ablation`: each run's combined style reward against samples, one panel
  per robot, the decomposed (DAIL) runs solid, the whole-body ones dashed.
- `perturbation`: the stability test with learned policies: each run's
  controller standing in its diagram (a clone of the whole-body
  controller walking its walk) while a cube of increasing momentum is
  thrown at its torso from several directions; the fall rate against the
  momentum (CSV, PNG), and a Meshcat replay of one hit per robot.

Every figure comes from the runs' `report.json` (written by `train
evaluate` from the last checkpoint; made here if a run has a checkpoint and
no report, or with `--reevaluate`), `run.json` and `metrics.jsonl`
(or `.jsonl.gz`); nothing is typed in.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hotu_drake.cli import ArgumentParser, run_cli
from hotu_drake.commands import train, train_skill
from hotu_drake.commands.figures import pyplot, save_figure
from hotu_drake.errors import InputError, check_number
from hotu_drake.io import check_output_path, write_text_atomic

LEGGED = ("udh", "naviai", "h1", "bruce", "walker")  # CURI rolls on a wheeled base
CUBE_SPEED = 6.0  # m/s at launch: the momentum is varied by the cube's mass
CUBE_DISTANCE = 1.5  # m from the torso, horizontally
CUBE_SIZE = 0.15  # m
THROW_TIME = 1.5  # s after the start (the robot has settled)
PERTURBATION_SECONDS = 4.0


@dataclass
class Run:
    """What a run folder holds that the tables read."""

    path: Path
    settings: dict
    report: dict | None
    metrics: list[dict] | None

    @property
    def name(self) -> str:
        return self.path.name


def read_run(path: str | Path, need_report: bool = True, reevaluate: bool = False, episodes: int | None = None) -> Run:
    """A run folder's settings, report and metrics; `InputError` naming the
    folder and what is wrong if it cannot be read. A run with a training
    checkpoint and no report (or `reevaluate`) is evaluated first."""
    run = Path(path)
    if not run.is_dir():
        raise InputError(f"{run}: not a run folder (no such folder)")
    try:
        settings = json.loads((run / "run.json").read_text())
    except FileNotFoundError:
        raise InputError(f"{run}: not a run folder (no run.json)") from None
    except (OSError, ValueError) as error:
        raise InputError(f"{run}: run.json cannot be read ({str(error).splitlines()[0][:100]})") from None
    if not isinstance(settings, dict) or "robot" not in settings or "algo" not in settings:
        raise InputError(f"{run}: run.json is not a training run's settings (no robot and algo)")
    report_file = run / "report.json"
    if (reevaluate or not report_file.is_file()) and (run / "checkpoint.pt").is_file() and need_report:
        _evaluate(run, settings, episodes)
    report = None
    if report_file.is_file():
        try:
            report = json.loads(report_file.read_text())
        except ValueError as error:
            raise InputError(f"{report_file}: not valid JSON ({str(error)[:80]})") from None
    elif need_report:
        raise InputError(f"{run}: no report.json and no checkpoint.pt to evaluate")
    return Run(run, settings, report, _metrics(run))


def _evaluate(run: Path, settings: dict, episodes: int | None) -> None:
    if settings.get("command") in ("skill", "finetune"):
        train_skill.evaluate_skill_run(run, episodes or train_skill.EVALUATION_EPISODES, 1000, 2)
    else:
        train.evaluate_run(run, episodes or 20, 1000, 2)


def _metrics(run: Path) -> list[dict] | None:
    for name, opener in (("metrics.jsonl", open), ("metrics.jsonl.gz", gzip.open)):
        file = run / name
        if file.is_file():
            try:
                with opener(file, "rt") as stream:
                    return [json.loads(line) for line in stream if line.strip()]
            except (OSError, ValueError, EOFError) as error:
                raise InputError(f"{file}: cannot be read ({str(error).splitlines()[0][:100]})") from None
    return None


def _machine(run: Run) -> str:
    machine = (run.report or {}).get("machine", {})
    return f"{machine.get('cpu_cores', '?')} cores, {machine.get('date', '?')}"


def _write_table(out: Path, name: str, header: list[str], rows: list[list], notes: list[str]) -> None:
    """`name`.md (a Markdown table and its notes) and `name`.csv in `out`."""
    out.mkdir(parents=True, exist_ok=True)
    text = io.StringIO()
    csv.writer(text, lineterminator="\n").writerows([header, *rows])
    write_text_atomic(out / f"{name}.csv", text.getvalue())
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(v) for v in row) + " |" for row in rows]
    write_text_atomic(out / f"{name}.md", "\n".join(lines + [""] + notes) + "\n")
    print(f"wrote {out / name}.md and .csv", file=sys.stderr)


def _cell(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


# -- Table II ---------------------------------------------------------------------------


def primitives_table(runs: list[Run]) -> tuple[list[str], list[list]]:
    """Table II's header and rows (one per run and motion; a clone's, motion
    by motion from its evaluation, with no judges' return)."""
    header = [
        "robot",
        "algo",
        "motion",
        "normalized return",
        "standing return",
        "share of frames",
        "fall rate",
        "distance (deg)",
        "coverage (deg)",
        "standing coverage (deg)",
        "travel ratio",
        "samples",
        "wall-clock (h)",
        "run",
        "machine",
    ]
    rows = []
    for run in runs:
        if run.settings.get("command") in ("skill", "finetune"):
            raise InputError(f"{run.path}: a skill run; Table II takes behavior runs (train pretrain)")
        evaluation = run.report.get("evaluation", {})
        common = [
            run.report.get("samples"),
            round(run.report.get("wall_clock_seconds", 0.0) / 3600, 3),
            run.name,
            _machine(run),
        ]
        robot, algo = run.settings["robot"], run.settings["algo"]
        if "teacher" in evaluation or "by_motion" in evaluation:  # a clone of the whole-body controller
            by_motion = evaluation.get("by_motion") or {run.settings["motions"][0]: evaluation}
            for motion, figures in by_motion.items():
                policy, standing = figures["policy"], figures["standing"]
                rows.append(
                    [robot, algo, motion, None, None, None, policy["fall_rate"], None]
                    + [policy.get("coverage_deg"), standing.get("coverage_deg"), policy.get("travel_ratio"), *common]
                )
            continue
        policy, standing = evaluation.get("policy"), evaluation.get("standing")
        if policy is None or standing is None:
            raise InputError(f"{run.path}/report.json: no policy and standing evaluation (not a behavior report)")
        for motion, figures in policy.get("motions", {}).items():
            rows.append(
                [
                    robot,
                    algo,
                    motion,
                    figures.get("normalized_return"),
                    standing.get("motions", {}).get(motion, {}).get("normalized_return"),
                    figures.get("share_of_frames"),
                    policy.get("fall_rate"),
                    policy.get("joint_distance_deg", {}).get("all"),
                    policy.get("coverage_deg", {}).get("all"),
                    standing.get("coverage_deg", {}).get("all"),
                    None,
                    *common,
                ]
            )
    return header, rows


PRIMITIVE_NOTES = [
    "Normalised return: the policy's combined style reward over the evaluation frames nearest to that motion,",
    "per step (1 is the best possible); a motion no frame is nearest to has none. Distance: the mean joint",
    "distance from each policy frame to the nearest reference frame; coverage: from each reference frame to the",
    "nearest policy frame (a robot that holds one pose of a clip is near it but covers little of it). Standing:",
    "the same robot holding its standing pose on the same episodes. From each run's report.json. The return is",
    "the run's own judges' (DAIL: the product of its part rewards; AMP: one whole-body reward), so it compares",
    "within an algorithm; distance and coverage compare across algorithms and robots. A clone of the whole-body",
    "controller (dagger) has no judges: its rows give its falls, coverage and travel against its clip's",
    "(travel ratio), each motion from its own episodes.",
]


# -- Table III --------------------------------------------------------------------------


def skills_table(runs: list[Run]) -> tuple[list[str], list[list], list[str]]:
    """Table III's header, rows and notes (how transfer hours are counted, fine-tune / scratch)."""
    header = [
        "robot",
        "method",
        "task",
        "success rate",
        "normalized return",
        "standing return",
        "tracking return",
        "standing tracking return",
        "fall rate",
        "samples",
        "hours",
        "how the hours are counted",
        "run",
        "machine",
    ]
    transfers: dict[str, int] = {}
    for run in runs:
        if run.settings.get("command") not in ("skill", "finetune"):
            raise InputError(f"{run.path}: a behavior run; Table III takes train skill and train finetune runs")
        if run.settings["command"] == "finetune":
            transfers[run.settings["skill"]] = transfers.get(run.settings["skill"], 0) + 1
    rows, hours = [], {}
    for run in runs:
        s, report = run.settings, run.report
        evaluation = report["evaluation"]
        seconds = float(report.get("wall_clock_seconds", 0.0))
        if s["command"] == "finetune":
            skill_seconds = float(s.get("skill_summary", {}).get("seconds") or 0.0)
            share = transfers[s["skill"]]
            references = float(s.get("transfer_seconds", 0.0))
            total = skill_seconds / share + references + seconds
            method = f"transfer ({s.get('skill_summary', {}).get('algo', 'ours')}) + fine-tune"
            how = (
                f"UDH skill {skill_seconds:.0f} s / {share} robot(s) + references {references:.0f} s "
                f"+ fine-tune {seconds:.0f} s"
            )
            hours.setdefault(s["robot"], {})["transfer"] = (references + seconds) / 3600
        else:
            total, method, how = seconds, s["algo"], f"training {seconds:.0f} s"
            hours.setdefault(s["robot"], {}).setdefault("scratch", {})[s["algo"]] = seconds / 3600
        rows.append(
            [
                s["robot"],
                method,
                s["task"],
                evaluation.get("success_rate"),
                evaluation.get("normalized_return"),
                evaluation.get("standing", {}).get("normalized_return"),
                evaluation.get("normalized_tracking_return"),
                evaluation.get("standing", {}).get("normalized_tracking_return"),
                evaluation.get("fall_rate"),
                report.get("samples"),
                round(total / 3600, 3),
                how,
                run.name,
                _machine(run),
            ]
        )
    notes = [
        "Normalised return: the task reward summed over the episode over its 300 steps (a transfer's on held-out",
        "references, judged by the task's reward). Tracking return: a transfer's tracking reward (joints, key",
        "bodies, object) on the same episodes, likewise normalised. Standing: the robot holding its standing",
        "pose on the same task instances.",
    ]
    for robot, figures in hours.items():
        if "transfer" in figures and figures.get("scratch"):
            for algo, scratch in figures["scratch"].items():
                ratio = figures["transfer"] / scratch
                notes.append(
                    f"{robot}: references + fine-tune / {algo} from scratch = {figures['transfer']:.3f} h / "
                    f"{scratch:.3f} h = {ratio:.2f} (wall-clock; see the returns for what each reached)."
                )
    return header, rows, notes


# -- ablation figure --------------------------------------------------------------------


def ablation_figure(runs: list[Run], out: Path, smooth: int = 10) -> None:
    """Combined style reward against samples, one panel per robot."""

    robots: dict[str, list[Run]] = {}
    for run in runs:
        if not run.metrics:
            raise InputError(f"{run.path}: no metrics.jsonl to draw")
        if run.settings.get("command") in ("skill", "finetune"):
            raise InputError(f"{run.path}: a skill run; the ablation compares behavior runs")
        robots.setdefault(run.settings["robot"], []).append(run)
    plt = pyplot("ablation")
    figure, axes = plt.subplots(1, len(robots), figsize=(5 * len(robots), 3.5), squeeze=False)
    for ax, (robot, group) in zip(axes[0], robots.items()):
        for run in group:
            points = np.array([(r["samples"], r["style"]) for r in run.metrics if r.get("style") is not None])
            if len(points) == 0:
                raise InputError(f"{run.path}: no style reward in its metrics")
            window = min(smooth, len(points))
            y = np.convolve(points[:, 1], np.ones(window) / window, mode="valid")
            decomposed = run.settings["algo"] == "dail"
            label = f"{run.name} ({run.settings['algo']})"
            ax.plot(points[window - 1 :, 0], y, "-" if decomposed else "--", label=label)
        ax.set_title(robot)
        ax.set_xlabel("samples")
        ax.set_ylabel("style reward (combined)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    save_figure(plt, figure, out, dpi=110)


# -- perturbation -----------------------------------------------------------------------


def throw(momentum: float, direction: float, height: float):
    """The `CubeLaunch` of one hit: a cube of mass momentum / `CUBE_SPEED`
    from `CUBE_DISTANCE` away in `direction` (rad, 0 = in front) at
    `height`, aimed above the torso by its fall over the flight."""
    from hotu_drake.systems.perturbation import CubeLaunch

    flight = CUBE_DISTANCE / CUBE_SPEED
    start = [CUBE_DISTANCE * np.cos(direction), CUBE_DISTANCE * np.sin(direction), height]
    return CubeLaunch(
        time=THROW_TIME,
        start=[float(x) for x in start],
        speed=CUBE_SPEED,
        mass=momentum / CUBE_SPEED,
        size=CUBE_SIZE,
        aim_height=0.5 * 9.81 * flight**2,
    )


def perturbation_scenario(run: Run, momentum: float, direction: float, latent_seed: int):
    """The run's controller from standing with one cube thrown at it (none
    at 0): a style policy standing (latents from its prior); a clone of the
    whole-body controller (`dagger`) performing its walk (else its first
    motion), as the teacher is hit walking (`bench pushes`); each at the
    rate it was trained at."""
    from hotu_drake import embodiment as embodiments
    from hotu_drake.learning.checkpoint import read_checkpoint
    from hotu_drake.scenario import InitialCondition, PolicyCheckpoint, Scenario

    robot, hands = run.settings["robot"], run.settings["hands"]
    emb = embodiments.load(robot, hands)
    height = 1.4 * emb.standing_pelvis_height  # about the chest: the aim itself is at the torso body at launch
    launches = [throw(momentum, direction, height)] if momentum > 0 else []
    policy = str((run.path / "policy.pt").resolve())
    driver = PolicyCheckpoint(policy, latents="prior", latent_seed=latent_seed)
    if run.settings.get("algo") == "dagger":
        motions = [str(m) for m in run.settings["motions"]]
        driver = PolicyCheckpoint(policy, latents="walk" if "walk" in motions else motions[0])
    return Scenario(
        embodiment=robot,
        hands=hands,
        control_rate=float(read_checkpoint(policy)["control_rate"]),
        initial=InitialCondition(drop_height=0.0),
        driver=driver,
        perturbations=launches,
        duration=PERTURBATION_SECONDS,
    )


def perturbation_test(runs: list[Run], momenta: list[float], directions: int, out: Path, html: bool) -> list[dict]:
    """Falls per run and momentum over `directions` throws; CSV, PNG and one replay per robot in `out`."""
    from hotu_drake.diagrams import run_scenario as simulate

    for run in runs:
        if run.settings["robot"] not in LEGGED:
            raise InputError(f"{run.path}: {run.settings['robot']} has no legs to knock over (legged: {LEGGED})")
        if run.settings.get("command") in ("skill", "finetune") or not (run.path / "policy.pt").is_file():
            raise InputError(f"{run.path}: not a behavior run with a policy.pt")
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for run in runs:
        for momentum in momenta:
            falls = 0
            for k in range(directions):
                scenario = perturbation_scenario(run, momentum, 2 * np.pi * k / directions, latent_seed=k)
                falls += int(simulate(scenario)["fell"])
            rows.append({"robot": run.settings["robot"], "run": run.name, "momentum": momentum, "throws": directions})
            rows[-1] |= {"falls": falls, "fall_rate": falls / directions}
            print(f"{run.name} momentum {momentum:g}: {falls}/{directions} falls", file=sys.stderr)
        if html:
            _hit_replay(run, rows, out)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_text_atomic(out / "perturbation.csv", text.getvalue())
    _perturbation_plot(rows, out / "perturbation.png")
    return rows


def _hit_replay(run: Run, rows: list[dict], out: Path) -> None:
    """A Meshcat replay of the run's hardest hit from the front that it survived (or its lightest if none)."""
    from pydrake.geometry import StartMeshcat

    from hotu_drake.diagrams import run_scenario as simulate

    mine = [r for r in rows if r["run"] == run.name and r["momentum"] > 0]
    if not mine:
        return
    survived = [r["momentum"] for r in mine if r["falls"] < r["throws"]]
    momentum = max(survived) if survived else min(r["momentum"] for r in mine)
    meshcat = StartMeshcat()
    simulate(perturbation_scenario(run, momentum, 0.0, latent_seed=0), meshcat=meshcat)
    write_text_atomic(out / f"hit_{run.settings['robot']}.html", meshcat.StaticHtml())


def _perturbation_plot(rows: list[dict], out: Path) -> None:

    plt = pyplot("perturbation")
    figure, ax = plt.subplots(figsize=(6, 4))
    for name in dict.fromkeys(r["run"] for r in rows):
        mine = [r for r in rows if r["run"] == name]
        ax.plot([r["momentum"] for r in mine], [r["fall_rate"] for r in mine], "o-", label=f"{mine[0]['robot']}")
    ax.set_xlabel("cube momentum (kg m/s)")
    ax.set_ylabel("fall rate")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(alpha=0.3)
    ax.legend()
    save_figure(plt, figure, out, dpi=110)


# -- command line -----------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.evaluate", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for name, text in (
        ("primitives", "Table II from behavior runs (Markdown and CSV)"),
        ("skills", "Table III from skill and fine-tune runs (Markdown and CSV)"),
        ("ablation", "style-reward curves, decomposed against whole-body (PNG)"),
        ("perturbation", "fall rate against thrown cubes' momentum (CSV, PNG, Meshcat HTML)"),
    ):
        command = sub.add_parser(name, help=text)
        command.add_argument("--runs", nargs="+", required=True, help="run folders")
        command.add_argument("--out", required=True, help="the output folder (a .png file for ablation)")
        if name in ("primitives", "skills"):
            command.add_argument("--reevaluate", action="store_true", help="evaluate every run's checkpoint again")
            command.add_argument("--episodes", type=int, help="evaluation episodes when evaluating")
    perturb = sub.choices["perturbation"]
    perturb.add_argument("--momenta", default="0,2,5,10,20,40", help="cube momenta, kg m/s (comma-separated)")
    perturb.add_argument("--directions", type=int, default=4, help="throws per momentum, from around the robot")
    perturb.add_argument("--no-html", action="store_true", help="skip the Meshcat replays")
    args = parser.parse_args(argv)
    out = Path(args.out)
    if args.command == "ablation":
        check_output_path(out)
        if out.suffix != ".png":
            raise InputError(f"{out}: the ablation figure is a .png file")
        ablation_figure([read_run(r, need_report=False) for r in args.runs], out)
        return 0
    check_output_path(out, folder=True)
    if args.command == "perturbation":
        momenta = _momenta(args.momenta)
        check_number(args.directions, "--directions", low=1, high=64, integer=True)
        runs = [read_run(r, need_report=False) for r in args.runs]
        perturbation_test(runs, momenta, args.directions, out, not args.no_html)
        return 0
    if args.episodes is not None:
        check_number(args.episodes, "--episodes", low=1, high=100_000, integer=True)
    runs = [read_run(r, reevaluate=args.reevaluate, episodes=args.episodes) for r in args.runs]
    if args.command == "primitives":
        header, rows = primitives_table(runs)
        _write_table(out, "table2", header, rows, PRIMITIVE_NOTES)
    else:
        header, rows, notes = skills_table(runs)
        _write_table(out, "table3", header, rows, notes)
    return 0


def _momenta(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"--momenta {text!r}: give comma-separated numbers (kg m/s)") from None
    if not values or any(not np.isfinite(v) or v < 0 or v > 1000 for v in values):
        raise InputError(f"--momenta {text!r}: give one or more momenta between 0 and 1000 kg m/s")
    return values


if __name__ == "__main__":
    sys.exit(run_cli(main))
