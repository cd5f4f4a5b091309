"""The demo: the DoF table and a self-contained gallery page of the six embodiments."""

import subprocess
import sys

import numpy as np
from pydrake.geometry import StartMeshcat

from hotu_drake import embodiment
from hotu_drake.gallery import render_gallery


def test_gallery_shows_all_six():
    meshcat = render_gallery(hands="none", meshcat=StartMeshcat())
    for name in embodiment.EMBODIMENT_NAMES:
        assert meshcat.HasPath(f"/drake/visualizer/{name}"), name
    html = meshcat.StaticHtml()
    assert html.lstrip().lower().startswith("<!doctype html") or "<html" in html[:500].lower()
    # Self-contained: no scripts fetched from elsewhere.
    assert 'src="http' not in html and "src='http" not in html


def test_demo_prints_the_table_and_writes_the_gallery(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "hotu_drake.demo", "--out", str(tmp_path)], capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stderr
    assert "udh" in result.stdout and "92" in result.stdout and "curi" in result.stdout
    page = tmp_path / "gallery.html"
    assert page.stat().st_size > 100_000
    legged = ("bruce", "h1", "naviai", "udh", "walker")
    perturbations = [f"perturb_{robot}.html" for robot in legged]
    learned = ["learned_bruce_squat.html", "learned_h1_upper_body.html", "learned_h1_walk.html", "learned_h1_wave.html"]
    # (systems/policies)
    walking = [f"whole_body_walk_{robot}.html" for robot in legged]  # systems/whole_body.yaml
    expected = sorted(["box_carry.html", "clips", "gallery.html", "walk.html", *perturbations, *learned, *walking])
    assert sorted(p.name for p in tmp_path.iterdir()) == expected
    for name in perturbations:
        assert (tmp_path / name).stat().st_size > 100_000
        assert f"cubes thrown at {name[8:-5]}, which stayed up" in result.stdout
    for name in learned:
        assert (tmp_path / name).stat().st_size > 100_000
        assert f"a learned policy ({name[:-5]}), which stayed up" in result.stdout
    for name in walking:  # (H1 and BRUCE fall: BENCHMARKS.md)
        assert (tmp_path / name).stat().st_size > 100_000
        assert f"under the whole-body controller ({name[:-5]}), which" in result.stdout
    for robot in ("naviai", "udh", "walker"):  # each walked from all six seeds measured
        assert f"under the whole-body controller (whole_body_walk_{robot}), which stayed up" in result.stdout
    clips = sorted(p.name for p in (tmp_path / "clips").iterdir())
    robots = ("bruce", "curi", "h1", "naviai", "udh", "walker")
    assert clips == sorted(f"{motion}_{robot}.npz" for motion in ("box_carry", "walk") for robot in robots)
    assert "box_carry retargeted onto udh, naviai, h1, bruce, walker, curi" in result.stdout


def _chromium() -> str | None:
    import shutil

    return shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


def test_gallery_renders_six_robots_in_a_browser(tmp_path):
    """Headless Chromium draws the page: six coloured figures on the floor."""
    import pytest

    browser = _chromium()
    if browser is None:
        pytest.skip("no Chromium on this machine")
    image_module = pytest.importorskip("PIL.Image")
    import numpy as np

    from hotu_drake.gallery import write_gallery

    page = write_gallery(tmp_path / "gallery.html", hands="full", meshcat=StartMeshcat())
    shot = tmp_path / "gallery.png"
    flags = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--window-size=1600,800",
        "--virtual-time-budget=20000",
        f"--screenshot={shot}",
    ]
    subprocess.run([browser, *flags, page.as_uri()], capture_output=True, timeout=180)
    if not shot.exists():
        pytest.skip("Chromium could not take a screenshot here")
    pixels = np.asarray(image_module.open(shot).convert("RGB"), dtype=float) / 255.0
    saturation = pixels.max(axis=2) - pixels.min(axis=2)
    coloured = saturation > 0.25  # the floor and sky are grey; parts are coloured
    assert coloured.mean() > 0.005
    # Six figures side by side: coloured columns form six groups across the width.
    columns = coloured[: int(0.75 * len(coloured))].any(axis=0)
    edges = np.flatnonzero(np.diff(columns.astype(int)) == 1)
    groups = len(edges) + int(columns[0])
    assert 6 <= groups <= 12  # a robot may split where its arms leave the body


def test_a_walk_replay_looks_along_the_whole_path():
    """A replay of a robot that walked 3.6 m along +x looks from the side at
    the middle of its path (Meshcat's own camera, at the origin, lost it
    after a few steps); one that stayed put keeps Meshcat's camera."""
    from hotu_drake.commands.demo import frame_travel

    class Camera:
        def __init__(self):
            self.poses = []

        def SetCameraPose(self, position, target):
            self.poses.append((np.asarray(position), np.asarray(target)))

    walked, stood = Camera(), Camera()
    frame_travel(walked, 3.6)
    frame_travel(stood, 0.1)
    ((position, target),) = walked.poses
    assert np.allclose(target[:2], [1.8, 0.0]) and position[0] == target[0]
    assert np.linalg.norm(position[:2] - target[:2]) >= 3.0  # far enough back to see both ends
    assert not stood.poses
