"""The training loop every learner shares, and the run folder it keeps.

A run folder (`RunFolder`) holds:

- `run.json`: the settings of the command that started the run;
- `config.yaml`: the training configuration;
- `checkpoint.pt`: everything to resume (every `checkpoint_every`
  iterations, by default about `CHECKPOINT_SECONDS` of them, and at the end);
- `policy.pt`: the policy alone, for a scenario's `!PolicyCheckpoint`;
- `metrics.jsonl`: one line of scalars per iteration (`tb/` too when
  TensorBoard is installed);
- `report.json`: the evaluation of the end.

`train` runs a learner (`agent.Agent`, `skill_agent.SkillAgent`: anything
with `iteration`, `counters` and `state_dict`) to a sample budget: its
warm start first if it has one not yet done, then iterations, one metrics
line each and a progress line on standard error. Killed at any point, a
run resumed from its folder continues from the last checkpoint with the
same counters, optimiser state and random streams; only the iterations
after that checkpoint are done again.
"""

from __future__ import annotations

import json
import os
import platform
import time
from collections.abc import Callable
from datetime import date
from pathlib import Path

import yaml

from hotu_drake.errors import InputError
from hotu_drake.io import check_output_path, write_text_atomic
from hotu_drake.learning.checkpoint import read_checkpoint, save_checkpoint
from hotu_drake.learning.logger import MetricsLog, Progress

CHECKPOINT_SECONDS = 180.0  # the default checkpoint interval, as wall-clock


class RunFolder:
    """A training run's folder (see the module docstring)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.checkpoint_path = self.path / "checkpoint.pt"
        self.policy_path = self.path / "policy.pt"
        self.settings_path = self.path / "run.json"

    def holds_run(self) -> bool:
        return self.checkpoint_path.is_file() and self.settings_path.is_file()

    def check_new(self) -> None:
        """`InputError` unless a new run can start here."""
        if self.checkpoint_path.exists() or self.settings_path.exists():
            raise InputError(
                f"{self.path}: a run is already here (add --resume to continue it, or choose another --out)"
            )
        check_output_path(self.path, folder=True)

    def check_resumable(self) -> None:
        if not self.holds_run():
            raise InputError(f"{self.path}: no run to resume here (no checkpoint.pt and run.json)")

    def check_run(self) -> None:
        if not self.holds_run():
            raise InputError(f"{self.path}: not a run folder (no checkpoint.pt and run.json)")

    def start(self, settings: dict, config: dict) -> None:
        """A new run: the folder with its settings and configuration."""
        self.path.mkdir(parents=True, exist_ok=True)
        write_text_atomic(self.settings_path, json.dumps(settings, indent=2) + "\n")
        write_text_atomic(self.path / "config.yaml", yaml.safe_dump(config, sort_keys=False))

    def settings(self) -> dict:
        return json.loads(self.settings_path.read_text())

    def checkpoint(self) -> dict:
        """The last training checkpoint."""
        return read_checkpoint(self.checkpoint_path, kind="training")

    def save(self, agent, settings: dict, keys: tuple[str, ...], extra_meta: dict | None = None) -> None:
        """The training checkpoint, and the policy alone next to it. Their
        meta: the run's `settings` under `keys`, what the agent records of
        itself (`checkpoint_meta`) and `extra_meta`."""
        meta = {k: settings[k] for k in keys} | agent.checkpoint_meta() | (extra_meta or {})
        policy, robot, hands, info = agent.model.policy, settings["robot"], settings["hands"], agent.policy_info()
        save_checkpoint(self.checkpoint_path, policy, robot, hands, meta, state=agent.state_dict(), **info)
        save_checkpoint(self.policy_path, policy, robot, hands, meta, **info)

    def write_report(self, report: dict) -> None:
        write_text_atomic(self.path / "report.json", json.dumps(report, indent=2) + "\n")


def run_record(agent) -> dict:
    """What a report says of the run that made it: samples, iterations, wall-clock, and the machine."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return {
        "samples": agent.counters["samples"],
        "iterations": agent.counters["iteration"],
        "wall_clock_seconds": round(agent.counters["seconds"], 1),
        "machine": {"cpu_cores": cores, "python": platform.python_version(), "date": date.today().isoformat()},
    }


def train(
    agent,
    folder: RunFolder,
    steps: int,
    save: Callable[[], None],
    *,
    resume: bool = False,
    checkpoint_every: int | None = None,
    shown: Callable[[dict], dict] | None = None,
    label: str = "style",
) -> None:
    """Run `agent` until `steps` samples: its warm start if due, then
    iterations, each logged in `folder`'s metrics; `save()` about every
    `CHECKPOINT_SECONDS` (or every `checkpoint_every` iterations) and at
    the end. The progress line shows `shown(stats)` under `label`."""
    log = MetricsLog(folder.path, agent.counters["iteration"] if resume else None)
    try:
        if not agent.counters.get("warm_started", True):
            start = time.perf_counter()
            stats = agent.warm_start()
            seconds = time.perf_counter() - start
            agent.counters["seconds"] += seconds
            log.write(0, {**stats, "samples": 0, "warm_start_seconds": seconds})
        _iterate(agent, steps, save, log, Progress(steps, label=label), checkpoint_every, shown)
    finally:
        log.close()


def _iterate(agent, steps: int, save, log: MetricsLog, progress: Progress, every: int | None, shown) -> None:
    shown = shown or (lambda stats: {})
    since, terms = 0, {}
    while agent.counters["samples"] < steps:
        stats = agent.iteration()
        log.write(agent.counters["iteration"], stats)
        terms = shown(stats)
        progress.update(agent.counters["samples"], stats["samples_per_second"], terms)
        if every is None:  # about CHECKPOINT_SECONDS of iterations, from the first one's pace
            every = max(1, round(CHECKPOINT_SECONDS / max(stats["rollout_seconds"] + stats["update_seconds"], 1e-3)))
        since += 1
        if since >= every:
            save()
            since = 0
    save()
    counters = agent.counters
    progress.update(counters["samples"], counters["samples"] / max(counters["seconds"], 1e-9), terms, done=True)
