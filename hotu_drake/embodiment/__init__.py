"""Embodiments: the unified digital human and the five humanoid robots.

>>> from hotu_drake import embodiment
>>> h1 = embodiment.load("h1", hands="none")
>>> h1.part_dof["total"]
25
"""

from hotu_drake.embodiment.embodiment import (
    EMBODIMENT_NAMES,
    EXPORT_FORMATS,
    HANDS_VARIANTS,
    Embodiment,
    build_spec,
    load,
)
from hotu_drake.embodiment.spec import PARTS

__all__ = [
    "EMBODIMENT_NAMES",
    "EXPORT_FORMATS",
    "HANDS_VARIANTS",
    "PARTS",
    "Embodiment",
    "build_spec",
    "load",
]
