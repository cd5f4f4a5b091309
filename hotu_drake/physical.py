"""Physical clips: a kinematic clip performed in the simulator by the whole-body controller.

(`retarget --physics` calls it; it composes a scenario's diagram, so it
stands beside `diagrams.py`, above the controller's package `control/`.)

`perform` runs the controller (`!WholeBodyTracking`) on a clip of an
embodiment and records, at the clip's own frames, what the simulated robot
did: its states and key bodies (a `MotionClip` whose contacts are the feet
the floor actually carried), the controller's actions, the torques the
plant applied and the floor's force on each foot; and a report next to the
clip: whether and when it fell (in the clip or in the `SETTLE` s after
it, its last frame held), its travel against the clip's, how far from
the clip's its pelvis ended (`end_offset_m`: a robot can stand through
a clip and end far from it), joint and key-body RMS against the clip,
the share of frames with a joint at its torque limit, the least margin
of its centre of pressure inside the support of its loaded feet, the
wall time (the diagram built, its lead-in and the clip's frames), the
steps the controller took of its own to catch the robot, and for a robot
that fell what in the clip is past it (`cannot`: a flight phase, a
joint asked more than its torque limit) and when and where it lost its
balance (`lost_balance`: its capture point gone from its loaded soles for
good; None if it was still over them as it fell, a fall of another kind).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hotu_drake.motion.clip import MotionClip, lifts
from hotu_drake.motion.playback import ClipPlayback
from hotu_drake.rotations import matrix_to_quat

LOADED = 0.05  # a foot carries the robot when the floor pushes it with this share of its weight or more
SATURATED = 0.99  # a joint is at its torque limit at this share of it
FLIGHT = 0.1  # s: no foot down for this long is a flight phase (a jump), which the controller does not plan
# s: a clip that ends is held at its last frame this long after it: a robot still falling as the clip ended
# (H1 stopping in start_stop, 4 starts of 10) stood through the clip and fell just after it.
SETTLE = 1.0
OVER_LIMIT = 0.05  # a joint the clip asks more than its limit of on this share of its frames is past what it can do
LOST = 0.02  # m: a capture point more than this outside the loaded soles (or over none) is past what they can push


@dataclass
class Performance:
    """A clip as the simulated robot performed it (`clip`), per frame the
    controller's `actions`, the applied `torques` (actuator order) and the
    floor's force on each foot (`foot_forces`, (T, feet, 3), world), and
    the `report`."""

    clip: MotionClip
    actions: np.ndarray
    torques: np.ndarray
    foot_forces: np.ndarray
    report: dict

    def save(self, path: str | Path) -> Path:
        """Write the clip as `.npz` with the actions, torques and foot forces beside its own arrays."""
        extra = {"actions": self.actions, "torques": self.torques, "foot_forces": self.foot_forces}
        return self.clip.save(path, extra)


def perform(
    clip: MotionClip,
    hands: str = "none",
    control_rate: float = 60.0,
    loop: bool = False,
    settle: float = SETTLE,
    lead_in: float = -1.0,
) -> Performance:
    """Perform `clip` (of any embodiment, CURI on its wheeled base; starting on its first frame)
    under the whole-body controller at `control_rate` (the plant's step too),
    over the clip's duration (`loop`: tracked as a loop, its plan looking
    ahead into the next pass), then, a clip that ends, `settle` s more with
    its last frame held: a robot that falls just after the clip's end did
    not perform it (the recorded clip is the performed frames alone). A clip
    that does not loop is first held at its first frame `lead_in` s
    (`WholeBodyTracking.lead_in`; negative: as the robot needs); times in the
    report count from the clip's start, after it."""
    from hotu_drake.diagrams import build_simulation
    from hotu_drake.scenario import InitialCondition, Scenario, WholeBodyTracking

    with tempfile.TemporaryDirectory() as folder:
        path = clip.save(Path(folder) / f"{clip.embodiment}.npz")
        scenario = Scenario(
            embodiment=clip.embodiment,
            hands=hands,
            driver=WholeBodyTracking(motion=str(path), loop=loop, lead_in=lead_in),
            initial=InitialCondition(reference_time=0.0),
            control_rate=control_rate,
        )
        scenario.plant_config.time_step = 1.0 / control_rate
        start = time.perf_counter()
        sim = build_simulation(scenario)
    plant, model, context, emb = sim.plant, sim.model, sim.plant_context(), sim.embodiment
    controller = sim.systems["whole_body_controller"]
    fall = sim.fall_check()
    weight = plant.CalcTotalMass(context, [model]) * 9.81
    root = plant.GetBodyByName(emb.spec.root.name, model)
    keys = list(dict.fromkeys(emb.key_bodies.values()))
    key_bodies = [plant.GetBodyByName(name, model) for name in keys]
    sides = [side for side in ("left", "right") if f"{side}_foot" in emb.key_bodies]
    feet = {int(plant.GetBodyByName(emb.key_bodies[f"{side}_foot"], model).index()): i for i, side in enumerate(sides)}
    soles = controller.soles
    joints = [plant.GetJointByName(name, model) for name in emb.joint_names]
    frames = clip.num_frames
    held = controller.plan.clip.num_frames - frames  # the lead-in's frames, before the clip's
    record = {name: [] for name in ("q", "root_p", "root_q", "keys", "actions", "torques", "forces", "pressure")}
    sole_bodies = [plant.GetBodyByName(sole.body.name(), model) for sole in soles.values()]
    balance = _BalanceTrace(plant, context, model, root, sides, sole_bodies, soles)
    fell_at, checked = None, 0
    for frame in range(-held, frames):
        sim.simulator.AdvanceTo((held + frame) / clip.fps)
        # The lead-in: standing, not yet the clip (a robot down in it is down at the clip's start). Stepped
        # frame by frame as the clip is: advanced over it in one call, H1's turning walk ended 0.7 mm elsewhere.
        if frame < 0:
            continue
        if frame == 0:
            checked = controller.predictions_checked  # the lead-in's, left out of the prediction error
        record["q"].append([plant.GetPositions(context)[joint.position_start()] for joint in joints])
        pose = plant.EvalBodyPoseInWorld(context, root)
        record["root_p"].append(pose.translation())
        record["root_q"].append(matrix_to_quat(pose.rotation().matrix()))
        record["keys"].append([plant.EvalBodyPoseInWorld(context, body).translation() for body in key_bodies])
        record["actions"].append(controller.last_action)
        record["torques"].append(plant.get_net_actuation_output_port(model).Eval(context))
        forces, pressure = _floor_forces(plant, context, feet, len(sides))
        record["forces"].append(forces)
        record["pressure"].append(pressure)
        balance.sample(frame / clip.fps, _loaded(forces, weight))
        if fall(context):
            fell_at = frame / clip.fps
            break
    wall = time.perf_counter() - start  # the diagram built, its lead-in and the clip's frames
    done = len(record["q"])
    error = controller.prediction_error(checked)  # over the clip's frames, as every other figure
    settled = 0.0  # s held after the clip's end, as simulated
    if fell_at is None and not loop:
        for step in range(1, int(round(settle * clip.fps)) + 1):
            at = (frames - 1 + step) / clip.fps
            sim.simulator.AdvanceTo((held + frames - 1 + step) / clip.fps)  # on the frames' grid
            settled = step / clip.fps
            balance.sample(at, _loaded(_floor_forces(plant, context, feet, len(sides))[0], weight))
            if fall(context):
                fell_at = at
                break
    forces = np.array(record["forces"])
    performed = MotionClip.from_positions(
        emb.name,
        f"{clip.source} (performed)",
        clip.fps,
        emb.joint_names,
        np.array(record["q"]),
        np.array(record["root_p"]),
        np.array(record["root_q"]),
        keys,
        np.array(record["keys"]),
        part_index=emb.parts,
        contact_names=[f"{side}_foot" for side in sides],
        contacts=_loaded(forces, weight),
    )
    report = _report(clip, performed, emb, np.array(record["torques"]))
    report["least_pressure_margin_m"] = None  # a robot on a base stands on no soles
    if soles:  # over the clip's frames (the trace's first), not the settle after them
        corners, down = np.array(balance.corners[:done]), balance.down()[:done]
        report["least_pressure_margin_m"] = _least_margin(corners, down, np.array(record["pressure"]))
    report |= {"fell": fell_at is not None, "fell_at_s": fell_at, "frames": done, "wall_time_s": round(wall, 2)}
    report["settle_s"] = round(settled, 3)
    # The steps the controller took of its own to catch the robot (`whole_body.WholeBodyController._start_catch`):
    # when its foot lifted (s, the clip's time; in the settle after it, past its end; in its lead-in, before
    # 0) and which foot; a catch whose foot the robot could not move is none.
    report["lead_in_s"] = round(held / clip.fps, 3)
    report["catch_steps"] = [[round(at - held / clip.fps, 3), foot] for at, foot in controller.catch_steps()]
    report["com_acceleration_error_m_s2"] = None if error is None else [round(float(e), 3) for e in error]
    torques = np.array(record["torques"])
    saturated = (np.abs(torques) >= SATURATED * emb.effort_limits).mean(axis=0) if len(torques) else None
    report["cannot"] = demands_beyond(clip, emb, saturated) if fell_at is not None else []
    report["lost_balance"] = balance.lost() if fell_at is not None and soles else None
    return Performance(performed, np.array(record["actions"]), np.array(record["torques"]), forces, report)


def demands_beyond(clip: MotionClip, emb, saturated: np.ndarray | None = None) -> list[str]:
    """What in `clip` (of embodiment `emb`) is past the robot, a line per
    reason: its flight phases (no foot down for `FLIGHT` s or more after
    its first frame: a jump, which the controller does not plan; one line
    for all; a clip that starts in the air is started on its feet), and each joint the performance held
    at its torque limit (`saturated`: per joint, the share of the performed
    frames) on `OVER_LIMIT` of the frames or more that the clip's own
    inverse dynamics (`retarget.balance.TorqueDemand`) also asks more than
    its limit of. Empty: nothing found in the clip that the robot cannot do."""
    from hotu_drake.retarget.balance import TorqueDemand
    from hotu_drake.retarget.retargeter import foot_contacts_of

    reasons = []
    names = [name for name in ("left_foot", "right_foot") if name in clip.contact_names]
    if names:
        down = np.any([clip.contact(name).astype(bool) for name in names], axis=0)
        flights = [
            (start / clip.fps, (stop - start) / clip.fps)
            for start, stop in lifts(down)
            if start > 0 and (stop - start) / clip.fps >= FLIGHT
        ]
        if flights:
            longest = max(seconds for _, seconds in flights)
            reasons.append(
                f"flight: {len(flights)} phase{'s' if len(flights) > 1 else ''} with no foot down, the first at "
                f"{flights[0][0]:.2f} s, the longest {longest:.2f} s (a jump; the controller plans no flight phase)"
            )
    if saturated is None:
        return reasons
    ratios = TorqueDemand(emb).ratios(clip, foot_contacts_of(clip, clip.num_frames))
    for j in np.argsort(-saturated):
        if saturated[j] < OVER_LIMIT:
            break
        if ratios[:, j].max() > 1.0:
            reasons.append(
                f"torque: {emb.joint_names[j]} at its {emb.effort_limits[j]:g} N m limit on {saturated[j]:.0%} of the "
                f"performed frames (the clip's inverse dynamics asks up to {ratios[:, j].max():.1f}x it)"
            )
    return reasons


class _BalanceTrace:
    """Per sampled moment of a performance: the robot's capture point, its
    soles' corners, which feet the floor carries and the way it faces; then
    when it lost its balance (`lost`). The robot is `model` in `plant` at
    `context`, its `root` body, its feet's `sides` and their soles (`soles`,
    by contact name, on the bodies `sole_bodies`), in one order."""

    def __init__(self, plant, context, model, root, sides, sole_bodies, soles):
        self._plant, self._context, self._model, self._root = plant, context, model, root
        self._sides, self._bodies, self._soles = sides, sole_bodies, list(soles.values())
        self.times, self.captures, self.corners, self.loaded, self.headings = [], [], [], [], []

    def sample(self, at: float, loaded: np.ndarray) -> None:
        """Record the robot's state at clip time `at`, with the feet the floor carries (`loaded`, per side)."""
        from hotu_drake.control.catch_step import capture_point

        if not self._soles:
            return
        plant, context, model = self._plant, self._context, self._model
        com = plant.CalcCenterOfMassPositionInWorld(context, [model])
        velocity = plant.CalcCenterOfMassTranslationalVelocityInWorld(context, [model])
        self.times.append(at)
        self.captures.append(capture_point(com, velocity))
        self.corners.append(
            np.vstack(
                [
                    plant.EvalBodyPoseInWorld(context, body).multiply(sole.corners.T).T[:, :2]
                    for body, sole in zip(self._bodies, self._soles)
                ]
            )
        )
        self.loaded.append(np.asarray(loaded, bool))
        self.headings.append(plant.EvalBodyPoseInWorld(context, self._root).rotation().matrix()[:2, 0])

    def down(self) -> np.ndarray:
        """Per sample, which sole corners the floor carries (T, K): their feet's `loaded`."""
        counts = [len(sole.corners) for sole in self._soles]
        return np.array([np.repeat(loaded, counts) for loaded in self.loaded]).reshape(len(self.loaded), sum(counts))

    def lost(self) -> dict | None:
        """When the capture point last left the loaded soles (by more than
        `LOST`, or no sole loaded) and stayed out to the last sample: the time
        (s, the clip's), and at the first of those samples with a sole
        loaded how far out (m), which way against the robot's heading
        (`ahead`, `behind`, `left`, `right`) and the feet it stood on
        (`in the air` and none, if no sole was loaded again); None if it was
        inside at the last sample."""
        from hotu_drake.control.clip_plan import into_support
        from hotu_drake.control.footsteps import heading_axes
        from hotu_drake.retarget.balance import Support

        if not self.times:
            return None
        corners, down, captures = np.array(self.corners), self.down(), np.array(self.captures)
        margins = Support(corners, down, 0.0).margin(captures)
        out = ~(margins >= -LOST)  # no sole loaded (NaN): out
        if not out[-1]:
            return None
        start = len(out) - 1
        while start > 0 and out[start - 1]:
            start -= 1
        lost = {"at_s": round(self.times[start], 3), "outside_m": None, "toward": "in the air", "standing_on": []}
        standing = [k for k in range(start, len(out)) if down[k].any()]
        if standing:
            k = standing[0]
            offset = captures[k] - into_support(captures[k], corners[k][down[k]])
            forward, left = (offset @ axis for axis in heading_axes(self.headings[k]))
            if abs(forward) >= abs(left):
                toward = "ahead" if forward > 0 else "behind"
            else:
                toward = "left" if left > 0 else "right"
            feet = [f"{side}_foot" for side, on in zip(self._sides, self.loaded[k]) if on]
            lost |= {"outside_m": round(float(-margins[k]), 3), "toward": toward, "standing_on": feet}
        return lost


def _loaded(forces: np.ndarray, weight: float) -> np.ndarray:
    """Which feet carry the robot: the floor pushing each (`forces`, (..., feet, 3)) with `LOADED` of its `weight`."""
    return forces[..., 2] >= LOADED * weight


def _floor_forces(plant, context, feet: dict[int, int], count: int) -> tuple[np.ndarray, np.ndarray]:
    """The floor's force on each foot (count, 3) and the centre of pressure
    of the feet's contacts (2,; NaN with no foot loaded)."""
    results = plant.get_contact_results_output_port().Eval(context)
    forces = np.zeros((count, 3))
    moment, normal = np.zeros(2), 0.0
    world = int(plant.world_body().index())
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        a, b = int(info.bodyA_index()), int(info.bodyB_index())
        foot = feet.get(b) if a == world else feet.get(a) if b == world else None
        if foot is None:  # not a foot on the floor (a foot on the other, a foot on an object)
            continue
        force = info.contact_force() if b in feet else -info.contact_force()  # on the foot
        forces[foot] += force
        moment += force[2] * info.contact_point()[:2]
        normal += force[2]
    return forces, moment / normal if normal > 1e-9 else np.full(2, np.nan)


def _report(clip: MotionClip, performed: MotionClip, emb, torques: np.ndarray) -> dict:
    """The figures of a performance against the clip it performed."""
    done = performed.num_frames
    reference = ClipPlayback(clip, loop=False)
    q_reference = np.array([reference.joints_at(t / clip.fps)[0] for t in range(done)])
    joint_rms = float(np.sqrt(np.mean(np.square(performed.joint_positions - q_reference))))
    names = list(performed.key_body_names)
    clip_keys = [clip.key_body_names.index(name) for name in names if name in clip.key_body_names]
    ours = [names.index(clip.key_body_names[i]) for i in clip_keys]
    key_error = performed.key_body_positions[:, ours] - clip.key_body_positions[:done, clip_keys]
    key_rms = float(np.sqrt(np.mean(np.sum(np.square(key_error), axis=-1)))) if clip_keys else None
    saturated = np.abs(torques) >= SATURATED * emb.effort_limits
    # The pelvis' travel (a planar base's too, which moves by its joints, not its root).
    pelvis = emb.key_bodies["pelvis"]
    has_pelvis = pelvis in clip.key_body_names and pelvis in performed.key_body_names
    ours = performed.key_body(pelvis) if has_pelvis else performed.root_position
    theirs = clip.key_body(pelvis) if has_pelvis else clip.root_position
    travel = np.linalg.norm(ours[-1, :2] - ours[0, :2])
    reference_travel = np.linalg.norm(theirs[done - 1, :2] - theirs[0, :2])
    end_offset = np.linalg.norm(ours[-1, :2] - theirs[done - 1, :2])
    return {
        "root_travel_m": round(float(travel), 4),
        "reference_travel_m": round(float(reference_travel), 4),
        "end_offset_m": round(float(end_offset), 4),
        "joint_rms_rad": round(joint_rms, 4),
        "key_body_rms_m": None if key_rms is None else round(key_rms, 4),
        "torque_saturation_share": round(float(np.mean(saturated.any(axis=1))), 4),
    }


def _least_margin(corners: np.ndarray, down: np.ndarray, pressure: np.ndarray) -> float | None:
    """The least distance (m) over the frames of the centre of pressure
    (T, 2) inside the hull of the loaded feet's sole corners (`corners` (T,
    K, 2) in the world, `down` (T, K)); negative: outside."""
    from hotu_drake.retarget.balance import Support

    margins = Support(corners, down, 0.0).margin(pressure)
    finite = margins[np.isfinite(margins)]
    return round(float(finite.min()), 4) if finite.size else None
