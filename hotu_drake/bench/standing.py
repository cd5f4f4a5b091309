"""Real-time factor of each embodiment standing after a drop, on one core."""

import contextlib
import os
import platform
import resource
import time
from datetime import UTC, datetime

from hotu_drake import embodiment
from hotu_drake.diagrams import build_standing_simulation
from hotu_drake.scenario import default_plant_config


def pin_to_one_core() -> None:
    """Run on a single core so figures are per core."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})


@contextlib.contextmanager
def one_core():
    """Run the block on a single core, then on the cores of before."""
    before = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    pin_to_one_core()
    try:
        yield
    finally:
        if before is not None:
            os.sched_setaffinity(0, before)


def machine() -> dict:
    """What the figures were measured on."""
    return {
        "cpu": _cpu_model(),
        "cores_visible": os.cpu_count(),
        "python": platform.python_version(),
        "drake": _version("drake"),
        "date": datetime.now(UTC).strftime("%Y-%m-%d"),
        "speed_index_seconds": speed_index(),
    }


def speed_index() -> float:
    """Seconds this machine takes for a fixed pure-Python loop (10 million
    additions), best of three: shared and throttled virtual machines vary
    by a factor of two or more from hour to hour, so figures from different
    runs compare only through this number."""
    best = float("inf")
    for _ in range(3):
        start, total = time.perf_counter(), 0
        for i in range(10_000_000):
            total += i
        best = min(best, time.perf_counter() - start)
    return round(best, 3)


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _version(package: str) -> str:
    from importlib.metadata import version

    return version(package)


def standing_realtime_factor(
    name: str, hands: str, seconds: float, time_step: float, self_collision: bool = True, drop_height: float = 0.1
) -> dict:
    """Simulate `seconds` of standing; return the real-time factor and outcome."""
    emb = embodiment.load(name, hands)
    plant_config = default_plant_config()
    plant_config.time_step = time_step
    start = time.perf_counter()
    drop = drop_height if emb.floating_base else 0.0
    sim = build_standing_simulation(emb, plant_config, drop_height=drop, self_collision=self_collision)
    build = time.perf_counter() - start
    start = time.perf_counter()
    sim.simulator.AdvanceTo(seconds)
    wall = time.perf_counter() - start
    height = sim.pelvis_height()
    nominal = emb.standing_pelvis_height
    return {
        "embodiment": name,
        "hands": hands,
        "dof": emb.part_dof["total"],
        "sim_seconds": seconds,
        "wall_seconds": round(wall, 3),
        "realtime_factor": round(seconds / wall, 2),
        "build_seconds": round(build, 3),
        "pelvis_height_ratio": round(height / nominal, 4) if nominal > 0 else None,
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }
