"""Whether the retargeted clips are ones a robot can stand on: for each
clip and legged embodiment, the `retarget --report` figures of stance,
legs apart, balance and torques (issue 27's acceptance), one table."""

from __future__ import annotations

from pathlib import Path

from hotu_drake import embodiment
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.library.steering import VOCABULARY
from hotu_drake.retarget.metrics import report
from hotu_drake.retarget.pipeline import retarget_onto
from hotu_drake.retarget.retargeter import RetargetOptions

LEGGED = ("udh", "h1", "naviai", "walker", "bruce")
# The library's motions the acceptance names: walk, squat, the box carry and the steering vocabulary.
LIBRARY = ("walk", "squat", "box_carry", *VOCABULARY)


def source(name: str) -> MotionClip:
    """A library motion by name, or a motion file by path."""
    if Path(name).suffix:
        from hotu_drake.motion.load import load_motion

        return load_motion(Path(name))
    from hotu_drake.motion.library import generate

    return generate(name)


def clip_rows(name: str, clip: MotionClip, robots: tuple[str, ...] = LEGGED, pace: str = "auto") -> list[dict]:
    """One row per embodiment: the clip retargeted at `pace` (human -> UDH
    -> robot, no fingers; `pipeline.retarget_onto`) and its report's stance,
    legs, balance and torque figures."""
    stages = retarget_onto(clip, robots, "none", RetargetOptions(pace=pace))
    rows = []
    for robot in robots:
        stage = stages[robot]
        figures = report(clip, stage.clip, embodiment.load(robot, "none"), stage.seconds, stage.margins)
        margin = figures.get("centre_of_pressure_margin", {})
        torques = figures.get("torque_over_limit", {})
        worst = next(iter(torques.items()), None)
        rows.append(
            {
                "clip": Path(name).name,
                "robot": robot,
                "frames": figures["frames"],
                "seconds": round(stage.seconds, 3),
                "stance_ratio": figures["stance_ratio"],
                "leg_penetration_m": figures["leg_penetration_m"],
                "planted_sole_tilt_deg": figures["planted_sole_tilt_deg"],
                "planted_sole_height_m": figures["planted_sole_height_m"],
                "foot_skate_m_per_s": figures["foot_skate_m_per_s"],
                "planted_sole_slip_m_per_s": figures["planted_sole_slip_m_per_s"],
                "centre_of_pressure_margin": margin,
                "torque_over_limit_share": figures.get("torque_over_limit_share"),
                "worst_joint": {"name": worst[0], **worst[1]} if worst else None,
            }
        )
    return rows


def markdown(rows: list[dict]) -> str:
    """The rows as one Markdown table, with each median's share of the UDH's on the same clip."""
    udh = {row["clip"]: row["stance_ratio"]["median"] for row in rows if row["robot"] == "udh"}
    lines = [
        "| clip | robot | stance median (least) | / UDH's | leg penetration | planted sole tilt (deg) "
        "| CoP inside before | after | after, clear of flight "
        "| least margin after (m) | skate: ankle, sole (m/s) | frames over a torque limit "
        "| joint most often over (share, most) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        stance, margin = row["stance_ratio"], row["centre_of_pressure_margin"]
        base = udh.get(row["clip"])
        ratio = f"{stance['median'] / base:.2f}" if base else "-"
        before, after = margin.get("before", {}), margin.get("after", {})
        worst = row["worst_joint"]
        joint = f"{worst['name']} ({worst['share']:.2f}, {worst['most']}x)" if worst else "none"
        lines.append(
            f"| {row['clip']} | {row['robot']} | {stance['median']:.3f} ({stance['least']:.3f}) | {ratio} "
            f"| {100 * row['leg_penetration_m']:.1f} cm "
            f"| {row['planted_sole_tilt_deg']['median']} ({row['planted_sole_tilt_deg']['most']}) "
            f"| {before.get('inside_share', '-')} "
            f"| {after.get('inside_share', '-')} | {after.get('inside_share_clear_of_flight', '-')} "
            f"| {after.get('least_m', '-')} | {row['foot_skate_m_per_s']}, {row['planted_sole_slip_m_per_s']} "
            f"| {row['torque_over_limit_share']} | {joint} |"
        )
    return "\n".join(lines)
