"""Fidelity of the plant at a time step and a SAP near-rigid threshold.

For each legged robot, four trials, each run at the candidate settings and
at a fine reference step (1/1440 s by default):

- `stand`: dropped from 0.1 m, its PD holding the standing pose, 3 s;
- `squat`: the library squat's knee profile (its timing; the UDH bends its
  knees up to 1.6 rad) as a knee bend of `SQUAT_KNEE` rad with the hips and
  ankles keeping the torso upright and the feet flat, tracked by the PD on
  the floor from the standing pose. (The retargeted squat itself leans the
  pelvis, which a PD on joints alone cannot follow on a free base: every
  robot but the UDH falls with it, at every step.) H1's squat is 0.1 rad: its
  PD (1-DoF ankles of 40 N m, heels 3.5 cm behind the ankles) tips over
  backwards from 0.2 rad on, at every step, the fine reference included;
- `push`: standing, a cube thrown at the torso at 1 s (the `perturb_<robot>`
  scenario's first throw), 3 s;
- `drop`: dropped from 0.3 m, 3 s.

Figures per trial: `fell` (the fall rule), `pelvis_height_ratio` (lowest
pelvis height over the standing one), `tracking_rms_deg` (squat: joints
against the clip), `trajectory_error_mm` (RMS over the run, sampled at
30 Hz, of the pelvis, head, hands and feet against the reference run),
`realtime_factor`. The harness states a bound on the trajectory error
(`ERROR_BOUND_MM`); a setting is acceptable for a robot when no trial
falls where the reference stands and the errors of standing, the squat and
the push are within the bound. The drop is judged by survival alone: where
a 0.3 m fall lands first decides its path, so its error to the reference
stays tens of millimetres at every candidate step (Walker: 38 mm at 1/180 s).
"""

import functools
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hotu_drake import embodiment as embodiments
from hotu_drake.diagrams import build_simulation
from hotu_drake.motion.clip import MotionClip
from hotu_drake.retarget.references import reference_clip
from hotu_drake.scenario import InitialCondition, ReferenceTracking, Scenario, load_scenario, shipped_scenarios

LEGGED = ("udh", "naviai", "h1", "bruce", "walker")
TRIALS = ("stand", "squat", "push", "drop")
BOUNDED_TRIALS = ("stand", "squat", "push")  # the error bound applies; the drop must only survive
REFERENCE_STEP = 1.0 / 1440.0
SAMPLE_PERIOD = 1.0 / 30.0
TRIAL_SECONDS = 3.0
ERROR_BOUND_MM = 15.0  # trajectory error against the fine reference a default may have
TRACKED_ROLES = ("pelvis", "head", "left_hand", "right_hand", "left_foot", "right_foot")
DEFAULT_SQUAT_KNEE = 0.6  # rad of knee bend at the squat's deepest
SQUAT_KNEE = {"h1": 0.1}


@dataclass(frozen=True)
class Setting:
    """A plant time step and SAP near-rigid threshold."""

    time_step: float
    near_rigid_threshold: float

    @property
    def label(self) -> str:
        return f"1/{round(1 / self.time_step)} s, threshold {self.near_rigid_threshold:g}"


def trial_scenario(robot: str, trial: str, setting: Setting) -> Scenario:
    """The scenario of one trial at one setting."""
    scenario = Scenario(embodiment=robot, hands="none", duration=TRIAL_SECONDS)
    if trial == "stand":
        scenario.initial = InitialCondition(drop_height=0.1)
    elif trial == "drop":
        scenario.initial = InitialCondition(drop_height=0.3)
    elif trial == "push":
        scenario.initial = InitialCondition(drop_height=0.0)
        scenario.perturbations = load_scenario(f"perturb_{robot}").perturbations[:1]
    elif trial == "squat":
        scenario.driver = ReferenceTracking(motion=str(squat_clip(robot)), loop=False)
        scenario.initial = InitialCondition(drop_height=0.0)
    else:
        raise ValueError(f"unknown trial {trial!r}")
    scenario.plant_config.time_step = setting.time_step
    scenario.plant_config.sap_near_rigid_threshold = setting.near_rigid_threshold
    return scenario


@functools.cache
def _scratch() -> Path:
    return Path(tempfile.mkdtemp(prefix="hotu_drake_fidelity_"))


def squat_clip(robot: str) -> Path:
    """The squat trial's joint trajectory for `robot`, as a clip file (in a scratch folder of this process)."""
    emb = embodiments.load(robot, "none")
    path = _scratch() / f"squat_{robot}.npz"
    if path.is_file():
        return path
    udh = reference_clip("squat", embodiments.load("udh", "none"))
    knee = udh.joint("left_knee_y") - udh.joint("left_knee_y")[0]
    bend = SQUAT_KNEE.get(robot, DEFAULT_SQUAT_KNEE) * knee / knee.max()
    q = np.tile(emb.standing_pose, (udh.num_frames, 1))
    for side in ("left", "right"):  # thigh forward, shin back: the torso stays upright, the foot flat
        for joint, share in ((f"{side}_hip_y", -0.5), (f"{side}_knee_y", 1.0), (f"{side}_ankle_y", -0.5)):
            q[:, emb.joint_names.index(joint)] += share * bend
    n = udh.num_frames
    root = np.tile([0.0, 0.0, emb.standing_root_height], (n, 1))
    clip = MotionClip.from_positions(
        robot, "fidelity squat", udh.fps, emb.joint_names, q, root, np.tile([1.0, 0, 0, 0], (n, 1))
    )
    return clip.save(path)


def run_trial(robot: str, trial: str, setting: Setting) -> dict:
    """Simulate one trial; its figures and the sampled key-body track."""
    scenario = trial_scenario(robot, trial, setting)
    sim = build_simulation(scenario)
    emb, plant, context = sim.embodiment, sim.plant, sim.plant_context()
    if trial == "squat":
        scenario.duration = sim.reference.duration
    fall = sim.fall_check()
    bodies = [plant.GetBodyByName(emb.key_bodies[r], sim.model) for r in TRACKED_ROLES if r in emb.key_bodies]
    track, errors, lowest, fell, wall = [], [], np.inf, False, 0.0
    steps = int(round(scenario.duration / SAMPLE_PERIOD))
    for k in range(1, steps + 1):
        start = time.perf_counter()
        sim.simulator.AdvanceTo(k * SAMPLE_PERIOD)
        wall += time.perf_counter() - start
        track.append([plant.EvalBodyPoseInWorld(context, body).translation() for body in bodies])
        lowest = min(lowest, fall.pelvis_height(context))
        fell = fell or fall(context)
        if trial == "squat":
            reference = sim.output("reference_joint_positions")
            errors.append(np.fromiter(sim.joint_positions().values(), float) - reference)
    figures = {
        "fell": bool(fell),
        "pelvis_height_ratio": round(float(lowest / emb.standing_pelvis_height), 4),
        "realtime_factor": round(scenario.duration / wall, 1),
    }
    if errors:
        figures["tracking_rms_deg"] = round(float(np.degrees(np.sqrt(np.mean(np.square(errors))))), 3)
    return {"figures": figures, "track": np.array(track)}


def fidelity(robots: tuple[str, ...], settings: list[Setting], reference: Setting, report=print) -> list[dict]:
    """Every trial of every robot at every setting, against the reference; one row each."""
    rows = []
    for robot in robots:
        for trial in TRIALS:
            truth = run_trial(robot, trial, reference)
            report({"robot": robot, "trial": trial, "setting": "reference " + reference.label, **truth["figures"]})
            for setting in settings:
                result = run_trial(robot, trial, setting)
                error = np.sqrt(np.mean(np.sum((result["track"] - truth["track"]) ** 2, axis=-1)))
                row = {
                    "robot": robot,
                    "trial": trial,
                    "time_step": setting.time_step,
                    "near_rigid_threshold": setting.near_rigid_threshold,
                    **result["figures"],
                    "trajectory_error_mm": round(1000 * float(error), 2),
                    "reference_fell": truth["figures"]["fell"],
                }
                row["acceptable"] = acceptable(row)
                report(row)
                rows.append(row)
    return rows


def acceptable(row: dict) -> bool:
    """No fall where the reference stands, and the trajectory within the bound
    (for the bounded trials, where both stand: after a fall the tracks part anyway)."""
    if row["fell"] and not row["reference_fell"]:
        return False
    if row["trial"] not in BOUNDED_TRIALS or row["reference_fell"]:
        return True
    return row["trajectory_error_mm"] <= ERROR_BOUND_MM


def summary(rows: list[dict]) -> list[str]:
    """A Markdown table: per setting, per trial, the worst figures over the robots."""
    lines = [
        "| step | threshold | trial | acceptable | falls (ref.) | worst error (mm) | lowest pelvis "
        "| squat RMS (deg) | RTF |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    keys = sorted({(r["time_step"], r["near_rigid_threshold"]) for r in rows}, key=lambda k: (k[1], k[0]))
    for step, threshold in keys:
        for trial in TRIALS:
            group = [
                r for r in rows if (r["time_step"], r["near_rigid_threshold"], r["trial"]) == (step, threshold, trial)
            ]
            if not group:
                continue
            falls = sum(r["fell"] for r in group)
            reference_falls = sum(r["reference_fell"] for r in group)
            squat = max((r.get("tracking_rms_deg", 0.0) for r in group), default=0.0)
            lines.append(
                f"| 1/{round(1 / step)} s | {threshold:g} | {trial} "
                f"| {sum(r['acceptable'] for r in group)}/{len(group)} | {falls} ({reference_falls}) "
                f"| {max(r['trajectory_error_mm'] for r in group):.1f} "
                f"| {min(r['pelvis_height_ratio'] for r in group):.3f} "
                f"| {squat:.2f} | {min(r['realtime_factor'] for r in group):.0f} |"
            )
    return lines


def legged_robots() -> tuple[str, ...]:
    """The robots with legs (and a shipped perturbation scenario)."""
    shipped = shipped_scenarios()
    return tuple(r for r in LEGGED if embodiments.load(r, "none").floating_base and f"perturb_{r}" in shipped)
