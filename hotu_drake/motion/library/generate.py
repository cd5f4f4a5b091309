"""Generating the library: each motion planned, realised on the UDH, and turned into a clip."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from functools import lru_cache
from pathlib import Path

import numpy as np

from hotu_drake import embodiment
from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.kinematics import batch_center_of_mass, batch_link_poses
from hotu_drake.embodiment.spec import SIDES
from hotu_drake.errors import InputError, check_number
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import human_clip
from hotu_drake.motion.library.gestures import boxing, finger_motions, handshake, kungfu, slap, thumbs_up, wave
from hotu_drake.motion.library.grasps import hand_grasp
from hotu_drake.motion.library.locomotion import jump, leg_stretch, squat, walk
from hotu_drake.motion.library.object_tasks import box_carry, box_carry_task, drill_grasp, drill_grasp_task
from hotu_drake.motion.library.planning import (
    Scene,
)
from hotu_drake.motion.library.steering import VOCABULARY
from hotu_drake.motion.synthesis import (
    Body,
    Plan,
    realize,
)
from hotu_drake.motion.udh_skeleton import udh_landmarks
from hotu_drake.rotations import finite_difference, matrix_to_quat

MOTIONS: tuple[str, ...] = (
    "walk",
    "jump",
    "squat",
    "leg_stretch",
    "boxing",
    "finger_motions",
    "handshake",
    "kungfu",
    "wave",
    "slap",
    "thumbs_up",
    "box_carry",
    "drill_grasp",
    *VOCABULARY,  # the steering vocabulary (`steering`)
    # A task's demonstrations, one per seed (`box_carry_task@7`): drawn from the task environment's ranges.
    "box_carry_task",
    "drill_grasp_task",
    # The grasp set (`grasps`), one grasp per seed (`hand_grasp@3`): hand-only data for the hand group.
    "hand_grasp",
)
# Nominal durations (s); `duration=` stretches or shortens a motion.
DURATIONS: dict[str, float] = {
    "walk": 4.4,
    "jump": 2.6,
    "squat": 4.6,
    "leg_stretch": 7.0,
    "boxing": 4.6,
    "finger_motions": 6.0,
    "handshake": 4.2,
    "kungfu": 7.4,
    "wave": 4.0,
    "slap": 3.0,
    "thumbs_up": 3.6,
    "box_carry": 11.8,
    "drill_grasp": 5.4,
    "walk_fast": 4.0,
    "walk_turn_left": 4.6,
    "walk_turn_right": 4.6,
    "turn_in_place_left": 4.0,
    "turn_in_place_right": 4.0,
    "sidestep_left": 6.0,
    "sidestep_right": 6.0,
    "walk_backward": 4.4,
    "start_stop": 5.2,
    "box_carry_task": 11.0,
    "drill_grasp_task": 4.2,
    "hand_grasp": 6.0,
}
CONTACT_HEIGHT = 0.01  # m: a sole this close to the floor ...
CONTACT_SPEED = 0.1  # m/s: ... and moving this slowly is in contact


@lru_cache(maxsize=1)
def _default_udh() -> Embodiment:
    return embodiment.load("udh", hands="full")


_PLANNERS: dict[str, Callable[[Scene], Plan]] = {
    "walk": walk,
    "jump": jump,
    "squat": squat,
    "leg_stretch": leg_stretch,
    "boxing": boxing,
    "finger_motions": finger_motions,
    "handshake": handshake,
    "kungfu": kungfu,
    "wave": wave,
    "slap": slap,
    "thumbs_up": thumbs_up,
    "box_carry": box_carry,
    "drill_grasp": drill_grasp,
    **VOCABULARY,
    "box_carry_task": box_carry_task,
    "drill_grasp_task": drill_grasp_task,
    "hand_grasp": hand_grasp,
}


def _foot_contacts(udh: Embodiment, body: Body, poses: dict, fps: float) -> dict[str, np.ndarray]:
    """Floor contact per foot: sole within 1 cm of the floor and the foot
    (its link origin, the ankle) moving slowly, so a foot rolling onto its
    toes to push off is already out of contact."""
    out = {}
    for side in SIDES:
        rot, pos = poses[udh.key_bodies[f"{side}_foot"]]
        points = pos[:, None, :] + np.einsum("tij,kj->tki", rot, body.foot_points)
        height = points[..., 2].min(axis=1) - body.foot_radius
        speed = np.linalg.norm(finite_difference(pos, fps), axis=1)
        out[f"{side}_foot"] = (height < CONTACT_HEIGHT) & (speed < CONTACT_SPEED)
    return out


def _grounded(left: np.ndarray, right: np.ndarray) -> dict[str, np.ndarray]:
    """Foot contacts with a foot down on every frame after the first: where
    neither is, the feet down on the frame before stay down (the contact
    test lets a foot go as its ankle speeds up, while its toes still push
    off the floor: the fast walk's heels rise quickly enough to leave
    frames with no foot down, a run's flight, which a walk has not)."""
    left, right = left.copy(), right.copy()
    for t in range(1, len(left)):
        if not left[t] and not right[t]:
            left[t], right[t] = left[t - 1], right[t - 1]
    return {"left_foot": left, "right_foot": right}


CENTRING_PASSES = 4  # `_centred`: each pass leaves the share of the error the legs carry (about a third)
UPPER_BODY_SHARE = 0.65  # about the share of the UDH's mass that moves with its pelvis when the feet stay put


def _centred(udh: Embodiment, body: Body, plan: Plan) -> np.ndarray:
    """`plan` realised with its pelvis moved (in x and y) until the centre of
    mass sits over the middle of the two soles on every frame; the hands'
    targets stay where they are in the world (the arms reach further)."""
    soles = np.mean([pos + rot @ body.foot_points.mean(axis=0) for pos, rot in plan.feet.values()], axis=0)
    for _ in range(CENTRING_PASSES):
        q = realize(body, plan)
        poses = batch_link_poses(udh.spec, udh.joint_names, q, plan.pelvis_rot, plan.pelvis)
        error = batch_center_of_mass(poses, udh.spec)[:, :2] - soles[:, :2]
        plan.pelvis[:, :2] -= error / UPPER_BODY_SHARE
    return realize(body, plan)


def _to_clip(udh: Embodiment, body: Body, plan: Plan, name: str) -> MotionClip:
    q = _centred(udh, body, plan) if plan.centred else realize(body, plan)
    fps = plan.fps
    quat = matrix_to_quat(plan.pelvis_rot)
    poses = batch_link_poses(udh.spec, udh.joint_names, q, plan.pelvis_rot, plan.pelvis)
    key_links = list(udh.key_bodies.values())
    contacts = _foot_contacts(udh, body, poses, fps) | plan.contacts
    if plan.grounded:
        contacts |= _grounded(contacts["left_foot"], contacts["right_foot"])
    objects = list(plan.objects)
    return MotionClip.from_positions(
        "udh",
        f"hotu_drake/library/{name}",
        fps,
        udh.joint_names,
        q,
        plan.pelvis.copy(),
        quat,
        key_links,
        np.stack([poses[link][1] for link in key_links], axis=1),
        part_index={part: list(joints) for part, joints in udh.parts.items()},
        object_names=objects,
        object_poses=np.stack([plan.objects[o] for o in objects], axis=1) if objects else None,
        contact_names=list(contacts),
        contacts=np.stack(list(contacts.values()), axis=1),
    )


def split_motion_name(name: str, seed: int = 0) -> tuple[str, int]:
    """A library name with an instance seed (`box_carry_task@7`: the motion
    `box_carry_task` drawn with seed 7) as (name, seed); a plain name keeps `seed`."""
    if "@" not in name:
        return name, seed
    base, _, instance = name.partition("@")
    if not instance.isdigit():
        raise InputError(f"{name!r}: the part after @ must be a whole number (a seed)", field="name")
    return base, int(instance)


def is_library_motion(name: str) -> bool:
    """Whether `name` names a library motion (with or without an instance seed)."""
    try:
        return split_motion_name(name)[0] in _PLANNERS
    except InputError:
        return False


def generate_udh(
    name: str, *, seed: int = 0, fps: float = 30.0, duration: float | None = None, udh: Embodiment | None = None
) -> MotionClip:
    """The library motion `name` on the UDH (92 joints with full hands).

    `seed` varies step lengths, timings and object placements (the same
    seed gives identical arrays); `duration` (s) stretches the motion.
    """
    label = name
    name, seed = split_motion_name(name, seed)
    if name not in _PLANNERS:
        raise InputError(f"unknown motion {name!r}; choose from {', '.join(MOTIONS)}", field="name")
    fps = check_number(fps, "fps", name, low=1.0, high=1000.0, unit="Hz")
    nominal = DURATIONS[name]
    duration = nominal if duration is None else duration
    duration = check_number(duration, "duration", name, low=0.5 * nominal, high=3.0 * nominal, unit="s")
    udh = _default_udh() if udh is None else udh
    if udh.name != "udh":
        raise ValueError("the library is generated on the UDH")
    body = Body.of(udh)
    scene = Scene(body, float(fps), duration, duration / nominal, np.random.default_rng(seed))
    return _to_clip(udh, body, _PLANNERS[name](scene), label)


def generate(name: str, *, seed: int = 0, fps: float = 30.0, duration: float | None = None) -> MotionClip:
    """The library motion `name` as a human demonstration (landmarks, objects, contacts)."""
    udh = _default_udh()
    clip = generate_udh(name, seed=seed, fps=fps, duration=duration, udh=udh)
    return human_clip(
        udh_landmarks(udh, clip),
        clip.fps,
        source=f"hotu_drake/library/{name}",
        object_names=clip.object_names,
        object_poses=clip.object_poses,
        contact_names=clip.contact_names,
        contacts=clip.contacts,
    )


def generate_library(out_dir: str | Path, names: Iterable[str] = MOTIONS, seed: int = 0) -> list[Path]:
    """Write `<name>.npz` human clips for `names` into `out_dir`; returns the paths."""
    out_dir = Path(out_dir)
    return [generate(name, seed=seed).save(out_dir / f"{name}.npz") for name in names]
