"""Read any supported demonstration file into a `MotionClip`, by its suffix."""

from pathlib import Path

from hotu_drake.motion.clip import ClipFormatError, MotionClip

SUFFIXES = (".bvh", ".c3d", ".npz")


def load_motion(path: str | Path, skeleton_map=None) -> MotionClip:
    """A BVH or C3D demonstration (as a human clip) or a saved `.npz` clip.

    `skeleton_map` (a YAML file or dict) names the BVH joints or C3D markers
    of each landmark when no built-in map fits.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise ClipFormatError(f"{path}: no such file")
    if suffix == ".bvh":
        from hotu_drake.motion.bvh import read_bvh

        return read_bvh(path, skeleton_map=skeleton_map)
    if suffix == ".c3d":
        from hotu_drake.motion.c3d import load_c3d_clip

        return load_c3d_clip(path, marker_set=skeleton_map)
    if suffix == ".npz":
        return MotionClip.load(path)
    raise ClipFormatError(f"{path}: unsupported file type '{suffix}' (expected {', '.join(SUFFIXES)})")
