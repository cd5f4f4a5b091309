"""Drake LeafSystems of the pipeline, each with named ports and its `AddXxx` helper.

| module | system | helper |
|---|---|---|
| `pd` | `SaturatedPdController` (and the action -> target gain) | `AddPdControl`, `AddActionToTargets` |
| `observation` | `ObservationSystem` | `AddObservation` |
| `policy` | `PolicySystem` | `AddPolicy` |
| `skill` | `SkillPolicySystem` (a skill's high level) | `AddSkillPolicy` |
| `reference` | `ReferenceMotionSource` | `AddReferenceMotion` |
| `interaction_graph` | `InteractionGraphSystem` | `AddInteractionGraph` |
| `perturbation` | `Perturbation` (thrown cubes) | `AddPerturbation` |
| `object_holder` | `ObjectHolder` | `AddObjectHolder` |
| `base_command` | `PlanarBaseCommand` | `AddPlanarBaseCommand` |
| `retargeting` | `RetargetingSystem` (streaming retargeting) | |

`hotu_drake.diagrams.build_simulation` composes them from a scenario.
"""

from hotu_drake.systems.base_command import PlanarBaseCommand
from hotu_drake.systems.retargeting import RetargetingSystem

__all__ = ["PlanarBaseCommand", "RetargetingSystem"]
