"""Gymnasium environments over the scenario diagrams.

Importing this package registers:

- `hotu_drake/Imitation-v0` (`imitation.ImitationEnv`): imitate reference
  motions with per-part AMP observations;
- `hotu_drake/BoxCarry-v0`, `hotu_drake/DrillGrasp-v0` (`tasks`): the
  method's loco-manipulation tasks with goal, s_I and task reward;
- `hotu_drake/BoxCarryTransfer-v0`, `hotu_drake/DrillGraspTransfer-v0`
  (`transfer`): a task on a robot, tracking retargeted UDH skill episodes.

Episodes are cut at 300 control steps (10 s at the default 30 Hz) by
gymnasium's TimeLimit; a training run asks for 10 s at its own rate.
The rollout workers and the rollout loop (`EnvSpec`, `make_vector_env`,
`RolloutCollector`, `Rollout`) live in `hotu_drake.learning.rollout` (no
pydrake) and are re-exported here. Beside the environments: `runs` (a
training run's environments and demonstrations), `recording` (an episode
as a clip), `reach` (how far a controller's latents move its body).
"""

from gymnasium.envs.registration import register, registry

from hotu_drake.learning.rollout import EnvSpec, Rollout, RolloutCollector, make_vector_env

ENV_IDS: dict[str, str] = {
    "hotu_drake/Imitation-v0": "hotu_drake.envs.imitation:ImitationEnv",
    "hotu_drake/BoxCarry-v0": "hotu_drake.envs.tasks:BoxCarryEnv",
    "hotu_drake/DrillGrasp-v0": "hotu_drake.envs.tasks:DrillGraspEnv",
    "hotu_drake/BoxCarryTransfer-v0": "hotu_drake.envs.transfer:BoxCarryTransferEnv",
    "hotu_drake/DrillGraspTransfer-v0": "hotu_drake.envs.transfer:DrillGraspTransferEnv",
}
MAX_EPISODE_STEPS = 300

for _id, _entry in ENV_IDS.items():
    if _id not in registry:
        register(id=_id, entry_point=_entry, max_episode_steps=MAX_EPISODE_STEPS, disable_env_checker=True)

__all__ = ["ENV_IDS", "EnvSpec", "Rollout", "RolloutCollector", "make_vector_env"]
