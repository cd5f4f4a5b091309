"""RetargetingSystem: human landmark frames in, an embodiment's positions out.

For streaming a motion through a diagram (for example into a Meshcat
visualiser). At each period it retargets the latest input frame with the
same part-wise IK as the batch retargeter, warm-started from the previous
frame; feet are kept above the floor but not pinned (that needs the whole
clip's contact phases).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from hotu_drake.embodiment import Embodiment
from hotu_drake.retarget.retargeter import Retargeter, RetargetStream
from hotu_drake.rotations import matrix_to_quat


class RetargetingSystem(LeafSystem):
    """Streaming retargeting of landmark frames onto one embodiment.

    .. pydrake_system::

        name: RetargetingSystem
        input_ports:
        - human_pose
        output_ports:
        - positions

    `human_pose` is 3k numbers: the landmarks' world positions, in
    `landmark_names` order; `positions` the embodiment's generalised
    positions (root quaternion w x y z and position for a floating base,
    then the joints in the embodiment's order). The stream (warm start,
    body-size ratio set by the first frame) is abstract state, so every
    Context retargets on its own.
    """

    def __init__(self, embodiment: Embodiment, landmark_names: list[str], fps: float):
        super().__init__()
        self._names = list(landmark_names)
        self._retargeter = Retargeter(embodiment, set(self._names))
        self._fps = fps
        self._floating = embodiment.floating_base
        size = len(embodiment.joint_names) + (7 if self._floating else 0)
        initial = np.zeros(size)
        if self._floating:
            initial[0] = 1.0
        initial[-len(embodiment.joint_names) :] = embodiment.standing_pose
        self._human_pose = self.DeclareVectorInputPort("human_pose", 3 * len(self._names))
        self._positions = self.DeclareDiscreteState(initial)
        self._stream = self.DeclareAbstractState(Value[object](None))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / fps, 0.0, self._Retarget)
        self.DeclareVectorOutputPort("positions", size, self._CalcPositions)

    def frame(self, context: Context) -> dict[str, np.ndarray]:
        """The input frame as landmark -> (1, 3) position."""
        values = self._human_pose.Eval(context).reshape(-1, 3)
        return {name: values[i : i + 1] for i, name in enumerate(self._names)}

    def _Retarget(self, context: Context, state: State) -> None:
        frame = self.frame(context)
        stream = state.get_mutable_abstract_state(self._stream).get_value()
        if stream is None:  # the first frame sets the body-size ratio
            stream = RetargetStream(self._retargeter, self._fps, frame)
        q, rotation, position = stream.push(frame)
        if self._floating:
            q = np.concatenate([matrix_to_quat(rotation), position, q])
        state.get_mutable_abstract_state(self._stream).set_value(stream)
        state.get_mutable_discrete_state(self._positions).set_value(q)

    def _CalcPositions(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._positions).get_value())
