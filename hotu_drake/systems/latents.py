"""LatentSampler: a trained policy's latents, drawn from its prior as in training.

Each part group's latent is a point on the unit sphere, drawn again after a
number of control periods drawn from U[low, high). The draws are a
function of (seed, group, draw count), so the state is numbers only and a
run is repeatable from its seed.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem

from hotu_drake.learning import sample_sphere


class LatentSampler(LeafSystem):
    """Latents of the policy's part groups.

    .. pydrake_system::

        name: LatentSampler
        output_ports:
        - latent_<group> (one per part group)

    Discrete state per group: [latent, periods left, draws so far], updated
    every control period.
    """

    def __init__(self, groups: list[str], size: int, low: int, high: int, control_rate: float, seed: int = 0):
        super().__init__()
        self._size, self._low, self._high, self._seed = size, low, high, seed
        self._groups = list(groups)
        self._states = {}
        for index, group in enumerate(self._groups):
            self._states[group] = self.DeclareDiscreteState(self._draw(index, 0))
            self.DeclareVectorOutputPort(
                f"latent_{group}",
                size,
                lambda context, output, group=group: output.SetFromVector(self.latent(context, group)),
                prerequisites_of_calc={self.discrete_state_ticket(self._states[group])},
            )
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / control_rate, 1.0 / control_rate, self._Advance)

    def _draw(self, group_index: int, count: int) -> np.ndarray:
        rng = np.random.default_rng([self._seed, group_index, count])
        latent = sample_sphere(rng, 1, self._size)[0]
        return np.concatenate([latent, [rng.integers(self._low, self._high), count]])

    def _Advance(self, context: Context, discrete_state) -> None:
        for index, group in enumerate(self._groups):
            state = context.get_discrete_state(self._states[group]).get_value().copy()
            state[self._size] -= 1
            if state[self._size] <= 0:
                state = self._draw(index, int(state[self._size + 1]) + 1)
            discrete_state.set_value(self._states[group], state)

    def latent(self, context: Context, group: str) -> np.ndarray:
        return context.get_discrete_state(self._states[group]).get_value()[: self._size].copy()


def AddLatentSampler(
    builder: DiagramBuilder, groups: list[str], size: int, low: int, high: int, control_rate: float, seed: int = 0
) -> LatentSampler:
    """Add a `LatentSampler` named `latents`."""
    return builder.AddNamedSystem("latents", LatentSampler(groups, size, low, high, control_rate, seed))
