"""Model files: they load in Drake (and MuJoCo) cleanly, and match the specs."""

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JointActuatorIndex
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.embodiment.formats.common import fmt
from hotu_drake.models import generated_files, same_model_text
from hotu_drake.resources import model_path, models_dir
from hotu_drake.scenario import default_plant_config

VARIANTS = [(n, h) for n in embodiment.EMBODIMENT_NAMES for h in embodiment.HANDS_VARIANTS]


def _load(text: str, kind: str) -> MultibodyPlant:
    from pydrake.multibody.plant import AddMultibodyPlant

    plant, _ = AddMultibodyPlant(default_plant_config(), DiagramBuilder())
    Parser(plant).AddModelsFromString(text, kind)
    plant.Finalize()
    return plant


@pytest.mark.parametrize("name,hands", VARIANTS)
@pytest.mark.parametrize("fmt", ["sdf", "urdf"])
def test_checked_in_model_loads_in_drake_without_warnings(name, hands, fmt, drake_warnings):
    emb = embodiment.load(name, hands)
    plant = _load(model_path(name, hands, fmt).read_text(), fmt)
    assert [r.getMessage() for r in drake_warnings.records] == []
    assert plant.num_actuators() == len(emb.joint_names)
    assert plant.num_actuated_dofs() == emb.part_dof["total"] + len(emb.base_joints)
    expected_positions = len(emb.joint_names) + (7 if emb.floating_base else 0)
    assert plant.num_positions() == expected_positions
    for i in range(plant.num_actuators()):
        actuator = plant.get_joint_actuator(JointActuatorIndex(i))
        assert actuator.has_controller(), actuator.name()
        assert actuator.effort_limit() > 0
    for body_index in plant.GetBodyIndices(plant.GetModelInstanceByName(name)):
        body = plant.get_body(body_index)
        assert body.default_mass() > 0, body.name()
        inertia = body.default_spatial_inertia()
        assert inertia.IsPhysicallyValid(), body.name()


@pytest.mark.parametrize("name,hands", VARIANTS)
def test_checked_in_mjcf_loads_in_mujoco(name, hands, mujoco):
    emb = embodiment.load(name, hands)
    model = mujoco.MjModel.from_xml_path(str(model_path(name, hands, "mjcf")))
    assert model.nu == len(emb.joint_names)
    assert model.njnt == len(emb.joint_names) + (1 if emb.floating_base else 0)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) for i in range(model.nu)]
    assert names == emb.joint_names


def test_regenerated_models_mean_the_checked_in_files():
    """Edit a spec, then run `python -m hotu_drake.models generate`. The
    files are compared by what they say (numbers to the writers' six
    digits), not by their last bits, which differ between machines."""
    root = models_dir()
    differing = [rel for rel, text in generated_files().items() if not same_model_text((root / rel).read_text(), text)]
    assert differing == []


def test_model_numbers_are_canonical_text():
    """A sum that is zero in exact arithmetic is written 0 whatever its last bits (1e-19 on one machine)."""
    assert [fmt(x) for x in (-1.25538e-19, 3e-17, -0.0, 0.0)] == ["0"] * 4
    assert [fmt(x) for x in (-0.00436004, 0.151226, 1 / 3, 2.0, 1e-9)] == [
        "-0.00436004",
        "0.151226",
        "0.333333",
        "2",
        "1e-09",
    ]


def test_same_model_text_tolerates_last_digits_only():
    text = '<pose>-0.00436004 0 0.151226</pose><mass value="12.5"/><link name="left_hip_2"/>'
    assert same_model_text(text, text.replace("0.151226", "0.151227"))  # rounded the other way in the 6th digit
    assert same_model_text(text, text.replace(" 0 ", " -1.25538e-19 "))  # an old file's unrounded zero
    assert not same_model_text(text, text.replace("0.151226", "0.151326"))  # a different model
    assert not same_model_text(text, text.replace("12.5", "12.6"))
    assert not same_model_text(text, text.replace("left_hip_2", "left_hip_3"))
    assert not same_model_text(text, text.replace("<mass", "<inertia"))
    assert not same_model_text(text, text + "<extra/>")


def test_mass_and_axes_agree_between_drake_and_the_spec():
    emb = embodiment.load("h1", "none")
    plant = _load(emb.model_text("urdf"), "urdf")
    total = sum(plant.get_body(i).default_mass() for i in plant.GetBodyIndices(plant.GetModelInstanceByName("h1")))
    assert total == pytest.approx(sum(link.mass for link in emb.spec.links))
    for joint in emb.spec.joints:
        assert tuple(plant.GetJointByName(joint.name).revolute_axis()) == pytest.approx(joint.axis, abs=1e-6)


@pytest.mark.parametrize("name,hands", VARIANTS)
def test_mjcf_stands_in_mujoco(name, hands, mujoco):
    """The MJCF's servos hold the standing pose in MuJoCo as the PD does in Drake."""
    emb = embodiment.load(name, hands)
    spec = mujoco.MjSpec.from_file(str(model_path(name, hands, "mjcf")))
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1])
    model = spec.compile()
    data = mujoco.MjData(model)
    if emb.floating_base:
        data.qpos[2] = emb.standing_root_height + 0.02
    for joint, q in emb.standing_pose_dict().items():
        data.qpos[model.joint(joint).qposadr[0]] = q
    data.ctrl[:] = emb.standing_pose
    mujoco.mj_forward(model, data)
    while data.time < 2.0:
        mujoco.mj_step(model, data)
    assert np.all(np.isfinite(data.qpos))
    pelvis = data.body(emb.key_bodies["pelvis"]).xpos
    if emb.floating_base:
        assert pelvis[2] == pytest.approx(emb.standing_pelvis_height, rel=0.10)
    body = [i for i, n in enumerate(emb.joint_names) if n not in emb.base_joints]
    reached = np.array([data.qpos[model.joint(emb.joint_names[i]).qposadr[0]] for i in body])
    assert np.max(np.abs(reached - emb.standing_pose[body])) < 0.3
