"""What the readers and the motion library cost: seconds to generate the
whole library on the UDH, and to read each given motion file (the median of
`repeats` reads). Targets, checked here and not by timed tests (a loaded
machine would fail them): the library in under 10 s, a 3000-frame BVH in
under 1.5 s, CMU 01_01 (2752 frames) in under 2 s."""

from __future__ import annotations

import statistics
import time
from pathlib import Path

LIBRARY_TARGET_SECONDS = 10.0


def library_seconds() -> dict:
    """Every motion of the generated library on the UDH, timed once."""
    from hotu_drake import embodiment
    from hotu_drake.motion.library import MOTIONS, generate_udh

    udh = embodiment.load("udh", "full")
    start = time.perf_counter()
    frames = sum(generate_udh(name, udh=udh).num_frames for name in MOTIONS)
    seconds = time.perf_counter() - start
    return {
        "motions": len(MOTIONS),
        "frames": frames,
        "seconds": round(seconds, 3),
        "target_seconds": LIBRARY_TARGET_SECONDS,
        "met": seconds < LIBRARY_TARGET_SECONDS,
    }


def read_seconds(path: str | Path, repeats: int = 3) -> dict:
    """The median seconds of `repeats` reads of a motion file (any format
    `load_motion` takes; the reading, without the plausibility checks)."""
    from hotu_drake.motion.load import load_motion

    times, frames = [], 0
    for _ in range(repeats):
        start = time.perf_counter()
        frames = load_motion(Path(path), check_plausible=False).num_frames
        times.append(time.perf_counter() - start)
    median = statistics.median(times)
    return {
        "file": str(path),
        "frames": frames,
        "seconds": round(median, 3),
        "frames_per_second": round(frames / median),
    }
