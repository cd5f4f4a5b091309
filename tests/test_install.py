"""A non-editable install (a built wheel) finds models/ and systems/."""

import os
import subprocess
import sys
import zipfile

from tests.conftest import REPO

CHECK = """
import hotu_drake, hotu_drake.resources as r
from hotu_drake.scenario import load_scenario
assert r.models_dir().is_relative_to(r.Path(hotu_drake.__file__).parent), r.models_dir()
assert r.model_path("h1", "none", "urdf").is_file()
print(load_scenario("stand_h1").embodiment, hotu_drake.__file__)
"""


def test_wheel_carries_models_and_systems(tmp_path):
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(tmp_path / "dist"), str(REPO)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stderr
    (wheel,) = (tmp_path / "dist").glob("hotu_drake-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "hotu_drake/_data/models/h1/h1_hands_none.sdf" in names
    assert "hotu_drake/_data/systems/stand.yaml" in names

    site = tmp_path / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--quiet", "--target", str(site), str(wheel)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert install.returncode == 0, install.stderr
    env = dict(os.environ, PYTHONPATH=str(site))
    result = subprocess.run(
        [sys.executable, "-c", CHECK], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("h1 ") and str(site) in result.stdout
