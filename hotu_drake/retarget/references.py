"""Reference clips on an embodiment, for scenarios to track and environments to imitate.

A motion is a name from the generated library (retargeted human -> UDH ->
robot) or a path to a `.npz` clip of the embodiment. Retargeting a library
motion takes seconds, so results are cached on disk, keyed by the source
of the code that produces them (a change to the library or the retargeter
makes a new key): `$HOTU_DRAKE_CACHE`, else `~/.cache/hotu_drake`.
"""

import hashlib
import os
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path

from hotu_drake.embodiment import Embodiment
from hotu_drake.errors import InputError
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.library import MOTIONS, is_library_motion
from hotu_drake.retarget.pipeline import library_clip

_PACKAGE = Path(__file__).resolve().parent.parent


def cache_dir() -> Path:
    return Path(os.environ.get("HOTU_DRAKE_CACHE", Path.home() / ".cache" / "hotu_drake"))


@lru_cache(maxsize=1)
def _code_key() -> str:
    """A digest of the sources that shape a retargeted library clip."""
    digest = hashlib.sha256()
    sources = [_PACKAGE / "motion", _PACKAGE / "retarget", _PACKAGE / "embodiment"]
    for folder in sources:
        for path in sorted(folder.rglob("*.py")):
            digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def library_clip_cached(motion: str, embodiment: Embodiment) -> MotionClip:
    """`motion` of the generated library on `embodiment`, from the disk cache if there."""
    path = cache_dir() / "clips" / _code_key() / f"{embodiment.name}_{embodiment.hands}_{motion}.npz"
    if path.is_file():
        try:
            return MotionClip.load(path)
        except ClipFormatError:
            pass  # a damaged cache entry: make it again
    clip = library_clip(motion, embodiment.name, embodiment.hands)
    try:
        clip.save(path)  # atomic: parallel workers may race here harmlessly
    except OSError:
        pass  # a read-only home still works, just slower
    return clip


def reference_clip(motion: str, embodiment: Embodiment, base_dir: str | Path | None = None) -> MotionClip:
    """One motion on `embodiment`; a relative clip path is taken from `base_dir`.
    Raises `InputError` for a name that is neither, or a clip of another embodiment."""
    if is_library_motion(motion):
        clip = library_clip_cached(motion, embodiment)
    else:
        path = Path(motion).expanduser()
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        if path.suffix != ".npz" or not path.is_file():
            raise InputError(f"{path}: not a library motion ({', '.join(MOTIONS)}) nor a .npz clip")
        clip = MotionClip.load(path)
    if list(clip.joint_names) != list(embodiment.joint_names):
        raise InputError(f"{motion}: a clip for '{clip.embodiment}', not {embodiment.name} hands={embodiment.hands}")
    return clip


def motion_list(motions: Iterable[str] | str | None = None) -> list[str]:
    """`motions` as a list of names and clip paths (one given alone, or the
    whole generated library for None); `InputError` for anything else."""
    if isinstance(motions, str | Path):
        return [str(motions)]
    if motions is None:
        return list(MOTIONS)
    if not isinstance(motions, list | tuple) or not all(isinstance(m, str | Path) for m in motions):
        raise InputError(f"{motions!r}: give motion names or .npz clip paths", field="motions")
    return [str(m) for m in motions]


def reference_clips(embodiment: Embodiment, motions: Iterable[str] | str | None = None) -> list[MotionClip]:
    """The clips for `motions` (`motion_list`: default the whole generated library)."""
    clips = [reference_clip(motion, embodiment) for motion in motion_list(motions)]
    if not clips:
        raise InputError("motions: give at least one motion")
    return clips


def motion_key(motion: str | Path) -> str:
    """How a motion is compared with another: a library name as it is, a clip by its resolved path."""
    motion = str(motion)
    return str(Path(motion).expanduser().resolve()) if motion.endswith(".npz") else motion


def looped_motions(loop: bool | Iterable[str], motions: Iterable[str], where: str = "loop") -> list[bool]:
    """Which of `motions` repeat under a `loop` setting: all (True), none
    (False), or those it names (a walk repeats, a squat need not). A named
    motion not among `motions` raises `InputError`."""
    motions = [motion_key(m) for m in motions]
    if isinstance(loop, bool):
        return [loop] * len(motions)
    if isinstance(loop, str | Path) or not all(isinstance(m, str | Path) for m in loop):
        raise InputError(f"{loop!r}: give true, false or a list of the motions that repeat", field=where)
    named = {motion_key(m) for m in loop}
    unknown = sorted(named - set(motions))
    if unknown:
        raise InputError(f"{', '.join(unknown)}: not among the motions ({', '.join(motions)})", field=where)
    return [m in named for m in motions]
