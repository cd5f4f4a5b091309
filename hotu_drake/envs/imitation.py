"""Imitation-v0: the behaviour-primitive environment of the method.

    env = gymnasium.make("hotu_drake/Imitation-v0", robot="h1", hands="none", motions=["walk"])

- Observation: the policy observation of `ObservationSystem` (root height,
  rotation and velocities in the heading frame, joint positions and
  velocities, hands and feet relative to the root), float32.
- Action: normalised PD targets in [-1, 1] per joint (-1 and 1 are the
  joint's limits), held for one control period (1/30 s).
- Reward: 0. The imitation reward is the per-part discriminators'; the
  trainer computes it from `info["amp"]` (part -> the last K AMP frames).
- Start: a reference clip at a random time (reference state
  initialisation) with probability `reference_init_probability`, else the
  standing pose dropped from up to `drop_height` m.
- Termination: a body other than a foot touches the floor, or the pelvis
  drops below `termination_height` x its standing height.
- `motions`: names from the generated library and/or `.npz` clips of the
  embodiment; default the whole library (retargeted once, then cached).
"""

from collections.abc import Sequence

from hotu_drake import embodiment as embodiments
from hotu_drake.envs.base import DiagramEnv
from hotu_drake.retarget.references import reference_clips


class ImitationEnv(DiagramEnv):
    def __init__(self, robot: str = "h1", hands: str = "none", motions: Sequence[str] | None = None, **options):
        emb = embodiments.load(robot, hands)
        super().__init__(clips=reference_clips(emb, motions), embodiment=emb, **options)
