"""Imitation-v0: the behaviour-primitive environment of the method.

    env = gymnasium.make("hotu_drake/Imitation-v0", robot="h1", hands="none", motions=["walk"])

- Observation: the policy observation of `ObservationSystem` (root height,
  rotation and velocities in the heading frame, joint positions and
  velocities, hands and feet relative to the root), float32.
- Action: normalised PD targets in [-1, 1] per joint (-1 and 1 are the
  joint's limits), held for one control period (1/30 s).
- Reward: 0. The imitation reward is the per-part discriminators'; the
  trainer computes it from `info["amp"]` (part -> the last K AMP frames).
  With `tracking_reward=True`, DeepMimic's tracking of the episode's clip
  instead (`envs.tracking.ClipTracking`; its terms in `info["tracking"]`;
  0 after a default start, which has no clip).
- Start: a reference clip at a random time (reference state
  initialisation) with probability `reference_init_probability`, else the
  standing pose dropped from up to `drop_height` m.
- Termination: a body other than a foot touches the floor, or the pelvis
  drops below `termination_height` x its standing height.
- `motions`: names from the generated library and/or `.npz` clips of the
  embodiment; default the whole library (retargeted once, then cached).
  `loop`: every clip repeats (True), none (False), or those named (a
  list of some of `motions`: a walk goes on, a squat is done once).
- The diagram: the environment's own scenario (H1 without fingers on the
  floor, the default 1/60 s plant step, actions at 30 Hz), or `scenario=` (a
  `Scenario`, a scenario file or a shipped name: its robot, plant and
  objects); `robot`, `hands`, `time_step`, `control_rate` and
  `sampled_output_ports` override either.
- `clip_objects`: the clips' objects in the scene (`envs.clip_objects`):
  an episode on a clip that handles an object starts with the clip's
  table and object where the clip has them; `info["object_rise"]` is how
  far its object is above where it started (NaN on other clips).
"""

from collections.abc import Sequence

from hotu_drake import embodiment as embodiments
from hotu_drake.envs.base import DiagramEnv, environment_scenario
from hotu_drake.envs.clip_objects import ClipObjects
from hotu_drake.envs.tracking import CLIP_SCALES, CLIP_WEIGHTS, ClipTracking, tracking_terms
from hotu_drake.errors import check_bool
from hotu_drake.retarget.references import looped_motions, motion_list, reference_clips
from hotu_drake.scenario import Scenario


class ImitationEnv(DiagramEnv):
    def __init__(
        self,
        robot: str | None = None,
        hands: str | None = None,
        motions: Sequence[str] | str | None = None,
        scenario: Scenario | str | None = None,
        time_step: float | None = None,
        control_rate: float | None = None,
        sampled_output_ports: bool | None = None,
        tracking_reward: bool = False,
        loop: bool | Sequence[str] = False,
        clip_objects: bool = False,
        **options,
    ):
        scenario = environment_scenario(scenario, robot, hands, time_step, control_rate, sampled_output_ports)
        emb = embodiments.load(scenario.embodiment, scenario.hands)
        where = type(self).__name__
        clips = reference_clips(emb, motions)
        loops = looped_motions(loop, motion_list(motions), f"{where}: loop")
        self._clip_objects = ClipObjects(clips) if check_bool(clip_objects, "clip_objects", where) else None
        if self._clip_objects is not None:
            scenario.objects = [*scenario.objects, *self._clip_objects.scene_objects()]
        super().__init__(scenario, clips, emb, loop=loops, **options)
        if self._clip_objects is not None:
            self._clip_objects.bind(self.sim.plant, self.sim.objects)
        self.tracking_reward = check_bool(tracking_reward, "tracking_reward", where)
        self._tracking = ClipTracking(self.sim.plant, self.sim.model, emb, self._observer, self.clips, self.loops)

    def _place_task(self) -> None:
        if self._clip_objects is not None:
            clip, time_ = self._episode_clip, self._clip_time()
            self._clip_objects.place(self.sim.plant, self._plant_context, clip, time_, self._episode_frame)

    def _info(self, terminated: bool) -> dict:
        info = super()._info(terminated)
        if self._clip_objects is not None:
            info["object_rise"] = self._clip_objects.rise(self.sim.plant, self._plant_context)
        return info

    def _task_reward(self, info: dict) -> float:
        if not self.tracking_reward or self._episode_clip is None:
            return 0.0
        robot = self._observation_port.Eval(self._context)
        errors = self._tracking.errors(robot, self._episode_clip, self._clip_time())
        terms = tracking_terms(errors, CLIP_WEIGHTS, CLIP_SCALES)
        info["tracking"] = {k: v for k, v in terms.items() if k != "total"}
        return terms["total"]
