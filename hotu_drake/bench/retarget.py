"""Retargeting throughput per robot on one core, with the report's quality figures."""

from pathlib import Path

from hotu_drake import embodiment
from hotu_drake.motion.clip import MotionClip
from hotu_drake.retarget.metrics import report
from hotu_drake.retarget.pipeline import ROBOTS, retarget_onto
from hotu_drake.retarget.retargeter import RetargetOptions


def source_clip(path: str | None, seconds: float | None) -> MotionClip:
    """The given demonstration, or the generated walk at 120 fps."""
    if path:
        from hotu_drake.motion.load import load_motion

        clip = load_motion(Path(path))
    else:
        from hotu_drake.motion.library import generate

        clip = generate("walk", fps=120.0)
    if seconds is not None:
        clip = clip.slice(0, min(clip.num_frames, int(round(seconds * clip.fps)) + 1))
    return clip


def _direction_means(figures: dict, key: str) -> dict[str, float]:
    return {part: error["mean"] for part, error in figures.get(key, {}).items()}


def retarget_throughput(
    source: MotionClip,
    hands: str,
    robots: tuple[str, ...] = ("udh", *ROBOTS),
    options: RetargetOptions | None = None,
) -> list[dict]:
    """Frames per second of each stage (human -> UDH, and each robot through
    the UDH clip that bridges to it, `pipeline.retarget_onto`), after a
    warm-up on the clip's first quarter second, with the report's quality
    figures; `options` picks the solve (default: whole clip). Each robot's
    row has its bridge's seconds too, and the set-up's (the robot's and its
    bridge's) apart."""
    warm_up = source.slice(0, min(source.num_frames, int(0.25 * source.fps) + 2))
    retarget_onto(warm_up, robots[-1:], hands, options)
    stages = retarget_onto(source, robots, hands, options)
    rows = []
    for robot in robots:
        stage = stages[robot]
        figures = report(source, stage.clip, embodiment.load(robot, hands), stage.seconds)
        rows.append(
            {
                "robot": robot,
                "hands": hands,
                "frames": figures["frames"],
                "seconds": round(stage.seconds, 6),
                "bridge_seconds": round(stage.bridge.seconds, 6) if stage.bridge else 0.0,
                "setup_seconds": round(stage.total_setup_seconds, 6),
                "frames_per_second": figures["frames_per_second"],
                "joint_limit_violations": figures["joint_limit_violations"],
                "foot_skate_m_per_s": figures["foot_skate_m_per_s"],
                "foot_penetration_m": figures["foot_penetration_m"],
                "key_body_error": figures.get("key_body_error"),
                "direction_error_deg": _direction_means(figures, "part_direction_error_deg"),
                "direction_error_from_neutral_deg": _direction_means(figures, "part_direction_error_neutral_deg"),
            }
        )
    for row, fps in zip(rows, end_to_end_frames_per_second(rows).values()):
        row["end_to_end_frames_per_second"] = fps
    return rows


def end_to_end_frames_per_second(rows: list[dict]) -> dict[tuple[str, str], float | None]:
    """(robot, hands) -> human -> robot frames per second of `retarget_throughput`
    rows: the robot's stage seconds plus its bridge's (the UDH's own alone for `udh`)."""
    out = {}
    for row in rows:
        seconds = row["seconds"] + row.get("bridge_seconds", 0.0)
        out[row["robot"], row["hands"]] = round(row["frames"] / seconds, 1) if seconds > 0 else None
    return out
