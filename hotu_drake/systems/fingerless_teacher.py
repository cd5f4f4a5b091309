"""A whole-body controller for a robot with fingers, solved without them.

A hand's fingers weigh grams, and nothing of the whole-body QP's balance
depends on them, but the UDH's 58 finger joints are most of its
variables: a teacher query on a grasp clip took 2.3 ms, against 1.1 ms
on the UDH without fingers (BENCHMARKS.md). `FingerlessTeacher` solves
the QP of the same robot with rigid hands (`hands="none"`, the clip's
fingers left out), each hand as heavy as the hand and fingers it stands
for (`lumped_hands`; lighter, the arm sagged and the objects rose 1-2 cm
less), and asks each finger for the clip's position at that time, as a
policy's PD target: 1.3 ms a query, the same grasps held. It answers what
the environments ask of a teacher (`act`, `reset`, and the plan,
reference and footing their reference observation is read from).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from hotu_drake import embodiment as embodiments
from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.actions import ActionScaling
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.systems.whole_body import WholeBodyController


def has_fingers(embodiment: Embodiment) -> bool:
    """Whether `embodiment` has joints its rigid-handed variant does not (its fingers)."""
    if embodiment.hands == "none":
        return False
    return len(embodiments.load(embodiment.name, "none").joint_names) < len(embodiment.joint_names)


def lumped_hands(embodiment: Embodiment) -> Embodiment:
    """`embodiment`'s rigid-handed variant, each hand's link as heavy as
    the hand and all it carries in `embodiment` (its fingers)."""
    body = embodiments.load(embodiment.name, "none")
    children: dict[str, list[str]] = {}
    for joint in embodiment.spec.joints:
        children.setdefault(joint.parent, []).append(joint.child)
    masses = {link.name: link.mass for link in embodiment.spec.links}

    def carried(link: str) -> float:
        return masses[link] + sum(carried(child) for child in children.get(link, []))

    hands = {embodiment.key_bodies[f"{side}_hand"] for side in ("left", "right")}
    links = [
        dataclasses.replace(link, mass=carried(link.name)) if link.name in hands else link for link in body.spec.links
    ]
    return Embodiment(dataclasses.replace(body.spec, links=links))


def _body_clip(clip: MotionClip, joints: list[str]) -> MotionClip:
    """`clip` with only the joints `joints` (in that order)."""
    columns = [clip.joint_names.index(name) for name in joints]
    parts = {part: [j for j in names if j in joints] for part, names in clip.part_index.items()}
    return dataclasses.replace(
        clip,
        joint_names=list(joints),
        joint_positions=clip.joint_positions[:, columns],
        joint_velocities=clip.joint_velocities[:, columns],
        part_index={part: names for part, names in parts.items() if names},
    )


def _state_columns(full: MultibodyPlant, body: MultibodyPlant) -> np.ndarray:
    """Where each entry of `body`'s [q; v] is in `full`'s (joints matched by name)."""
    q = np.zeros(body.num_positions(), int)
    v = np.zeros(body.num_velocities(), int)
    for index in body.GetJointIndices():
        joint = body.get_joint(index)
        theirs = full.GetJointByName(joint.name())
        for k in range(joint.num_positions()):
            q[joint.position_start() + k] = theirs.position_start() + k
        for k in range(joint.num_velocities()):
            v[joint.velocity_start() + k] = theirs.velocity_start() + k
    return np.r_[q, full.num_positions() + v]


class FingerlessTeacher:
    """The whole-body controller of `embodiment`'s body (see the module),
    with `WholeBodyController`'s arguments."""

    def __init__(
        self,
        embodiment: Embodiment,
        clip: MotionClip,
        control_period: float,
        loop: bool = True,
        plant_step: float | None = None,
    ):
        body = lumped_hands(embodiment)
        self.embodiment = embodiment
        self.controller = WholeBodyController(
            body, _body_clip(clip, body.joint_names), control_period, loop, None, 0.0, plant_step
        )
        full = MultibodyPlant(0.0)
        embodiment.add_to_plant(full, builtin_pd=False)
        full.Finalize()
        self._columns = _state_columns(full, self.controller.plant)
        self._body_joints = np.array([embodiment.joint_names.index(name) for name in body.joint_names])
        self._fingers = np.setdiff1d(np.arange(len(embodiment.joint_names)), self._body_joints)
        self._playback = ClipPlayback(clip, loop)
        self._clip_order = np.array([clip.joint_names.index(name) for name in embodiment.joint_names])
        self._scaling = ActionScaling.for_embodiment(embodiment)

    @property
    def plan(self):
        return self.controller.plan

    @property
    def plant(self) -> MultibodyPlant:
        """The body's plant (rigid hands) the QP is solved on."""
        return self.controller.plant

    @property
    def reference_context(self):
        return self.controller.reference_context

    @property
    def footing_shift(self) -> np.ndarray:
        return self.controller.footing_shift

    def reset(self) -> None:
        self.controller.reset()

    def act(self, x: np.ndarray, time: float) -> np.ndarray:
        """The action for `embodiment`'s state `x` ([q; v]) at `time`: the
        body's from its QP, each finger's the clip's position then."""
        action = np.empty(len(self.embodiment.joint_names))
        action[self._body_joints] = self.controller.act(np.asarray(x)[self._columns], time)
        positions = self._playback.joints_at(time)[0][self._clip_order]
        action[self._fingers] = np.clip(self._scaling.to_action(positions)[self._fingers], -1.0, 1.0)
        return action
