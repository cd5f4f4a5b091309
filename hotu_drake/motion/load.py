"""Read any supported demonstration file into a `MotionClip`, by its suffix,
and check that what was read is a plausible human motion."""

from pathlib import Path

import numpy as np

from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.human import body_height, landmarks_of, torso_tilt

SUFFIXES = (".bvh", ".c3d", ".npz")
# What a captured person can be: a child to the tallest humans (standing
# height, metres), and how fast a root can move between frames (m/s; a
# sprinter peaks near 12).
HEIGHT_RANGE = (0.5, 2.6)
MAX_ROOT_SPEED = 15.0
# How far (degrees) the torso may lean from the up axis and still count as
# upright; a captured person is upright at some time, unless the capture is
# of lying or crawling or its up axis is wrong. A walk leans a few degrees,
# lifting a box (the library's box_carry) or landing a jump (CMU 01_01)
# almost 50; lying is near 90, upside down near 180.
MAX_UPRIGHT_TILT = 60.0


def load_motion(
    path: str | Path,
    skeleton_map=None,
    *,
    marker_set=None,
    up: str | None = None,
    check_plausible: bool = True,
) -> MotionClip:
    """A BVH or C3D demonstration (as a human clip) or a saved `.npz` clip
    (human or UDH) to retarget.

    `skeleton_map` (a YAML file or dict) names the BVH joints of each
    landmark when no built-in map fits; `marker_set` (a built-in name, a YAML
    file or a dict) the C3D markers (default: the built-in set that fits the
    file; `skeleton_map` is taken for it too, as before). `up` overrides the
    up axis found in the data. With `check_plausible`, a human clip must
    stand upright at some time, have a human height and a root that does not
    jump (`check_human_motion`).
    Bad input raises `ClipFormatError` naming the file.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise ClipFormatError(f"{path}: no such file")
    if suffix == ".bvh":
        from hotu_drake.motion.bvh import read_bvh

        clip = read_bvh(path, skeleton_map=skeleton_map, up=up)
    elif suffix == ".c3d":
        from hotu_drake.motion.c3d import load_c3d_clip

        clip = load_c3d_clip(path, marker_set=marker_set if marker_set is not None else skeleton_map, up=up)
    elif suffix == ".npz":
        clip = MotionClip.load(path)
        check_retargetable(clip, str(path))
    else:
        raise ClipFormatError(f"{path}: unsupported file type '{suffix}' (expected {', '.join(SUFFIXES)})")
    if check_plausible and clip.embodiment == "human":
        check_human_motion(clip, str(path))
    return clip


def check_retargetable(clip: MotionClip, where: str) -> None:
    """A clip retargeting can start from: a human clip (landmarks, no joints)
    or a UDH clip (the UDH's joints); `ClipFormatError` otherwise."""
    from hotu_drake import embodiment
    from hotu_drake.motion.human import HUMAN, LANDMARKS, check_coverage

    if clip.embodiment == HUMAN:
        if clip.joint_names:
            raise ClipFormatError(f"{where}: a human clip has no joints, this one has {len(clip.joint_names)}")
        unknown = [n for n in clip.key_body_names if n not in LANDMARKS]
        if unknown:
            raise ClipFormatError(f"{where}: a human clip's key bodies are landmarks, not {', '.join(unknown[:3])}")
        check_coverage(clip.key_body_names, where)
        return
    if clip.embodiment != "udh":
        raise ClipFormatError(f"{where}: a clip of {clip.embodiment!r}; retargeting starts from a human or UDH clip")
    joints = set(embodiment.load("udh", "full").joint_names)
    if not clip.joint_names or not set(clip.joint_names) <= joints:
        strange = sorted(set(clip.joint_names) - joints)[:3] or ["none at all"]
        raise ClipFormatError(
            f"{where}: labelled as a UDH clip, but its joints are not the UDH's ({', '.join(strange)})"
        )


def check_human_motion(clip: MotionClip, where: str) -> None:
    """A human clip stands upright in some frame, its skeleton is of human
    height and its root does not jump; `ClipFormatError` with the figure
    otherwise (`check_plausible=False`, the command lines'
    `--allow-implausible`, skips this for a capture that is meant to be so:
    lying down all along, a giant puppet, cuts between takes).

    Uprightness is checked first: a body laid down by a wrong up axis also
    has a wrong height, and the up axis is the mistake to name. It is what
    the height misses for a capture without legs (whose height is its arm
    span)."""
    points = landmarks_of(clip)
    segment, tilt = torso_tilt(points)
    if len(tilt) and not np.any(tilt <= MAX_UPRIGHT_TILT):
        least = float(np.min(tilt))
        how = "upside down" if least > 180.0 - MAX_UPRIGHT_TILT else "lying down"
        raise ClipFormatError(
            f"{where}: the body never stands upright: the torso ({segment}) leans {least:.0f} degrees or more "
            f"from the up axis in every frame (more than {MAX_UPRIGHT_TILT:g}; {how}): the wrong up axis (--up)? "
            "(--allow-implausible to use it anyway)"
        )
    height = body_height(points)
    if not HEIGHT_RANGE[0] <= height <= HEIGHT_RANGE[1]:
        raise ClipFormatError(
            f"{where}: the skeleton is {height:.3g} m tall, not a person ({HEIGHT_RANGE[0]}-{HEIGHT_RANGE[1]} m): "
            "wrong units? (--allow-implausible to use it anyway)"
        )
    if clip.num_frames > 1:
        steps = np.linalg.norm(np.diff(clip.root_position, axis=0), axis=1) * clip.fps
        worst = int(np.argmax(steps))
        if steps[worst] > MAX_ROOT_SPEED:
            raise ClipFormatError(
                f"{where}: the root jumps {steps[worst] / clip.fps:.3g} m between frames {worst} and {worst + 1} "
                f"({steps[worst]:.3g} m/s, more than {MAX_ROOT_SPEED:g}): a cut or a glitch? "
                "(--allow-implausible to use it anyway)"
            )
