"""The learning package sees robots only through the gymnasium API: it imports
no pydrake, and none of the robot-side packages (environments, systems,
diagrams), directly or through anything it imports."""

import ast
import subprocess
import sys
from pathlib import Path

LEARNING = Path(__file__).resolve().parents[1] / "hotu_drake" / "learning"
FORBIDDEN = ("pydrake", "hotu_drake.envs", "hotu_drake.systems", "hotu_drake.diagrams")


def _imported_names(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
    return names


def _forbidden(name: str) -> bool:
    return any(name == f or name.startswith(f + ".") for f in FORBIDDEN)


def test_no_learning_module_names_a_forbidden_import():
    offenders = {
        f"{path.relative_to(LEARNING)}: {name}"
        for path in LEARNING.rglob("*.py")
        for name in _imported_names(path)
        if _forbidden(name)
    }
    assert not offenders


def test_importing_every_learning_module_loads_no_forbidden_module():
    modules = [
        "hotu_drake.learning" + ("." + ".".join(p.relative_to(LEARNING).with_suffix("").parts)).replace(".__init__", "")
        for p in LEARNING.rglob("*.py")
    ]
    script = (
        "import importlib, sys\n"
        f"for name in {sorted(set(modules))!r}:\n"
        "    importlib.import_module(name)\n"
        f"print('\\n'.join(m for m in sys.modules if m.startswith({FORBIDDEN!r})))\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == ""


def test_the_rollout_worker_reaches_environments_by_id_only():
    from hotu_drake.learning.rollout import EnvSpec

    spec = EnvSpec("hotu_drake/Imitation-v0", {"robot": "bruce"})
    assert spec.module == "hotu_drake.envs"  # imported by name in the worker, not by the learning code
