"""What the whole-body controller performs: each robot, each motion.

Each library motion once (`physical.perform` on the robot's clip, `loop:
false`; `--starts N`: from its first N frames, the table then giving how
many of the N it stood through): whether the robot stayed up (through
the clip and `physical.SETTLE` s after it), its travel against the clip's, the
share of frames with a joint at its torque limit, the steps the controller
took of its own to catch the robot (per start; the table gives the starts
that took any), how closely each start followed the clip (its key
bodies' RMS from the clip's, and how far from the clip's end its pelvis
ended), and, for a robot that fell, what in the clip is past it
(`Performance.report["cannot"]`) and, per start, where it lost its
balance (`lost_balance`). The
library walk looped for 10 s (`whole_body_walk_<robot>`) from several
seeds (its start drawn 0-0.05 s into the clip): how many it walked, and
its travel against the clip's. A capture (`--input`, a BVH or C3D)
retargeted and performed once. `--pace`: the clips' timing
(`RetargetOptions.pace`; the looped walk's too); `--hands`: the robots'
hands (none by default, as the figures in BENCHMARKS.md).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from hotu_drake import embodiment
from hotu_drake.motion.clip import MotionClip


def perform_row(robot: str, motion: str, clip, starts: int = 1) -> dict:
    """`clip` (the motion on `robot`) performed from its first frame; with
    `starts` > 1 also from 1 .. starts - 1 frames in (a motion a robot
    performs from one start and not the next is one it does not yet do:
    the row's `up_starts` of `starts`, and each start's fall time)."""
    from hotu_drake.physical import perform
    from hotu_drake.retarget.pipeline import has_fingers

    hands = "full" if has_fingers(clip) else "none"
    report = perform(clip, hands).report
    reports = [report] + [perform(clip.slice(start, clip.num_frames), hands).report for start in range(1, starts)]
    falls = [each["fell_at_s"] for each in reports]
    reference = report["reference_travel_m"]
    return {
        "robot": robot,
        "motion": motion,
        "hands": hands,
        "up": not report["fell"],
        "fell_at_s": report["fell_at_s"],
        "seconds": round(clip.duration, 2),
        "travel_ratio": round(report["root_travel_m"] / reference, 3) if reference > 0.2 else None,
        "torque_at_limit_share": report["torque_saturation_share"],
        "joint_rms_rad": report["joint_rms_rad"],
        # What is past the robot, from the first start that fell (one that stood says nothing of it).
        "cannot": next((each["cannot"] for each in reports if each["fell"]), []),
        "wall_time_s": report["wall_time_s"],
        "starts": starts,
        "up_starts": sum(fall is None for fall in falls),
        "fell_at_s_by_start": [None if fall is None else round(fall, 2) for fall in falls],
        "catch_steps_by_start": [len(each["catch_steps"]) for each in reports],
        # How closely each start followed the clip (a start that stood may still have ended far from it).
        "key_body_rms_m_by_start": [each["key_body_rms_m"] for each in reports],
        "end_offset_m_by_start": [each["end_offset_m"] for each in reports],
        # Where each start that fell lost its balance (`physical.perform`'s `lost_balance`; None if it stood).
        "lost_balance_by_start": [each["lost_balance"] for each in reports],
    }


def looped_walk_row(robot: str, seeds: int, walk: MotionClip | None = None, hands: str = "none") -> dict:
    """`whole_body_walk_<robot>` (10 s) from `seeds` seeds, the robot with
    `hands`: the walks, their travel ratios and fall times; tracking `walk`
    instead of the library's walk if given (the walk at another pace)."""
    from hotu_drake.diagrams import run_scenario
    from hotu_drake.scenario import load_scenario

    ratios, falls = [], []
    fingers = bool(embodiment.load(robot, hands).finger_joints)
    with tempfile.TemporaryDirectory() as folder:
        if walk is not None:
            walk.save(Path(folder) / "walk.npz")
        for seed in range(seeds):
            scenario = load_scenario(f"whole_body_walk_{robot}")
            scenario.seed, scenario.hands = seed, hands
            if walk is not None:
                scenario.driver.motion = str(Path(folder) / "walk.npz")
            figures = run_scenario(scenario)
            if figures["fell"]:
                falls.append(seed)
            ratios.append(round(figures["root_travel_m"] / figures["reference_travel_m"], 3))
    walked = [r for seed, r in enumerate(ratios) if seed not in falls]
    return {
        "robot": robot,
        "motion": "walk (looped, 10 s)",
        "hands": hands if fingers else "none",
        "walked": seeds - len(falls),
        "seeds": seeds,
        "travel_ratio_range": [min(walked), max(walked)] if walked else None,
        "fell_seeds": falls,
    }


def markdown(rows: list[dict], robots: list[str]) -> str:
    """The rows as a table: motions down, robots across ("up", or the fall
    time; from several starts, those it stood through, and how many of them
    took a catch step)."""
    motions = list(dict.fromkeys(row["motion"] for row in rows))
    lines = ["| motion | " + " | ".join(robots) + " |", "|---|" + "---|" * len(robots)]
    for motion in motions:
        cells = []
        for robot in robots:
            row = next((r for r in rows if r["robot"] == robot and r["motion"] == motion), None)
            if row is None:
                cells.append("")
            elif "walked" in row:
                cells.append(f"{row['walked']}/{row['seeds']}")
            elif row.get("starts", 1) > 1:
                caught = sum(count > 0 for count in row.get("catch_steps_by_start", []))
                cells.append(f"{row['up_starts']}/{row['starts']}" + (f" ({caught} caught)" if caught else ""))
            else:
                cells.append("up" if row["up"] else f"fell {row['fell_at_s']:.1f} s")
        lines.append(f"| {motion} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
