"""Footing: which feet a robot stands on as its clip goes, and where they stand against the clip's.

A clip is tracked from where the robot's feet actually landed, not from
where the clip put them: a step placed off the clip's footprint (to
catch the CoM) carries the CoM's and the next step's targets along. The
offset, the footing shift, is the planted feet's mean offset from the
clip's (horizontal), eased toward each new stance so that a stance handed
to a foot that landed elsewhere is no jump.

The whole-body controller keeps its clip where this says
(`systems.whole_body`); a policy that observes the reference
(`systems.motion_reference`) sees it placed the same way, without the
controller's QP.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context

from hotu_drake.control.clip_plan import ClipPlan
from hotu_drake.control.whole_body_qp import Sole

TOUCHING = 0.01  # m: a sole with a corner this close to the floor is down
# m: a foot the clip has lifted pushes off on its toes while, early in its swing, the clip's sole is pitched
# over an edge (its other corners `TOE_PITCH` higher) whose corners (those within `TOE_BAND` of its lowest)
# are within `TOE_DOWN` of the floor. The clips' contacts end as the heel rises (`_foot_contacts`), so a walk
# switched its support from foot to foot within a frame and the trailing foot lifted flat: no push-off.
# Over the first `TOE_SWING` of the swing (its share of the clip's frames up).
TOE_DOWN, TOE_BAND, TOE_PITCH, TOE_SWING = 0.005, 0.005, 0.01, 0.5
# m: a foot the clip has down stands on its toes (held on that edge, as pushing off) where the clip has its sole
# pitched over an edge on the floor with its other corners this much higher: the back foot of a lunge, its
# heel up and its ball down (leg_stretch). Held flat there, NAVIAI falls in three starts of four, on its toes
# in none (the UDH fell in three of four held flat before its clip kept the pressure within one ankle's reach on
# one foot, `balance.ANKLE_ALONE`; now it and Walker stand either way). At 2-4 cm a capture's rolling feet were
# held on their toes too (the UDH's Qualisys walk 0/4, 1/4 before; 2/4 at 6 cm).
PLANTED_TOE_PITCH = 0.06
# A foot the clip lifts flat (H1's: its leg cannot reach the floor at the person's push-off) pushes off
# all the same for `PUSH_OFF_TIME` (s) after the clip lifts it (a 30 fps clip's first frame up) while the
# other foot is down, if it is going at least `PUSH_OFF_STEP` (m) to its next footstep: on its edge toward it
# (the corners within `PUSH_OFF_EDGE` (m) of the furthest that way: its toes walking forward, its heel
# walking backwards, its left edge stepping to the left).
PUSH_OFF_TIME, PUSH_OFF_STEP, PUSH_OFF_EDGE = 0.05, 0.05, 0.02
FOOTING_EASING = 0.6  # s: the time constant over which the tracked clip moves to where the feet stand
# s: the same for a robot on line feet. A line cannot move its pressure across, so a stance foot that landed
# off the clip's footprint must carry the plan with it within its own stance: BRUCE's stance lasts 0.3 s, and at
# 0.6 its plan kept asking for pressure 1-2.5 cm outside the foot it stood on (the looped walk fell at a stop in
# 4 of 10 seeds). At 0.1: 10 of 10; 0.05, 0.15: 10 of 10 too, eight motions from ten starts 72 and 71 of 80
# against 73 (69 at 0.6).
LINE_FOOTING_EASING = 0.1


class Footing:
    """The feet a robot stands on at a clip time and the clip's footing
    shift, for the robot alone in `plant` (its contexts: the robot's
    measured state, the reference's set by `plan.set_reference`), its
    `soles` (`whole_body_qp.feet_soles`), updated every `period` s."""

    def __init__(self, plant: MultibodyPlant, plan: ClipPlan, soles: dict[str, Sole], period: float):
        self.plan, self.soles, self.period = plan, soles, period
        self._plant = plant
        self._nearby = plant.CreateDefaultContext()  # scratch: the reference at another time (`pushing_off`)
        on_lines = bool(soles) and all(sole.is_line for sole in soles.values())
        self.easing = LINE_FOOTING_EASING if on_lines else FOOTING_EASING

    def planted(self, robot: Context, time: float, pushing: dict[str, np.ndarray]) -> dict[str, bool]:
        """The soles the robot (its state in `robot`) stands on at `time`:
        those the clip has down that are down (a corner within `TOUCHING` of
        the floor). A foot the clip has landed that is still in the air
        stays a swing foot, drawn to its footstep on the floor; held still
        as planted it would hover (the robots that fell at the end of the
        walk stood on one leg, the other 3 cm up). A foot pushing off
        (`pushing`: `pushing_off`) is down if the corners it pushes off on
        are."""
        out = {}
        for name, down in self.plan.planted(time).items():
            sole = self.soles.get(name)
            if sole is not None and (down or name in pushing):
                corners = self._plant.EvalBodyPoseInWorld(robot, sole.body).multiply(sole.corners.T)[2]
                down = bool(corners[pushing.get(name, slice(None))].min() < TOUCHING)
            out[name] = down
        return out

    def pushing_off(self, reference: Context, time: float) -> dict[str, np.ndarray]:
        """The feet pushing off at `time` (`reference` set to it), each with
        the corners it pushes off on ((K,) bools). A foot the clip has down
        with its sole pitched over an edge on the floor (`PLANTED_TOE_PITCH`):
        that edge, as the back foot of a lunge stands. A foot the clip has lifted,
        in the first half of its swing (`TOE_SWING`), whose sole the clip
        still has on the floor pitched over an edge: that edge (`TOE_DOWN`,
        `TOE_PITCH`, `TOE_BAND`). Else, just lifted (`PUSH_OFF_TIME`), with
        the other foot down and a step to take (`PUSH_OFF_STEP`): its edge
        toward its next footstep (`PUSH_OFF_EDGE`; stepping diagonally, a
        single corner: an edge snapped to the sole's length or width lost
        H1's turning walk one start in eight). Held there, the trailing foot
        pushes the body on as a person's toes do while the other lands:
        without it H1 walked at 0.74-0.87 of the clip's pace, each landing
        foot braking a body that nothing had pushed. A foot the clip lifts in
        place (`ClipPlan.lifted_in_place`: a lunge's back heel rising over its
        toes) stays on its lowest edge (or, just lifted, an edge it pushes off
        on) through the whole lift: let go, NAVIAI stood on its front foot
        alone with its body behind it and fell in three starts of four (see
        `PLANTED_TOE_PITCH` for the heel held up)."""
        out = {}
        clip_planted = self.plan.planted(time)
        for name, down in clip_planted.items():
            sole = self.soles.get(name)
            in_place = not down and self.plan.lifted_in_place(name, time)
            if sole is None or (not down and not in_place and self.plan.swing_progress(name, time) >= TOE_SWING):
                continue
            pose = self._plant.EvalBodyPoseInWorld(reference, sole.body)
            heights = pose.multiply(sole.corners.T)[2]
            low = heights.min()
            lowest_edge = heights < low + TOE_BAND
            if low < TOE_DOWN and heights.max() - low > (PLANTED_TOE_PITCH if down else TOE_PITCH):
                out[name] = lowest_edge
                continue
            if down:
                continue
            edge = self._push_off_edge(name, time, clip_planted, sole, pose)
            if edge is not None or in_place:
                out[name] = lowest_edge if edge is None else edge
        return out

    def _push_off_edge(
        self, name: str, time: float, clip_planted: dict[str, bool], sole: Sole, pose: RigidTransform
    ) -> np.ndarray | None:
        """The edge ((K,) bools) of the sole of foot `name` (at `pose` in the
        reference) toward its next footstep, if the clip lifted it within
        `PUSH_OFF_TIME` s with the other foot down and it is going at least
        `PUSH_OFF_STEP` m (`pushing_off`)."""
        other_down = any(clip_planted.get(other) for other in self.soles if other != name)
        if not other_down or self.plan.since_lifting(name, time) >= PUSH_OFF_TIME:
            return None
        self.plan.set_reference(self._nearby, time + self.plan.until_landing(name, time))
        step = self._plant.EvalBodyPoseInWorld(self._nearby, sole.body).translation() - pose.translation()
        way = (pose.rotation().inverse() @ np.append(step[:2], 0.0))[:2]  # in the sole's frame
        if np.linalg.norm(way) < PUSH_OFF_STEP:
            return None
        along = sole.corners[:, :2] @ (way / np.linalg.norm(way))
        return along > along.max() - PUSH_OFF_EDGE

    def follow(
        self,
        shift: np.ndarray,
        robot: Context,
        reference: Context,
        planted: dict[str, bool],
        easing: float | None = None,
    ) -> np.ndarray:
        """The footing shift one period after `shift` (m, (3,), its z 0):
        eased toward the planted feet's mean offset from the clip's (over
        `easing` s, by default `self.easing`); kept through a flight phase."""
        plant = self._plant
        offsets = [
            plant.EvalBodyPoseInWorld(robot, sole.body).translation()
            - plant.EvalBodyPoseInWorld(reference, sole.body).translation()
            for name, sole in self.soles.items()
            if planted.get(name)
        ]
        if not offsets:
            return shift
        footing = np.append((sum(offsets) / len(offsets))[:2], 0.0)  # their mean (np.mean's, for one or two)
        easing = self.easing if easing is None else easing
        return shift + (footing - shift) * (1.0 - np.exp(-self.period / easing))
