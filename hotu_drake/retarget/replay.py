"""Side-by-side Meshcat replays of a source motion and its retargeted clips.

The source's landmarks are drawn as small spheres; each embodiment stands in
its own lane (along y) and plays its clip. `write_replay` saves the whole
animation as one self-contained HTML file.
"""

from pathlib import Path

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.geometry import Box, Cylinder, Meshcat, MeshcatVisualizer, Rgba, Sphere, StartMeshcat
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from hotu_drake import embodiment
from hotu_drake.io import write_text_atomic
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import landmarks_of
from hotu_drake.objects import OBJECT_MODELS, object_kind
from hotu_drake.plant import actuated_joint_order

LANE = 1.2  # metres between lanes
REPLAY_FPS = 30.0
OBJECT_COLOR = Rgba(0.72, 0.52, 0.30, 1.0)


def _add_object(meshcat: Meshcat, path: str, name: str, pose: np.ndarray) -> None:
    """An object's shapes (`objects.OBJECT_MODELS`) in its frame; the library's
    table stands at its pose (the top's centre) on a leg down to the floor."""
    kind = object_kind(name)
    model = OBJECT_MODELS.get(kind) if kind is not None else None
    if model is None:
        meshcat.SetObject(f"{path}/body", Sphere(0.05), OBJECT_COLOR)
        return
    if kind == "table":
        top, leg = model.shape("top").geometry, model.shape("leg").geometry
        height = float(pose[2])
        meshcat.SetObject(f"{path}/top", Box(*top.size), OBJECT_COLOR)
        meshcat.SetObject(f"{path}/leg", Box(*leg.size[:2], height), OBJECT_COLOR)
        meshcat.SetTransform(f"{path}/leg", RigidTransform([0.0, 0.0, -height / 2]))
        return
    for shape in model.shapes:
        g = shape.geometry
        meshcat.SetObject(f"{path}/{shape.name}", _drake_shape(g), Rgba(*shape.color))
        meshcat.SetTransform(f"{path}/{shape.name}", RigidTransform(RollPitchYaw(*g.rpy), list(g.position)))


def _frames_at(clip: MotionClip, times: np.ndarray) -> np.ndarray:
    """The frame of `clip` at each of the replay's `times` (its last held past its end): every lane plays
    on one clock, a clip at a faster pace (`RetargetOptions.pace`) ahead of the person's."""
    return np.minimum(np.round(times * clip.fps).astype(int), clip.num_frames - 1)


def _drake_shape(g):
    if g.shape == "box":
        return Box(*g.size)
    if g.shape == "sphere":
        return Sphere(g.size[0])
    return Cylinder(*g.size)


def _embodiment_of(clip: MotionClip) -> embodiment.Embodiment:
    hands = "full" if any(n.endswith("_index_0") or n.endswith("_thumb_0") for n in clip.joint_names) else "none"
    return embodiment.load(clip.embodiment, hands)


def render_replay(clips: list[MotionClip], source: MotionClip | None = None, meshcat: Meshcat | None = None) -> Meshcat:
    """Record `clips` (and the `source` landmarks) playing side by side."""
    meshcat = meshcat or StartMeshcat()
    meshcat.Delete()
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    loaded = [_embodiment_of(clip) for clip in clips]
    models = [emb.add_to_plant(plant, f"lane{i}") for i, emb in enumerate(loaded)]
    plant.Finalize()
    MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)

    lanes = len(clips) + (source is not None)
    offsets = (np.arange(lanes) - (lanes - 1) / 2.0) * LANE
    source_offset = offsets[0] if source is not None else None
    clip_offsets = offsets[1:] if source is not None else offsets
    fps = clips[0].fps if clips else source.fps
    stride = max(1, int(round(fps / REPLAY_FPS)))
    played = [*clips, *([source] if source is not None else [])]
    duration = max((clip.num_frames - 1) / clip.fps for clip in played)
    times = np.arange(int(np.floor(duration * fps / stride + 1e-9)) + 1) * stride / fps

    points = {}
    if source is not None:
        points = {name: track[_frames_at(source, times)] for name, track in landmarks_of(source).items()}
    for name in points:
        meshcat.SetObject(f"/source/{name}", Sphere(0.025), Rgba(0.1, 0.1, 0.1, 1.0))
    # Every lane draws its own clip's object tracks (a robot's are scaled to it by the retargeting).
    lanes_with_objects = ([(source, source_offset)] if source is not None else []) + list(zip(clips, clip_offsets))
    objects = []
    for lane, (clip, y) in enumerate(lanes_with_objects):
        if clip.object_poses is None:
            continue
        for i, name in enumerate(clip.object_names):
            path = f"/objects/{name}_{lane}"
            _add_object(meshcat, path, name, clip.object_poses[0, i])
            objects.append((path, clip.object_poses[_frames_at(clip, times), i], y))
    layout = [(actuated_joint_order(plant, model), model) for model in models]
    meshcat.StartRecording(frames_per_second=fps / stride, set_visualizations_while_recording=False)
    recording = meshcat.get_mutable_recording()
    # Where each clip's joints go in the plant's position vector.
    slots = []
    for clip, (order, model) in zip(clips, layout):
        column = {n: i for i, n in enumerate(clip.joint_names)}
        starts = [plant.GetJointByName(name, model).position_start() for name in order]
        lateral = [i for i, name in enumerate(order) if name == "base_y"]
        slots.append((starts, [column[name] for name in order], lateral))
    at = [_frames_at(clip, times) for clip in clips]
    for frame, time in enumerate(times):
        context.SetTime(time)
        positions = plant.GetPositions(plant_context)
        for clip, k, (starts, columns, lateral), y in zip(clips, at, slots, clip_offsets):
            values = clip.joint_positions[k[frame], columns]
            values[lateral] += y
            positions[starts] = values
        plant.SetPositions(plant_context, positions)
        for clip, k, emb, (_, model), y in zip(clips, at, loaded, layout, clip_offsets):
            if emb.floating_base:
                root = plant.GetBodyByName(emb.spec.root.name, model)
                t = k[frame]
                pose = RigidTransform(Quaternion(*clip.root_quaternion[t]), clip.root_position[t] + [0.0, y, 0.0])
                plant.SetFreeBodyPose(plant_context, root, pose)
        diagram.ForcedPublish(context)
        for name, trajectory in points.items():
            recording.SetTransform(
                frame, f"/source/{name}", RigidTransform(trajectory[frame] + [0.0, source_offset, 0.0])
            )
        for path, poses, y in objects:
            pose = RigidTransform(
                Quaternion(*(poses[frame, 3:] / np.linalg.norm(poses[frame, 3:]))), poses[frame, :3] + [0.0, y, 0.0]
            )
            recording.SetTransform(frame, path, pose)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    meshcat.SetProperty("/Axes", "visible", False)
    # Look at the middle of the motion from the front, far enough for all lanes.
    middle = np.mean([clip.root_position.mean(axis=0) for clip in clips], axis=0) if clips else np.zeros(3)
    width = LANE * lanes
    meshcat.SetCameraPose(middle + [0.6 * width + 1.5, 0.0, 1.6], np.array([middle[0], 0.0, 0.8]))
    return meshcat


def write_replay(
    path: str | Path, clips: list[MotionClip], source: MotionClip | None = None, meshcat: Meshcat | None = None
) -> Path:
    """Write a self-contained HTML replay."""
    meshcat = render_replay(clips, source, meshcat)
    return write_text_atomic(path, meshcat.StaticHtml())
