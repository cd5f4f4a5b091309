"""Actions of a policy: normalised PD targets, and their map to joint targets.

An action a in [-1, 1] per actuated joint asks for a PD target between the
joint's lower limit (a = -1) and upper limit (a = 1). The map is affine
per joint; joints without position limits (CURI's base yaw) span
+-`UNLIMITED_HALF_RANGE` around zero. The simulation diagram applies it
with a static gain (`systems.pd.AddActionToTargets`); learning code may
import this module, which needs numpy only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from hotu_drake.embodiment.embodiment import Embodiment

UNLIMITED_HALF_RANGE = np.pi  # rad


@dataclass(frozen=True)
class ActionScaling:
    """Per-joint affine map between actions in [-1, 1] and PD targets."""

    offset: np.ndarray
    scale: np.ndarray

    @staticmethod
    def for_embodiment(embodiment: Embodiment) -> ActionScaling:
        lower, upper = embodiment.position_lower, embodiment.position_upper
        limited = np.isfinite(lower) & np.isfinite(upper)
        low, high = np.where(limited, lower, 0.0), np.where(limited, upper, 0.0)
        offset = 0.5 * (high + low)
        scale = np.where(limited, 0.5 * (high - low), UNLIMITED_HALF_RANGE)
        return ActionScaling(offset, scale)

    def to_targets(self, action: np.ndarray) -> np.ndarray:
        """PD targets for actions (clipped to [-1, 1])."""
        return self.offset + self.scale * np.clip(action, -1.0, 1.0)

    def to_action(self, targets: np.ndarray) -> np.ndarray:
        """The action that asks for `targets` (not clipped)."""
        return (np.asarray(targets) - self.offset) / self.scale


def standing_action(embodiment: Embodiment) -> np.ndarray:
    """The action that holds `embodiment`'s standing pose (within [-1, 1])."""
    return np.clip(ActionScaling.for_embodiment(embodiment).to_action(embodiment.standing_pose), -1.0, 1.0)
