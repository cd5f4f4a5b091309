"""ObservationSystem: what a policy and the per-part discriminators see.

From the plant state and body kinematics of one model it computes, in the
heading frame (the root's yaw):

- `observation`: root height, root rotation (tangent and normal axes, 6
  numbers), root linear and angular velocity, joint positions and
  velocities, key-body positions relative to the root;
- `amp_observation`: one frame of the AMP features, laid out part by part
  (`root` first, then every functional part the embodiment has: its joint
  positions and velocities, and for hands and feet their key-body
  positions), so that each part's discriminator can take its own slice
  (`part_slices`).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import Value
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem, ValueProducer

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.spec import FOOT_ROLES, HAND_ROLES
from hotu_drake.plant import actuated_state_indices
from hotu_drake.rotations import heading_rotation

# Key bodies that belong to a part's AMP features (a hand with the wrist,
# a foot with the ankle).
PART_KEY_BODIES = {"wrist": HAND_ROLES, "ankle": FOOT_ROLES}
ROOT_FEATURES = 1 + 6 + 3 + 3  # height, tangent and normal, linear and angular velocity
ROOT_LINEAR_VELOCITY = slice(7, 10)  # the root's linear velocity (heading frame) among them
ROOT_LABELS = (
    "root:height",
    *(f"root:tangent_{a}" for a in "xyz"),
    *(f"root:normal_{a}" for a in "xyz"),
    *(f"root:linear_velocity_{a}" for a in "xyz"),
    *(f"root:angular_velocity_{a}" for a in "xyz"),
)


def key_body_roles(embodiment: Embodiment) -> list[str]:
    """The hands and feet the observation tracks, in order."""
    return [r for r in (*HAND_ROLES, *FOOT_ROLES) if r in embodiment.key_bodies]


def observation_size(embodiment: Embodiment) -> int:
    """Length of the policy observation of `embodiment`."""
    return ROOT_FEATURES + 2 * len(embodiment.joint_names) + 3 * len(key_body_roles(embodiment))


class ObservationSystem(LeafSystem):
    """Policy and AMP observations of one robot (see the module docstring).

    .. pydrake_system::

        name: ObservationSystem
        input_ports:
        - state
        - body_poses
        - body_spatial_velocities
        output_ports:
        - observation
        - amp_observation

    `state` is the model's [q; v]; `body_poses` and `body_spatial_velocities`
    are the plant's outputs of the same names. The features both outputs
    share are a cache entry, computed once per state.
    """

    def __init__(self, plant: MultibodyPlant, model: ModelInstanceIndex, embodiment: Embodiment):
        super().__init__()
        self._q, self._v = actuated_state_indices(plant, model, embodiment.joint_names)
        self._root = int(plant.GetBodyByName(embodiment.spec.root.name, model).index())
        roles = key_body_roles(embodiment)
        self._key_bodies = [int(plant.GetBodyByName(embodiment.key_bodies[r], model).index()) for r in roles]
        self.observation_size = observation_size(embodiment)
        # The observation is the feature vector [root, q, v, key bodies]; an AMP
        # frame gathers from it part by part (`_amp_index`).
        n = len(embodiment.joint_names)
        q_at, v_at, keys_at = ROOT_FEATURES, ROOT_FEATURES + n, ROOT_FEATURES + 2 * n
        self.part_slices: dict[str, slice] = {"root": slice(0, ROOT_FEATURES)}
        self.amp_labels: dict[str, list[str]] = {"root": list(ROOT_LABELS)}  # column names, part by part
        index = list(range(ROOT_FEATURES))
        names = embodiment.joint_names
        for part, joints in embodiment.parts.items():
            if not joints:
                continue
            columns = [names.index(j) for j in joints]
            keys = [roles.index(r) for r in PART_KEY_BODIES.get(part, ()) if r in roles]
            start = len(index)
            index += [q_at + c for c in columns] + [v_at + c for c in columns]
            index += [keys_at + 3 * k + axis for k in keys for axis in range(3)]
            self.part_slices[part] = slice(start, len(index))
            labels = [f"{names[c]}:q" for c in columns] + [f"{names[c]}:v" for c in columns]
            self.amp_labels[part] = labels + [f"{roles[k]}:{axis}" for k in keys for axis in "xyz"]
        self.joint_position_columns = np.arange(q_at, q_at + n)  # of the observation, in joint order
        self._amp_index = np.array(index)
        self.amp_size = len(index)
        self._state = self.DeclareVectorInputPort("state", plant.num_multibody_states(model))
        self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate()
        )
        self._features = self.DeclareCacheEntry(
            description="heading-frame features",
            value_producer=ValueProducer(allocate=lambda: Value[object](None), calc=self._CalcFeatures),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        self.DeclareVectorOutputPort("observation", self.observation_size, self._CalcObservation)
        self.DeclareVectorOutputPort("amp_observation", self.amp_size, self._CalcAmpObservation)

    def _CalcFeatures(self, context: Context, value) -> None:
        """[root, q, v, key bodies] in the heading frame: root height, tangent
        and normal axes, linear and angular velocity; joints; hands and feet
        relative to the root."""
        state = self._state.Eval(context)
        poses = self._poses.Eval(context)
        pose = poses[self._root]
        velocity = self._velocities.Eval(context)[self._root]
        rotation, origin = pose.rotation().matrix(), pose.translation()
        heading = heading_rotation(rotation)
        local = heading.T @ rotation
        n = len(self._q)
        features = np.empty(self.observation_size)
        features[0] = origin[2]
        features[1:4], features[4:7] = local[:, 0], local[:, 2]
        features[ROOT_LINEAR_VELOCITY] = heading.T @ velocity.translational()
        features[10:13] = heading.T @ velocity.rotational()
        features[ROOT_FEATURES : ROOT_FEATURES + n] = state[self._q]
        features[ROOT_FEATURES + n : ROOT_FEATURES + 2 * n] = state[self._v]
        keys = np.array([poses[body].translation() for body in self._key_bodies]).reshape(-1, 3) - origin
        features[ROOT_FEATURES + 2 * n :] = (keys @ heading).ravel()  # rows: heading.T @ each
        value.set_value(features)

    def _CalcObservation(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._features.Eval(context))

    def _CalcAmpObservation(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._features.Eval(context)[self._amp_index])

    def fix_inputs_from_plant(self, context: Context, plant: MultibodyPlant, plant_context, model) -> None:
        """Fix this system's inputs in `context` (its own, outside a diagram)
        to the plant state in `plant_context`: how the AMP frames of clip
        states are computed without stepping the simulation."""
        self._state.FixValue(context, plant.GetPositionsAndVelocities(plant_context, model))
        self._poses.FixValue(context, plant.get_body_poses_output_port().Eval(plant_context))
        self._velocities.FixValue(context, plant.get_body_spatial_velocities_output_port().Eval(plant_context))


def AddObservation(
    builder: DiagramBuilder, plant: MultibodyPlant, model: ModelInstanceIndex, embodiment: Embodiment
) -> ObservationSystem:
    """Add an `ObservationSystem` named `observation`, wired to the plant."""
    observation = builder.AddNamedSystem("observation", ObservationSystem(plant, model, embodiment))
    builder.Connect(plant.get_state_output_port(model), observation.GetInputPort("state"))
    builder.Connect(plant.get_body_poses_output_port(), observation.GetInputPort("body_poses"))
    builder.Connect(
        plant.get_body_spatial_velocities_output_port(), observation.GetInputPort("body_spatial_velocities")
    )
    return observation
