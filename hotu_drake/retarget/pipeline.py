"""Human -> UDH -> robots, as the method does it."""

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
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
    """One retargeting result, how long its solve took (`seconds`; the
    retargeter's set-up for the embodiment, its model and neutral pose, in
    `setup_seconds`, as a peer's model building is apart from its solve),
    and the support margins of its centre of pressure before and after the
    balance pass (per frame; none for a robot without legs)."""

    clip: MotionClip
    seconds: float
    margins: dict = field(default_factory=dict)
    setup_seconds: float = 0.0
    bridge: "Stage | None" = None  # a robot's: the UDH stage it was retargeted through (`retarget_onto`)

    @property
    def total_seconds(self) -> float:
        """Human -> this embodiment: the stage's solve and its bridge's."""
        return self.seconds + (self.bridge.seconds if self.bridge else 0.0)

    @property
    def total_setup_seconds(self) -> float:
        return self.setup_seconds + (self.bridge.setup_seconds if self.bridge else 0.0)


def to_udh(
    source: MotionClip, hands: str = "full", options: RetargetOptions | None = None, bridge: bool = False
) -> Stage:
    """Retarget a human clip onto the UDH. Without finger landmarks in the
    source, a full-hand UDH keeps its fingers at their standing pose.

    `bridge`: the clip only carries the motion on to robots (`to_robot`),
    so the UDH's own balance pass is left out: each robot's pass shifts its
    own body over its own feet, with its own mass. (Measured over the
    library and the captures: the robots' centres of pressure as far
    inside their support within 0.02, their feet skating less; the UDH
    stage in 60% of its time.)"""
    import time

    if source.embodiment == "udh":
        return Stage(source, 0.0)
    if bridge:
        options = replace(options or RetargetOptions(), balance=False)
    udh = embodiment.load("udh", hands)
    start = time.perf_counter()
    retargeter = Retargeter(udh, set(source.key_body_names), options)
    built = time.perf_counter()
    clip = retargeter.retarget(source)
    return Stage(clip, time.perf_counter() - built, retargeter.margins, built - start)


def to_robot(udh_clip: MotionClip, robot: str, hands: str = "full", options: RetargetOptions | None = None) -> Stage:
    """Retarget a UDH clip onto one robot through the UDH's landmarks."""
    import time

    udh = embodiment.load("udh", "full" if has_fingers(udh_clip) else "none")
    landmarks = udh_landmarks(udh, udh_clip)
    target = embodiment.load(robot, hands)
    start = time.perf_counter()
    retargeter = Retargeter(target, set(landmarks), options)
    built = time.perf_counter()
    clip = retargeter.retarget_landmarks(landmarks, udh_clip.fps, udh_clip)
    return Stage(clip, time.perf_counter() - built, retargeter.margins, built - start)


@lru_cache(maxsize=32)
def library_clip(motion: str, robot: str, hands: str = "none", pace: str = "auto") -> MotionClip:
    """A motion of the generated library on `robot` (or the UDH): the
    human demonstration retargeted through the UDH at `pace`
    (`RetargetOptions.pace`), cached per process (treat the returned clip
    as read-only)."""
    from hotu_drake.motion.library import generate

    options = RetargetOptions(pace=pace)
    return retarget_onto(generate(motion), [robot], hands, options, bridge_hands="none")[robot].clip


def retarget_onto(
    source: MotionClip,
    robots: Iterable[str],
    hands: str = "full",
    options: RetargetOptions | None = None,
    bridge_hands: str | None = None,
    done: Callable[[str], None] | None = None,
) -> dict[str, Stage]:
    """A human clip on each of `robots` (the UDH among them or not): the
    UDH's own clip where asked for, and every robot's through one UDH clip
    that only bridges to them (`to_udh(..., bridge=True)`; its hands
    `bridge_hands`, by default `hands`, or none where no robot has fingers
    to take from it), by name; a robot's stage keeps the bridge's
    (`Stage.bridge`). `done` is told each robot's name as its clip is
    ready."""
    robots = list(robots)
    out = {}
    if "udh" in robots:
        out["udh"] = to_udh(source, hands, options)
        if done:
            done("udh")
    others = [robot for robot in robots if robot != "udh"]
    if others:
        if bridge_hands is None:
            fingered = hands == "full" and any(embodiment.load(robot, hands).finger_joints for robot in others)
            bridge_hands = hands if fingered else "none"
        bridge = to_udh(source, bridge_hands, options, bridge=True)
        for robot in others:
            out[robot] = replace(to_robot(bridge.clip, robot, hands, options), bridge=bridge)
            if done:
                done(robot)
    return out
