"""Gestures of the library: boxing, finger motions, handshake, kung fu, wave, slap, thumbs up."""

from __future__ import annotations

import numpy as np

from hotu_drake.embodiment.spec import SIDES
from hotu_drake.motion.library.planning import (
    Scene,
    fist,
    hand_target,
    plan_base,
    set_hand_shape,
    set_joints,
    stand,
)
from hotu_drake.motion.synthesis import (
    Plan,
    Step,
    foot_tracks,
    keyframes,
    ramp,
)
from hotu_drake.rotations import rot_y


def boxing(sc: Scene) -> Plan:
    """Orthodox guard; alternating jabs and crosses, the torso turning into each."""
    t, s, w = sc.t, sc.s, sc.width
    steps = [
        Step("left", *sc.times(0.2, 0.6), (0.17 * s, w + 0.02 * s, 0.35), 0.05),
        Step("right", *sc.times(0.55, 0.95), (-0.13 * s, -w - 0.03 * s, 0.45), 0.05),
    ]
    feet = foot_tracks(t, sc.body, stand(sc), steps)
    bounce = 0.012 * s * (1 - np.cos(2 * np.pi * 2.2 * t)) * ramp(t, *sc.times(0.9, 1.2))
    base = plan_base(sc, feet, drop=0.05 * s + bounce, twist=-0.1)
    guard = ramp(t, *sc.times(0.2, 0.9))
    punches = []
    spacing = max(0.55 * sc.stretch, 0.5)  # a punch takes 0.46 s, however long the clip
    n = max(2, int((sc.duration - 1.1 * sc.stretch - 0.6) / spacing) + 1)
    for i in range(n):
        start = 1.1 * sc.stretch + spacing * i + 0.04 * sc.rng.uniform(-1, 1)
        punches.append(("left" if i % 2 == 0 else "right", start))
    plan = base.plan
    twist = np.zeros_like(t)
    for hand in SIDES:
        out = np.zeros_like(t)
        for side, start in punches:
            if side == hand:
                out = np.maximum(out, keyframes(t, [start, start + 0.16, start + 0.23, start + 0.46], [0, 1, 1, 0]))
        sign = 1.0 if hand == "left" else -1.0
        twist += -sign * (0.12 if hand == "left" else 0.3) * out
        rest = sc.body.rest_hand[hand]
        on_guard = np.array([0.28, sign * 0.13, 0.43]) * s
        strike = np.array([0.6, sign * 0.06, 0.33]) * s
        pos = (1 - guard)[:, None] * rest + guard[:, None] * (on_guard + out[:, None] * (strike - on_guard))
        up = guard * (1 - out)
        fingers = (1 - guard)[:, None] * np.array([0.0, 0.0, -1.0]) + up[:, None] * np.array([0.6, -sign * 0.2, 0.8])
        fingers = fingers + out[:, None] * np.array([1.0, 0.0, -0.2])
        palm = (1 - out)[:, None] * np.array([0.0, -sign * 1.0, 0.0]) + out[:, None] * np.array([0.0, 0.0, -1.0])
        elbow = (1 - out)[:, None] * np.array([-0.2, sign * 0.4, -1.0]) + out[:, None] * np.array([0.0, sign, -0.3])
        plan.hands[hand] = hand_target(base, hand, pos, fingers, palm, elbow, guard)
        fist(plan, hand, guard)
    set_joints(
        plan, torso_z=0.3 * guard + twist, neck_z=-0.3 * guard - 0.8 * twist, neck_y=0.1 * guard, torso_y=0.1 * guard
    )
    return plan


def finger_motions(sc: Scene) -> Plan:
    """Hands raised in front; each finger curls and straightens in turn, then fists."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, stand(sc), [])
    base = plan_base(sc, feet)
    plan = base.plan
    up = keyframes(t, sc.times(0.0, 0.3, 0.9, 5.3, 5.9), [0, 0, 1, 1, 0])
    for side in SIDES:
        sign = 1.0 if side == "left" else -1.0
        lag = 0.12 * sc.stretch * sc.jitter(0.5) if side == "right" else 0.0
        curls = []
        for i in range(5):  # thumb, index, middle, ring, little
            start = (1.0 + 0.55 * i) * sc.stretch + lag
            curls.append(keyframes(t, [start, start + 0.3, start + 0.4, start + 0.7], [0, 1, 1, 0]))
        fist = keyframes(t, sc.times(3.9, 4.2, 4.4, 4.7, 4.9, 5.2) + lag, [0, 1, 1, 0.1, 1, 0])
        grip = np.maximum(np.stack(curls[1:], 1), fist[:, None])
        set_hand_shape(plan, side, grip, np.maximum(curls[0], 0.8 * fist), np.maximum(curls[0], 0.6 * fist) * 0.9)
        pos = np.array([0.3 * sc.jitter(0.05), sign * 0.2, 0.45 * sc.jitter(0.04)]) * s
        plan.hands[side] = hand_target(base, side, pos, [1.0, 0.0, 1.0], [-1.0, -sign, 0.0], [0.0, 0.0, -1.0], up)
    set_joints(plan, neck_y=0.35 * up)
    return plan


def handshake(sc: Scene) -> Plan:
    """Right hand out, grip, three pumps, release, back."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, stand(sc), [])
    base = plan_base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.2, 1.5, 2.8, 3.1, 4.0)
    reach = keyframes(t, [k[0], k[1], k[4], k[5]], [0, 1, 1, 0])
    grip = keyframes(t, [k[1], k[2], k[3], k[4]], [0, 1, 1, 0])
    pump_phase = np.clip((t - k[2]) / (k[3] - k[2]), 0.0, 1.0)
    pump = 0.04 * s * sc.jitter(0.2) * np.sin(2 * np.pi * 3 * pump_phase) * np.sin(np.pi * pump_phase)
    reach_to = np.array([0.42 * sc.jitter(0.05), -0.1 * sc.jitter(0.2), 0.16 * sc.jitter(0.15)]) * s
    pos = reach_to + np.column_stack([0 * t, 0 * t, pump])
    plan.hands["right"] = hand_target(base, "right", pos, [1.0, 0.0, -0.25], [0.0, 1.0, 0.0], [-0.3, -0.3, -1.0], reach)
    set_hand_shape(plan, "right", np.repeat((0.05 + 0.55 * grip)[:, None], 4, 1), 0.1 + 0.4 * grip, 0.2 + 0.3 * grip)
    set_joints(plan, torso_y=0.08 * reach, neck_y=0.1 * reach, torso_z=0.1 * reach)
    return plan


def kungfu(sc: Scene) -> Plan:
    """Horse stance with chambered fists, three punches, then a front push kick."""
    t, s, w, body = sc.t, sc.s, sc.width, sc.body
    wide = 0.22 * s * sc.jitter(0.1)
    k = sc.times(0.3, 0.8, 4.0, 4.5, 5.0, 5.4, 5.8, 6.1, 6.6)
    steps = [Step("left", k[0], k[1], (0.0, w + wide, 0.0), 0.06), Step("left", k[2], k[3], (0.0, w, 0.0), 0.06)]
    feet = foot_tracks(t, body, stand(sc), steps)
    stance = keyframes(t, [k[0], k[1], k[2], k[3]], [0, 1, 1, 0])
    kick = keyframes(t, [k[4] - 0.35 * sc.stretch, k[4], k[8], k[8] + 0.35 * sc.stretch], [0, 1, 1, 0])
    # Weight over the left foot before the right one leaves the floor.
    shift = np.column_stack([-0.02 * s * kick, (w + 0.02 * s) * kick])
    base = plan_base(sc, feet, drop=0.16 * s * stance + 0.03 * s * kick, shift=shift, pitch=-0.25 * kick, sigma=0.12)
    plan = base.plan
    # The kick: chamber, extend (heel first, toes up), chamber, set down.
    kick_keys = [k[4], k[5], k[6], k[7], k[8]]
    ax = keyframes(t, kick_keys, [0.0, 0.2 * s, 0.7 * s, 0.2 * s, 0.0])
    az = keyframes(t, kick_keys, [0.0, 0.26 * s, 0.4 * s, 0.26 * s, 0.0])
    ap = keyframes(t, kick_keys, [0.0, 0.25, -0.35, 0.25, 0.0])
    right, rot = feet["right"]
    plan.feet["right"] = (right + np.column_stack([ax, 0 * ax, az]), rot @ rot_y(ap))
    strikes = {"right": [1.5, 3.1], "left": [2.3]}
    twist = np.zeros_like(t)
    for side in SIDES:
        sign = 1.0 if side == "left" else -1.0
        out = np.zeros_like(t)
        for start in strikes[side]:
            start = start * sc.stretch
            out = np.maximum(out, keyframes(t, [start, start + 0.2, start + 0.38, start + 0.75], [0, 1, 1, 0]))
        twist += -sign * 0.35 * out
        chamber = np.array([0.12, sign * 0.2, 0.22]) * s
        strike = np.array([0.62, sign * 0.04, 0.33]) * s
        pos = chamber + out[:, None] * (strike - chamber)
        fingers = np.array([1.0, 0.0, -0.2])
        palm = (1 - out)[:, None] * np.array([0.0, -sign, 1.0]) + out[:, None] * np.array([0.0, 0.0, -1.0])
        elbow = (1 - out)[:, None] * np.array([-1.0, 0.0, -0.3]) + out[:, None] * np.array([0.0, sign, -0.3])
        plan.hands[side] = hand_target(base, side, pos, fingers, palm, elbow, stance)
        fist(plan, side, np.maximum(stance, 0.3 * kick))
    set_joints(
        plan,
        torso_z=twist,
        neck_z=-twist,
        left_shoulder_x=0.12 + 0.5 * kick,
        right_shoulder_x=-0.12 - 0.4 * kick,
        left_elbow_y=-0.25 - 1.2 * kick,
        right_elbow_y=-0.25 - 1.2 * kick,
        torso_y=0.12 * kick,
    )
    return plan


def wave(sc: Scene) -> Plan:
    """Right forearm up, palm forward, hand swinging side to side."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, stand(sc), [])
    base = plan_base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.0, 3.2, 3.9)
    raised = keyframes(t, k, [0, 1, 1, 0])
    cycles = 4 + int(sc.rng.integers(0, 2))
    phase = np.clip((t - k[1]) / (k[2] - k[1]), 0.0, 1.0)
    angle = 0.35 * np.sin(2 * np.pi * cycles * phase) * np.sin(np.pi * phase) ** 0.5
    elbow_point = np.array([0.06, -0.42, 0.42]) * s
    reach = 0.39 * s
    direction = np.column_stack([0.12 + 0 * angle, -np.sin(angle), np.cos(angle)])
    pos = elbow_point + reach * direction / np.linalg.norm(direction, axis=1, keepdims=True)
    plan.hands["right"] = hand_target(base, "right", pos, direction, [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], raised)
    set_hand_shape(plan, "right", np.full((len(t), 4), 0.05), 0.05, 0.1)
    set_joints(plan, torso_x=0.06 * raised, neck_z=-0.15 * raised)
    return plan


# Slap keys (pelvis-heading frame): hand landmark / scale (the first and last
# are the hanging arm's), finger direction, palm normal.
_SLAP = np.array(
    [
        [[0.02, -0.21, -0.02], [0.2, -0.2, -1.0], [0.0, 1.0, 0.0]],  # arm down
        [[0.05, -0.5, 0.52], [0.3, -0.3, 1.0], [0.3, 1.0, 0.0]],  # wound up beside the head
        [[-0.02, -0.52, 0.55], [0.3, -0.3, 1.0], [0.3, 1.0, 0.0]],  # cocked back
        [[0.45, -0.08, 0.5], [0.8, 0.1, 0.6], [-0.3, 1.0, 0.0]],  # impact, palm first
        [[0.3, 0.25, 0.4], [0.6, 0.6, 0.3], [-0.8, 0.6, 0.0]],  # follow through
        [[0.25, 0.1, 0.2], [0.5, 0.3, -0.6], [-0.5, 0.6, 0.0]],  # recover
        [[0.02, -0.21, -0.02], [0.2, -0.2, -1.0], [0.0, 1.0, 0.0]],  # arm down
    ]
)


def slap(sc: Scene) -> Plan:
    """Wind up to the right, a fast open-hand swing across, follow through."""
    t, s = sc.t, sc.s
    step = Step("left", *sc.times(0.25, 0.6), (0.12 * s, sc.width, 0.1), 0.04)
    feet = foot_tracks(t, sc.body, stand(sc), [step])
    base = plan_base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.0, 1.3, 1.45, 1.65, 2.3, 2.9)
    keys = _SLAP[:, 0] * s * np.array([1.0, 1.0, sc.jitter(0.08)])
    keys[[0, -1]] = sc.body.rest_hand["right"]
    pos = keyframes(t, k, keys)
    fingers, palm = keyframes(t, k, _SLAP[:, 1]), keyframes(t, k, _SLAP[:, 2])
    weight = keyframes(t, [k[0], k[1], k[5], k[6]], [0, 1, 1, 0])
    plan.hands["right"] = hand_target(base, "right", pos, fingers, palm, [-0.3, -0.5, -1.0], weight)
    set_hand_shape(plan, "right", np.full((len(t), 4), 0.05), 0.05, 0.05)
    twist = keyframes(t, k, [0, -0.35, -0.4, 0.1, 0.35, 0.15, 0])
    set_joints(plan, torso_z=twist, neck_z=-0.8 * twist)
    return plan


def thumbs_up(sc: Scene) -> Plan:
    """Right fist forward at chest height, thumb up, a short push, back."""
    t, s = sc.t, sc.s
    feet = foot_tracks(t, sc.body, stand(sc), [])
    base = plan_base(sc, feet)
    plan = base.plan
    k = sc.times(0.3, 1.0, 1.4, 1.7, 2.6, 3.3)
    raised = keyframes(t, [k[0], k[1], k[4], k[5]], [0, 1, 1, 0])
    push = keyframes(t, [k[1], k[2], k[3], k[4]], [0, 1, 1, 0.6])
    height = 0.36 * sc.jitter(0.08)
    pos = np.column_stack([(0.32 + 0.08 * push) * s, np.full_like(t, -0.14 * s), (height + 0.03 * push) * s])
    plan.hands["right"] = hand_target(base, "right", pos, [1.0, 0.0, -0.1], [0.0, 1.0, 0.0], [-0.3, -0.4, -1.0], raised)
    set_hand_shape(plan, "right", np.repeat((0.98 * raised)[:, None], 4, 1), np.zeros_like(t), 0.05 * raised)
    set_joints(plan, neck_y=0.05 * raised, torso_z=0.1 * raised)
    return plan
