"""Whether a robot's clip is one it could stand on: its own stance, and legs
that do not pass through each other.

- `standing_width`: how far apart the ankles are sideways in the robot's
  standing pose, in its pelvis' heading frame;
- `stance`: over a clip, the feet's sideways distance over that width
  (1: the robot's own stance; 0: feet together; negative: crossed);
- `LegContacts`: the deepest interpenetration of a left-leg body with a
  right-leg body over a clip, from the robot's collision geometry in Drake
  (the model `python -m hotu_drake.models export` writes).
"""

from __future__ import annotations

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.landmarks import landmark_placements
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.udh_skeleton import points_on_clip
from hotu_drake.retarget import frames
from hotu_drake.rotations import heading_rotation

LEG_PARTS = ("hip", "knee", "ankle")
# Which links' collision geometry a leg point must keep clear of the other leg's.
CLEARED = {"knee": ("hip", "knee"), "ankle": ("knee", "ankle"), "toe": ("ankle",)}
CLEARANCE_MARGIN = 0.01  # m between the two legs' geometry


def leg_clearance(spec) -> dict[str, float]:
    """How far apart (m, sideways) the two legs' knees, ankles and toes must stay
    for their collision geometry not to meet: twice the largest sideways
    reach of a leg's links about them (a shank capsule's radius and offset,
    a sole's contact points), plus `CLEARANCE_MARGIN`. The links stand as
    at rest (their y along the body's left)."""
    reach = {part: 0.0 for part in LEG_PARTS}
    for link in spec.links:
        if link.part in LEG_PARTS and link.side == "left":
            for g in link.collisions:
                half = g.size[0] if g.shape in ("sphere", "capsule", "cylinder") else g.size[1] / 2
                reach[link.part] = max(reach[link.part], abs(g.position[1]) + half)
    return {point: 2 * max(reach[p] for p in parts) + CLEARANCE_MARGIN for point, parts in CLEARED.items()}


def sideways(landmarks: dict[str, np.ndarray]) -> np.ndarray:
    """The feet's sideways distance (T,) in the pelvis' heading frame: left
    ankle minus right ankle along the body's left (negative: crossed)."""
    heading = heading_rotation(frames.pelvis_frame(landmarks))
    return np.einsum("ti,ti->t", heading[:, :, 1], landmarks["left_ankle"] - landmarks["right_ankle"])


def standing_width(emb: Embodiment) -> float:
    """The ankles' sideways distance in the standing pose (m)."""
    standing = MotionClip.from_positions(
        emb.name,
        "standing",
        30.0,
        list(emb.joint_names),
        emb.standing_pose[None],
        np.array([[0.0, 0.0, emb.standing_root_height]]),
        np.array([[1.0, 0.0, 0.0, 0.0]]),
    )
    return float(sideways(points_on_clip(emb, standing, landmark_placements(emb.spec)))[0])


def stance(emb: Embodiment, landmarks: dict[str, np.ndarray], width: float | None = None) -> dict:
    """The clip's stance ratio (feet apart over the standing width): its
    median and least, and the share of frames with the feet crossed."""
    width = standing_width(emb) if width is None else width
    ratio = sideways(landmarks) / width
    return {
        "standing_width_m": round(width, 4),
        "median": round(float(np.median(ratio)), 3),
        "least": round(float(ratio.min()), 3),
        "crossed_share": round(float(np.mean(ratio < 0.0)), 3),
    }


class LegContacts:
    """The robot's collision geometry in a Drake `SceneGraph`, to measure how
    deep its left and right legs pass into each other."""

    def __init__(self, emb: Embodiment):
        from pydrake.geometry import SceneGraph
        from pydrake.multibody.plant import MultibodyPlant
        from pydrake.systems.framework import DiagramBuilder

        builder = DiagramBuilder()
        self.plant = plant = builder.AddSystem(MultibodyPlant(0.0))
        scene_graph = builder.AddSystem(SceneGraph())
        plant.RegisterAsSourceForSceneGraph(scene_graph)
        builder.Connect(plant.get_geometry_pose_output_port(), scene_graph.get_source_pose_port(plant.get_source_id()))
        builder.Connect(scene_graph.get_query_output_port(), plant.get_geometry_query_input_port())
        self.model = emb.add_to_plant(plant, builtin_pd=False)
        plant.Finalize()
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyContextFromRoot(self.context)
        self.emb = emb
        sides = {}
        for link in emb.spec.links:
            if link.part in LEG_PARTS and link.side in ("left", "right") and link.collisions:
                body = plant.GetBodyByName(link.name, self.model)
                for geometry in plant.GetCollisionGeometriesForBody(body):
                    sides[geometry] = link.side
        self._sides = sides
        self._columns = [plant.GetJointByName(n, self.model).position_start() for n in emb.joint_names]

    def depths(self, clip: MotionClip) -> np.ndarray:
        """Per frame, the deepest interpenetration (m, >= 0) of a left-leg
        body with a right-leg body (0: none)."""
        plant, context = self.plant, self.plant_context
        index = [clip.joint_names.index(n) for n in self.emb.joint_names]
        positions = plant.GetPositions(context)
        out = np.zeros(clip.num_frames)
        query_port = plant.get_geometry_query_input_port()
        for t in range(clip.num_frames):
            positions[self._columns] = clip.joint_positions[t, index]
            plant.SetPositions(context, positions)
            query = query_port.Eval(context)
            deepest = 0.0
            for pair in query.ComputeSignedDistancePairwiseClosestPoints(0.0):
                a, b = self._sides.get(pair.id_A), self._sides.get(pair.id_B)
                if a is not None and b is not None and a != b:
                    deepest = max(deepest, -pair.distance)
            out[t] = deepest
        return out


_BUILT: dict[int, tuple] = {}  # id(spec) -> (spec, its LegContacts)


def leg_contacts(emb: Embodiment) -> LegContacts:
    """The `LegContacts` of an embodiment, built once per spec (a report measures every clip of a robot)."""
    entry = _BUILT.get(id(emb.spec))
    if entry is None or entry[0] is not emb.spec:
        entry = _BUILT[id(emb.spec)] = (emb.spec, LegContacts(emb))
    return entry[1]
