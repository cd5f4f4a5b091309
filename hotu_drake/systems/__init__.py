"""Drake LeafSystems of the pipeline, each with named ports."""

from hotu_drake.systems.base_command import PlanarBaseCommand

__all__ = ["PlanarBaseCommand"]
