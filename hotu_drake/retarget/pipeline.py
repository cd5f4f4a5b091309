"""Human -> UDH -> robots, as the method does it."""

from dataclasses import dataclass, field
from functools import lru_cache

from hotu_drake import embodiment
from hotu_drake.embodiment.spec import FINGERS
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.udh_skeleton import udh_landmarks
from hotu_drake.retarget.retargeter import Retargeter, RetargetOptions

ROBOTS: tuple[str, ...] = ("naviai", "h1", "bruce", "walker", "curi")


def has_fingers(clip: MotionClip) -> bool:
    """Whether a human clip tracks finger landmarks (or a UDH clip has finger joints)."""
    if clip.embodiment == "human":
        return any(f"left_{finger}_4" in clip.key_body_names for finger in FINGERS)
    return any(name.endswith("_index_0") for name in clip.joint_names)


@dataclass
class Stage:
    """One retargeting result, how long its solve took, and the support
    margins of its centre of pressure before and after the balance pass
    (per frame; none for a robot without legs)."""

    clip: MotionClip
    seconds: float
    margins: dict = field(default_factory=dict)


def to_udh(source: MotionClip, hands: str = "full", options: RetargetOptions | None = None) -> Stage:
    """Retarget a human clip onto the UDH. Without finger landmarks in the
    source, a full-hand UDH keeps its fingers at their standing pose."""
    import time

    if source.embodiment == "udh":
        return Stage(source, 0.0)
    udh = embodiment.load("udh", hands)
    start = time.perf_counter()
    retargeter = Retargeter(udh, set(source.key_body_names), options)
    clip = retargeter.retarget(source)
    return Stage(clip, time.perf_counter() - start, retargeter.margins)


def to_robot(udh_clip: MotionClip, robot: str, hands: str = "full", options: RetargetOptions | None = None) -> Stage:
    """Retarget a UDH clip onto one robot through the UDH's landmarks."""
    import time

    udh = embodiment.load("udh", "full" if has_fingers(udh_clip) else "none")
    landmarks = udh_landmarks(udh, udh_clip)
    target = embodiment.load(robot, hands)
    start = time.perf_counter()
    retargeter = Retargeter(target, set(landmarks), options)
    clip = retargeter.retarget_landmarks(landmarks, udh_clip.fps, udh_clip)
    return Stage(clip, time.perf_counter() - start, retargeter.margins)


@lru_cache(maxsize=32)
def library_clip(motion: str, robot: str, hands: str = "none") -> MotionClip:
    """A motion of the generated library on `robot` (or the UDH): the
    human demonstration retargeted through the UDH, cached per process
    (treat the returned clip as read-only)."""
    from hotu_drake.motion.library import generate

    source = generate(motion)
    if robot == "udh":
        return to_udh(source, hands).clip
    return to_robot(to_udh(source, "none").clip, robot, hands).clip
