"""Read any supported demonstration file into a `MotionClip`, by its suffix,
and check that what was read is a plausible human motion."""

import logging
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
# m/s: no part of a person moves faster than this from one frame to the next (a pitcher's hand peaks near
# 40). A frame at a capture's start or end from which a landmark jumps faster is not of the take: a BVH
# conversion's T-pose first frame (CMU 01_01's wrists jump 0.55 m, at 65 m/s, to its second) is dropped,
# at most `MOST_TRIMMED` frames at each end, and said in a `note:` line.
MAX_LANDMARK_SPEED = 40.0
MOST_TRIMMED = 5

log = logging.getLogger("hotu_drake.input")


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
    if clip.embodiment == "human":
        clip = without_jumping_ends(clip, str(path))
        if check_plausible:
            check_human_motion(clip, str(path))
    return clip


def without_jumping_ends(clip: MotionClip, where: str) -> MotionClip:
    """The human clip without the frames at its start and end from which a
    landmark jumps faster than `MAX_LANDMARK_SPEED` (at most `MOST_TRIMMED`
    at each end; a clip that would keep fewer than two frames is left as it
    is), said on the `hotu_drake.input` logger."""
    if clip.num_frames < 3:
        return clip
    points = np.stack(list(landmarks_of(clip).values()), axis=1)  # (T, L, 3)
    with np.errstate(invalid="ignore"):
        # (T - 1, L), NaN where a landmark is missing
        jumps = np.linalg.norm(np.diff(points, axis=0), axis=-1) * clip.fps
        fastest = np.max(np.where(np.isnan(jumps), 0.0, jumps), axis=1)
    start, stop = 0, clip.num_frames
    while start < MOST_TRIMMED and fastest[start] > MAX_LANDMARK_SPEED:
        start += 1
    while clip.num_frames - stop < MOST_TRIMMED and stop - 2 > start and fastest[stop - 2] > MAX_LANDMARK_SPEED:
        stop -= 1
    if (start, stop) == (0, clip.num_frames) or stop - start < 2:
        return clip
    ends = [f"its first {start}"] if start else []
    ends += [f"its last {clip.num_frames - stop}"] if stop < clip.num_frames else []
    log.info(
        f"{where}: {' and '.join(ends)} frame(s) dropped: a landmark jumps from them at "
        f"{max(fastest[:start].max(initial=0.0), fastest[stop - 1 :].max(initial=0.0)):.0f} m/s "
        f"(more than {MAX_LANDMARK_SPEED:g}; not of the take, a T-pose or a glitch)"
    )
    return clip.slice(start, stop)


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
