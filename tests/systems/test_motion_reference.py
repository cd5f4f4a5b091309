"""MotionReference: a clip's phase and reference against the robot, as the environments give them."""

import gymnasium as gym
import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.analysis import Simulator

import hotu_drake.envs  # noqa: F401
from hotu_drake import embodiment
from hotu_drake.plant import placed_under
from hotu_drake.retarget.references import reference_clip
from hotu_drake.systems.motion_reference import PHASE_SIZE, REFERENCE_SIZE, MotionReference, clip_phase
from tests.systems.ports import assert_port_contract

RATE = 60.0


def test_port_contract():
    h1 = embodiment.load("h1", "none")
    system = MotionReference(h1, reference_clip("walk", h1), 1.0 / RATE)
    states = system.GetInputPort("state").size()
    assert states == 2 * (7 + len(h1.joint_names)) - 1  # the free root's quaternion: 7 positions, 6 velocities
    pose = 2 * len(h1.joint_names)
    assert_port_contract(system, {"state": states}, {"phase": PHASE_SIZE, "reference": REFERENCE_SIZE, "pose": pose})


def test_clip_phase():
    np.testing.assert_allclose(clip_phase(0.5, 2.0, loop=True), [1.0, 0.0], atol=1e-12)  # a quarter cycle
    np.testing.assert_allclose(clip_phase(2.5, 2.0, loop=True), [1.0, 0.0], atol=1e-12)  # a loop repeats
    np.testing.assert_allclose(clip_phase(1.0, 2.0, loop=False), [1.0, 0.0], atol=1e-12)  # half the clip
    np.testing.assert_allclose(clip_phase(5.0, 2.0, loop=False), [0.0, -1.0], atol=1e-12)  # held at its end


@pytest.mark.parametrize("start", ["reference", "default"])
def test_it_follows_the_clip_as_the_teachers_environment_does(start):
    """Stepped along an episode the teacher performs (H1's looped walk,
    1.5 s at 60 Hz), from the clip's first frame or from the standing pose
    dropped (`standing_follow`: the clip placed under the robot), the
    system fed the robot's states gives the phase, reference and pose the
    environment observed at each step, its footing shift (the teacher's,
    in the environment) moving as the feet land: the numbers a clone
    observed in training, without the teacher's QP."""
    options = {"robot": "h1", "hands": "none", "motions": ["walk"], "control_rate": RATE, "loop": True}
    env = gym.make(
        "hotu_drake/Imitation-v0",
        teacher=True,
        phase_observation=True,
        reference_observation=True,
        pose_observation=True,
        standing_follow=True,
        **options,
    )
    inner = env.unwrapped
    pose = 2 * len(inner.embodiment.joint_names)
    chosen = {"clip": 0, "time": 0.0} if start == "reference" else {}
    observation, info = env.reset(seed=3, options={"init": start, **chosen})
    assert info["init"] == start
    plant, model, context = inner.sim.plant, inner.sim.model, inner._plant_context
    system = MotionReference(inner.embodiment, inner.clips[0], 1.0 / RATE, loop=True)
    own = system.CreateDefaultContext()
    port = system.GetInputPort("state")
    port.FixValue(own, plant.GetPositionsAndVelocities(context, model))
    system.ExecuteInitializationEvents(own)
    shifts, states = [], []
    for step in range(90):
        if step:
            observation, _, terminated, _, info = env.step(info["teacher_action"])
            assert not terminated
            port.FixValue(own, plant.GetPositionsAndVelocities(context, model))
        states.append(plant.GetPositionsAndVelocities(context, model))
        own.SetTime(context.get_time())  # the environment's own sum of periods, as its teacher is asked at
        given = np.concatenate([system.GetOutputPort(extra).Eval(own) for extra in ("phase", "reference", "pose")])
        np.testing.assert_allclose(given, observation[-len(given) :], atol=1e-5, err_msg=f"{step}")
        own.get_mutable_discrete_state().SetFrom(system.EvalUniquePeriodicDiscreteUpdate(own))  # this step's update
        shifts.append(system.shift(own))
    assert max(np.linalg.norm(shift) for shift in shifts) > 0.005  # the clip moved to where the feet stood
    # Drake's own event order gives the same: the same states at each period's instant (as Drake times its
    # periodic events: a whole number of periods), in a Simulator.
    period = 1.0 / RATE
    simulator = Simulator(system)
    simulated = simulator.get_mutable_context()
    by_hand = system.CreateDefaultContext()
    for step, state in enumerate(states):
        if step:
            simulator.AdvanceTo(step * period)  # the update at the last period's instant, from the last state
        port.FixValue(simulated, state)
        port.FixValue(by_hand, state)
        if step == 0:
            simulator.Initialize()
            system.ExecuteInitializationEvents(by_hand)
        by_hand.SetTime(step * period)
        for extra in ("phase", "reference", "pose"):
            expected = system.GetOutputPort(extra).Eval(by_hand)
            np.testing.assert_array_equal(system.GetOutputPort(extra).Eval(simulated), expected, err_msg=f"{step}")
        by_hand.get_mutable_discrete_state().SetFrom(system.EvalUniquePeriodicDiscreteUpdate(by_hand))
    assert np.abs(given[-pose:]).max() > 0.01  # the teacher does not hold every joint on the clip's
    env.close()


def test_a_clip_is_placed_under_the_robots_root_facing_its_heading():
    """`placed_under`: the clip's start (brought to the origin facing +x by
    `start`) goes under a turned, tilted, raised root, on the floor, turned
    by the root's heading alone."""
    start = RigidTransform(RotationMatrix.MakeZRotation(0.3), [0.5, -0.2, 0.0])
    tilt = RotationMatrix.MakeZRotation(np.pi / 2) @ RotationMatrix.MakeYRotation(0.2)
    placed = placed_under(RigidTransform(tilt, [1.0, 2.0, 0.9]), start)
    clip_start = start.inverse().translation()  # the clip's world point that `start` takes to the origin
    np.testing.assert_allclose(placed @ clip_start, [1.0, 2.0, 0.0], atol=1e-12)
    heading = placed.rotation().matrix() @ start.inverse().rotation().matrix()
    np.testing.assert_allclose(heading, RotationMatrix.MakeZRotation(np.pi / 2).matrix(), atol=1e-12)
