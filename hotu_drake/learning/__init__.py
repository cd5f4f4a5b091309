"""Learning in PyTorch (pydrake-free): networks, checkpoints, trainers.

Nothing under this package imports pydrake; it sees the world through the
gymnasium API and plain arrays.

What a deployed system needs (the Drake systems that run a trained policy
or skill) is this package's public API, importable from here:
`load_checkpoint` (and `CheckpointError`), `PolicyNetwork` and
`PolicyConfig`, `sample_sphere` (latents from the prior), and a skill's
`to_latents` and `high_level_input`. Training lives in the modules:
`trainer` (the loop and the run folder), `base_agent`, `agent`,
`dagger` (learning from the whole-body controller's actions),
`skill_agent`, `rollout`, `high_level`, and their configurations.
"""

from hotu_drake.learning.checkpoint import CheckpointError, load_checkpoint
from hotu_drake.learning.high_level import high_level_input, to_latents
from hotu_drake.learning.latents import sample_sphere
from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork

__all__ = [
    "CheckpointError",
    "PolicyConfig",
    "PolicyNetwork",
    "high_level_input",
    "load_checkpoint",
    "sample_sphere",
    "to_latents",
]
