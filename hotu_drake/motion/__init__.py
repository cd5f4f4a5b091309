"""Demonstrations: the `MotionClip` type and format, readers of BVH, C3D and
OptiTrack files, the human landmark skeleton, and the procedural library."""

from hotu_drake.motion.clip import ClipFormatError, MotionClip

__all__ = ["ClipFormatError", "MotionClip"]
