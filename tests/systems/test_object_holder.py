"""ObjectHolder: its ports and wiring (the float-until-touched behaviour is
pinned at the scenario level, tests/test_scenario_features.py)."""

import numpy as np

from hotu_drake.objects import add_object
from hotu_drake.systems.object_holder import AddObjectHolder
from tests.systems.conftest import make_scene
from tests.systems.ports import assert_inputs_wired, assert_port_contract


def test_port_contract():
    s = make_scene(finalize=False)
    boxes = [add_object(s.plant, "box", name) for name in ("a", "b")]
    s.plant.Finalize()
    bodies = [s.plant.GetBodyByName("box", box) for box in boxes]
    holder = AddObjectHolder(s.builder, s.plant, s.scene_graph, s.model, bodies, 1.0 / 30.0)
    assert_inputs_wired(s.builder, holder)
    assert_port_contract(holder, {"geometry_query": None}, {"spatial_forces": None, "released": 2})
    diagram = s.builder.Build()
    context = holder.GetMyContextFromRoot(diagram.CreateDefaultContext())
    forces = holder.GetOutputPort("spatial_forces").Eval(context)
    weight = bodies[0].default_mass() * 9.81  # the plant's gravity, cancelled while held
    assert [f.F_Bq_W.translational()[2] for f in forces] == [weight, weight]
    np.testing.assert_array_equal(holder.GetOutputPort("released").Eval(context), [0.0, 0.0])
