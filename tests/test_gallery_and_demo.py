"""The demo: the DoF table and a self-contained gallery page of the six embodiments."""

import subprocess
import sys

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
    assert list(tmp_path.iterdir()) == [page]
