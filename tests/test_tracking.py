"""Diagram-level regression: the fixed-base UDH tracks a retargeted reference with its PD."""

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Multiplexer

from hotu_drake import embodiment
from hotu_drake.motion.library import generate
from hotu_drake.retarget.pipeline import to_udh
from hotu_drake.scenario import default_plant_config
from hotu_drake.systems.reference import ReferenceMotionSource

# Stated bound: RMS joint tracking error of arms and legs over the clip.
TRACKING_RMS_BOUND = 0.10  # rad


def test_fixed_base_udh_tracks_a_retargeted_boxing_clip():
    clip = to_udh(generate("boxing"), "none").clip
    udh = embodiment.load("udh", "none")
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(default_plant_config(), builder)
    model = udh.add_to_plant(plant)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("pelvis", model), RigidTransform([0, 0, 1.2]))
    plant.Finalize()
    reference = builder.AddSystem(ReferenceMotionSource(clip, loop=False, floating_base=False))
    desired = builder.AddSystem(Multiplexer([len(udh.joint_names)] * 2))
    builder.Connect(reference.GetOutputPort("joint_positions"), desired.get_input_port(0))
    builder.Connect(reference.GetOutputPort("joint_velocities"), desired.get_input_port(1))
    builder.Connect(desired.get_output_port(), plant.get_desired_state_input_port(model))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, model, clip.joint_positions[0])

    limbs = [i for i, n in enumerate(udh.joint_names) if any(p in n for p in ("shoulder", "elbow", "hip", "knee"))]
    errors, torque_ratio = [], 0.0
    for frame in range(1, clip.num_frames):
        simulator.AdvanceTo(frame / clip.fps)
        q = plant.GetPositions(plant_context, model)
        errors.append(q[limbs] - clip.joint_positions[frame, limbs])
        torques = plant.get_net_actuation_output_port(model).Eval(plant_context)
        torque_ratio = max(torque_ratio, float(np.max(np.abs(torques) / udh.effort_limits)))
    rms = float(np.sqrt(np.mean(np.square(errors))))
    print(f"boxing tracking: {np.degrees(rms):.2f} deg RMS, max torque ratio {torque_ratio:.2f}")
    assert rms < TRACKING_RMS_BOUND
    assert torque_ratio <= 1.0 + 1e-9
