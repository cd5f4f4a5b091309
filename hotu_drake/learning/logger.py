"""What a run records: one JSON line of scalars per iteration, TensorBoard
scalars when TensorBoard is installed, and a progress line on standard error."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from hotu_drake.io import write_text_atomic


class MetricsLog:
    """`metrics.jsonl` in the run folder (and `tb/` for TensorBoard).

    On resume the lines after the checkpoint's iteration are dropped, so the
    log holds each iteration once."""

    def __init__(self, folder: Path, resume_iteration: int | None = None):
        self.path = folder / "metrics.jsonl"
        if resume_iteration is not None and self.path.is_file():
            kept = [line for line in self.path.read_text().splitlines() if _iteration(line) <= resume_iteration]
            write_text_atomic(self.path, "".join(f"{line}\n" for line in kept))
        self._file = open(self.path, "a")
        self._writer = _tensorboard(folder / "tb", resume_iteration)

    def write(self, iteration: int, scalars: dict[str, float]) -> None:
        record = {"iteration": iteration, **{k: _plain(v) for k, v in scalars.items()}}
        self._file.write(json.dumps(record) + "\n")
        self._file.flush()
        if self._writer is not None:
            step = int(scalars.get("samples", iteration))
            for key, value in record.items():
                if isinstance(value, int | float) and key != "iteration":
                    self._writer.add_scalar(key, value, step)
            self._writer.flush()

    def close(self) -> None:
        self._file.close()
        if self._writer is not None:
            self._writer.close()


def read_metrics(path: str | Path) -> list[dict]:
    """The records of a `metrics.jsonl`."""
    return [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]


def _iteration(line: str) -> int:
    try:
        return int(json.loads(line)["iteration"])
    except (ValueError, KeyError, TypeError):
        return 1 << 62  # an unreadable (half-written) line goes


def _plain(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _tensorboard(folder: Path, resume_iteration: int | None):
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:  # TensorBoard is an optional extra
        return None
    return SummaryWriter(str(folder), purge_step=resume_iteration)


def count_iteration(counters: dict, samples: int, start: float, collected: float, end: float) -> dict[str, float]:
    """Add one iteration of `samples` (collected from `start` to `collected`,
    learned from until `end`, perf-counter seconds) to a trainer's
    `counters`; its pace, as the metrics log records it."""
    counters["iteration"] += 1
    counters["samples"] += samples
    counters["seconds"] += end - start
    return {
        "samples": counters["samples"],
        "rollout_seconds": collected - start,
        "update_seconds": end - collected,
        "learner_share": (end - collected) / (end - start),
        "samples_per_second": samples / (end - start),
    }


class Progress:
    """One status line: samples, rate, the mean style reward per group (or other `label`led terms), ETA.
    Rewritten in place on a terminal; a full line every `every` seconds otherwise."""

    def __init__(self, total: int, every: float = 30.0, label: str = "style"):
        self.total, self.every, self.label = total, every, label
        self.tty = sys.stderr.isatty()
        self._last = 0.0

    def update(self, samples: int, rate: float, style: dict[str, float], done: bool = False) -> None:
        now = time.monotonic()
        if not (self.tty or done or now - self._last >= self.every):
            return
        self._last = now
        left = max(self.total - samples, 0) / max(rate, 1e-9)
        groups = " ".join(f"{g} {r:.2f}" for g, r in style.items())
        line = (
            f"samples {_count(samples)}/{_count(self.total)} ({100 * samples / self.total:.0f}%) | "
            f"{rate:.0f}/s | {self.label} {groups} | ETA {_duration(left)}"
        )
        end = "\n" if (done or not self.tty) else ""
        print(("\r" if self.tty else "") + line, end=end, file=sys.stderr, flush=True)


def _count(n: float) -> str:
    return f"{n / 1e6:.2f}M" if n >= 1e6 else f"{n / 1e3:.1f}k" if n >= 1e3 else str(int(n))


def _duration(seconds: float) -> str:
    seconds = int(seconds)
    return (
        f"{seconds // 3600}h{seconds % 3600 // 60:02d}m" if seconds >= 3600 else f"{seconds // 60}m{seconds % 60:02d}s"
    )
