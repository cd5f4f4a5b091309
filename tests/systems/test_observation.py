"""ObservationSystem: features in the heading frame, part slices addressable by name."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.systems.observation import ROOT_FEATURES, AddObservation, ObservationSystem, observation_size
from tests.systems.ports import assert_inputs_wired, assert_port_contract


def _system(name: str):
    emb = embodiment.load(name, "none")
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.005), builder)
    model = emb.add_to_plant(plant)
    plant.Finalize()
    system = ObservationSystem(plant, model, emb)
    return emb, plant, model, system


def _evaluate(plant, model, system, root: RigidTransform, q: np.ndarray, v_root=(0.0,) * 6):
    context = plant.CreateDefaultContext()
    plant.SetFreeBodyPose(context, plant.GetBodyByName("pelvis", model), root)
    plant.SetPositions(context, model, np.concatenate([plant.GetPositions(context, model)[:7], q]))
    plant.SetVelocities(context, model, np.concatenate([np.asarray(v_root), np.zeros(len(q))]))
    system_context = system.CreateDefaultContext()
    system.fix_inputs_from_plant(system_context, plant, context, model)
    return system.GetOutputPort("observation").Eval(system_context), system.GetOutputPort("amp_observation").Eval(
        system_context
    )


def test_features_do_not_depend_on_heading_or_position():
    emb, plant, model, system = _system("h1")
    q = emb.standing_pose
    a, amp_a = _evaluate(plant, model, system, RigidTransform([0, 0, 1.0]), q, np.array([0, 0, 0.3, 0.5, 0, 0]))
    turned = RigidTransform(RollPitchYaw(0, 0, 1.2), [3.0, -2.0, 1.0])
    omega, linear = np.array([0, 0, 0.3]), np.array([0.5, 0, 0])
    yaw = RollPitchYaw(0, 0, 1.2).ToRotationMatrix().matrix()
    b, amp_b = _evaluate(plant, model, system, turned, q, np.concatenate([yaw @ omega, yaw @ linear]))
    assert a == pytest.approx(b, abs=1e-9) and amp_a == pytest.approx(amp_b, abs=1e-9)
    assert a[0] == pytest.approx(1.0)  # root height
    assert a[1:7] == pytest.approx([1, 0, 0, 0, 0, 1])  # upright: tangent x, normal z
    assert a[7:10] == pytest.approx([0.5, 0, 0]) and a[10:13] == pytest.approx([0, 0, 0.3])


def test_each_part_slice_holds_that_part():
    emb, plant, model, system = _system("udh")
    assert system.part_slices["root"] == slice(0, ROOT_FEATURES)
    q = emb.standing_pose.copy()
    knee = emb.joint_names.index("left_knee_y")
    q[knee] = 0.7
    _, amp = _evaluate(plant, model, system, RigidTransform([0, 0, 1.0]), q)
    knee_slice = amp[system.part_slices["knee"]]
    assert knee_slice[0] == pytest.approx(0.7)  # left_knee_y comes first in the knee part
    parts = [p for p, joints in emb.parts.items() if joints]
    assert list(system.part_slices) == ["root", *parts]
    sizes = sum(s.stop - s.start for s in system.part_slices.values())
    assert sizes == system.amp_size == amp.size
    # Hands and feet positions ride with the wrist and ankle parts.
    assert system.part_slices["ankle"].stop - system.part_slices["ankle"].start == 2 * 6 + 3 * 2


def test_port_contract(bruce):
    s = bruce
    system = AddObservation(s.builder, s.plant, s.model, s.embodiment)
    assert_inputs_wired(s.builder, system)
    inputs = {"state": s.plant.num_multibody_states(s.model), "body_poses": None, "body_spatial_velocities": None}
    outputs = {"observation": observation_size(s.embodiment), "amp_observation": system.amp_size}
    assert_port_contract(system, inputs, outputs)
    diagram = s.builder.Build()
    context = system.GetMyContextFromRoot(diagram.CreateDefaultContext())
    observation = system.GetOutputPort("observation").Eval(context)
    assert observation.shape == (outputs["observation"],) and np.all(np.isfinite(observation))
