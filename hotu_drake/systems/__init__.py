"""Drake LeafSystems of the pipeline, each with named ports."""

from hotu_drake.systems.base_command import PlanarBaseCommand
from hotu_drake.systems.retargeting import RetargetingSystem

__all__ = ["PlanarBaseCommand", "RetargetingSystem"]
