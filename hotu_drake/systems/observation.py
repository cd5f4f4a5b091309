"""ObservationSystem: what a policy and the per-part discriminators see.

From the plant state of one model it computes, in the heading frame (the
root's yaw):

- `observation`: root height, root rotation (tangent and normal axes, 6
  numbers), root linear and angular velocity, joint positions and
  velocities, key-body positions relative to the root;
- `amp_observation`: one frame of the AMP features, laid out part by part
  (`root` first, then every functional part the embodiment has: its joint
  positions and velocities, and for hands and feet their key-body
  positions), so that each part's discriminator can take its own slice
  (`part_slices`).
"""

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, LeafSystem

from hotu_drake.embodiment import Embodiment
from hotu_drake.systems.pd import actuated_state_indices

# Key bodies that belong to a part's AMP features (a hand with the wrist,
# a foot with the ankle).
PART_KEY_BODIES = {"wrist": ("left_hand", "right_hand"), "ankle": ("left_foot", "right_foot")}
ROOT_FEATURES = 1 + 6 + 3 + 3  # height, tangent and normal, linear and angular velocity


def heading_rotation(rotation: np.ndarray) -> np.ndarray:
    """The yaw-only rotation that shares `rotation`'s heading."""
    x = rotation[:, 0].copy()
    x[2] = 0.0
    n = np.linalg.norm(x)
    x = np.array([1.0, 0.0, 0.0]) if n < 1e-9 else x / n
    return np.column_stack([x, [-x[1], x[0], 0.0], [0.0, 0.0, 1.0]])


def key_body_roles(embodiment: Embodiment) -> list[str]:
    """The hands and feet the observation tracks, in order."""
    return [r for r in ("left_hand", "right_hand", "left_foot", "right_foot") if r in embodiment.key_bodies]


def observation_size(embodiment: Embodiment) -> int:
    """Length of the policy observation of `embodiment`."""
    return ROOT_FEATURES + 2 * len(embodiment.joint_names) + 3 * len(key_body_roles(embodiment))


class ObservationSystem(LeafSystem):
    """Input port `state` (the model's [q; v]); output ports `observation`
    and `amp_observation` (see the module docstring)."""

    def __init__(self, plant: MultibodyPlant, model, embodiment: Embodiment):
        super().__init__()
        self._plant, self._model, self._embodiment = plant, model, embodiment
        self._plant_context = plant.CreateDefaultContext()
        self._memo = None  # (state, features) of the last state seen
        self._q, self._v = actuated_state_indices(plant, model, embodiment.joint_names)
        self._root = plant.GetBodyByName(embodiment.spec.root.name, model)
        roles = key_body_roles(embodiment)
        self._key_roles = roles
        self._key_bodies = [plant.GetBodyByName(embodiment.key_bodies[r], model) for r in roles]
        self.observation_size = observation_size(embodiment)
        self.part_slices: dict[str, slice] = {"root": slice(0, ROOT_FEATURES)}
        self._part_columns: list[tuple[str, list[int], list[int]]] = []
        start = ROOT_FEATURES
        names = embodiment.joint_names
        for part, joints in embodiment.parts.items():
            if not joints:
                continue
            columns = [names.index(j) for j in joints]
            keys = [roles.index(r) for r in PART_KEY_BODIES.get(part, ()) if r in roles]
            size = 2 * len(columns) + 3 * len(keys)
            self.part_slices[part] = slice(start, start + size)
            self._part_columns.append((part, columns, keys))
            start += size
        self.amp_size = start
        self.DeclareVectorInputPort("state", plant.num_multibody_states(model))
        self.DeclareVectorOutputPort("observation", self.observation_size, self._CalcObservation)
        self.DeclareVectorOutputPort("amp_observation", self.amp_size, self._CalcAmpObservation)

    def _features(self, context):
        """Root features, joint positions and velocities, key bodies (heading
        frame); computed once per state, as both outputs are usually read."""
        state = self.get_input_port(0).Eval(context)
        if self._memo is not None and np.array_equal(self._memo[0], state):
            return self._memo[1]
        features = self._compute_features(state)
        self._memo = (state.copy(), features)
        return features

    def _compute_features(self, state: np.ndarray):
        plant, model = self._plant, self._model
        plant.SetPositionsAndVelocities(self._plant_context, model, state)
        pose = plant.EvalBodyPoseInWorld(self._plant_context, self._root)
        velocity = plant.EvalBodySpatialVelocityInWorld(self._plant_context, self._root)
        rotation = pose.rotation().matrix()
        heading = heading_rotation(rotation)
        local = heading.T @ rotation
        root = np.concatenate(
            [
                [pose.translation()[2]],
                local[:, 0],
                local[:, 2],
                heading.T @ velocity.translational(),
                heading.T @ velocity.rotational(),
            ]
        )
        keys = [
            heading.T @ (plant.EvalBodyPoseInWorld(self._plant_context, body).translation() - pose.translation())
            for body in self._key_bodies
        ]
        return root, state[self._q], state[self._v], np.array(keys).reshape(-1, 3)

    def _CalcObservation(self, context, output: BasicVector) -> None:
        root, q, v, keys = self._features(context)
        output.SetFromVector(np.concatenate([root, q, v, keys.ravel()]))

    def _CalcAmpObservation(self, context, output: BasicVector) -> None:
        root, q, v, keys = self._features(context)
        pieces = [root]
        for _, columns, key_rows in self._part_columns:
            pieces += [q[columns], v[columns], keys[key_rows].ravel()]
        output.SetFromVector(np.concatenate(pieces))
