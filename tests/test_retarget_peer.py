"""The mink peer of the retargeting benchmark (`bench retarget --peer mink`)."""

import json

import pytest

from hotu_drake.bench import __main__ as bench
from hotu_drake.bench import mink_peer
from hotu_drake.bench.retarget import end_to_end_frames_per_second, source_clip


@pytest.fixture
def no_pinning(monkeypatch):
    """Keep the test process on its cores (the benchmark pins itself to one)."""
    monkeypatch.setattr(bench, "pin_to_one_core", lambda: None)


def test_mink_peer_retargets_the_walk_onto_h1():
    pytest.importorskip("mink")
    clip = source_clip(None, 0.2)
    row = mink_peer.mink_throughput(clip, "h1")
    assert row["robot"] == "h1" and row["peer"] == "mink"
    assert row["frames"] == clip.num_frames
    assert row["frames_per_second"] > 0 and row["seconds"] > 0
    assert row["solves_per_frame"] >= 2  # two IK stages a frame
    # Measured 0.054 m on the 2 s walk (shoulders and chest: H1's torso is not a scaled human's).
    assert row["mean_position_error_m"] < 0.1


def test_end_to_end_adds_the_bridging_udh_stage_to_each_robot():
    rows = [
        {"robot": "udh", "hands": "none", "frames": 100, "seconds": 0.5, "bridge_seconds": 0.0},
        {"robot": "h1", "hands": "none", "frames": 100, "seconds": 1.5, "bridge_seconds": 0.5},
    ]
    assert end_to_end_frames_per_second(rows) == {("udh", "none"): 200.0, ("h1", "none"): 50.0}


def test_bench_retarget_reports_the_peer_and_the_speedup(capsys, no_pinning):
    pytest.importorskip("mink")
    assert bench.main(["retarget", "--hands", "none", "--seconds", "0.05", "--peer", "mink"]) == 0
    report = json.loads(capsys.readouterr().out)
    ours = end_to_end_frames_per_second(report["results"])
    assert [row["robot"] for row in report["peer"]] == [row["robot"] for row in report["results"]]
    for row in report["peer"]:
        assert row["frames"] == report["source"]["frames"] and row["frames_per_second"] > 0
        expected = ours[row["robot"], "none"] / row["frames_per_second"]
        assert report["speedup"][row["robot"]]["none"] == pytest.approx(expected, rel=0.01)


def test_bench_retarget_skips_the_peer_without_mink(capsys, monkeypatch, no_pinning):
    monkeypatch.setattr(mink_peer, "mink_available", lambda: False)
    assert bench.main(["retarget", "--hands", "none", "--seconds", "0.05", "--peer", "mink"]) == 0
    out, err = capsys.readouterr()
    skipped = [line for line in err.splitlines() if "--peer mink skipped" in line]
    assert len(skipped) == 1 and "pip install" in skipped[0]
    report = json.loads(out)
    assert report["results"] and "peer" not in report and "speedup" not in report


def test_bench_retarget_times_the_per_frame_path_in_the_same_run(capsys, no_pinning):
    assert bench.main(["retarget", "--hands", "none", "--seconds", "0.05", "--per-frame"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [row["robot"] for row in report["per_frame"]] == [row["robot"] for row in report["results"]]
    ours = end_to_end_frames_per_second(report["results"])
    for row in report["per_frame"]:
        expected = ours[row["robot"], "none"] / row["end_to_end_frames_per_second"]
        assert report["speedup_over_per_frame"][row["robot"]]["none"] == pytest.approx(expected, rel=0.01)
        assert row["joint_limit_violations"] == 0


def test_bench_retarget_alternates_pairs_with_the_peer(capsys, no_pinning):
    pytest.importorskip("mink")
    assert bench.main(["retarget", "--hands", "none", "--seconds", "0.05", "--peer", "mink", "--pairs", "2"]) == 0
    pairs = json.loads(capsys.readouterr().out)["pairs"]
    assert set(pairs) == {"udh", "naviai", "h1", "bruce", "walker", "curi"}
    for robot in pairs.values():
        row = robot["none"]
        assert len(row["ours"]) == len(row["peer"]) == 2
        ratios = sorted(a / b for a, b in zip(row["ours"], row["peer"]))
        assert row["median_speedup"] == pytest.approx(sum(ratios) / 2, rel=0.01)
