"""Where the repository's `models/` and `systems/` folders are.

From a clone (or an editable install) they sit beside the package; a wheel
carries copies inside the package as `hotu_drake/_data/`.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def _find(name: str) -> Path:
    for candidate in (_PACKAGE / "_data" / name, _PACKAGE.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"hotu_drake: cannot find the '{name}' folder (looked in the package and beside it)")


def models_dir() -> Path:
    """The folder of generated robot models and object models."""
    return _find("models")


def systems_dir() -> Path:
    """The folder of scenario YAML files (`scenario.shipped_scenarios` names them)."""
    return _find("systems")


def model_path(name: str, hands: str, fmt: str) -> Path:
    """Path of a checked-in model file, e.g. models/h1/h1_hands_none.urdf."""
    from hotu_drake.embodiment.embodiment import EXPORT_SUFFIX

    return models_dir() / name / f"{name}_hands_{hands}{EXPORT_SUFFIX[fmt]}"
