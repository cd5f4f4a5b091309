"""RetargetingSystem: human landmark frames in, an embodiment's positions out.

For streaming a motion through a diagram (for example into a Meshcat
visualiser). At each period it retargets the latest input frame with the
same part-wise IK as the batch retargeter, warm-started from the previous
frame; feet are kept above the floor but not pinned (that needs the whole
clip's contact phases).
"""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from hotu_drake.embodiment import Embodiment
from hotu_drake.motion.rotations import matrix_to_quat
from hotu_drake.retarget.retargeter import Retargeter, RetargetStream


class RetargetingSystem(LeafSystem):
    """Input port `human_pose` (3k: the landmarks' world positions, in
    `landmark_names` order); output port `positions` (the embodiment's
    generalised positions: root quaternion w x y z and position for a
    floating base, then the joints in the embodiment's order).
    """

    def __init__(self, embodiment: Embodiment, landmark_names: list[str], fps: float):
        super().__init__()
        self._names = list(landmark_names)
        self._retargeter = Retargeter(embodiment, set(self._names))
        self._fps = fps
        self._stream: RetargetStream | None = None
        self._floating = embodiment.floating_base
        size = len(embodiment.joint_names) + (7 if self._floating else 0)
        initial = np.zeros(size)
        if self._floating:
            initial[0] = 1.0
        initial[-len(embodiment.joint_names) :] = embodiment.standing_pose
        self.DeclareVectorInputPort("human_pose", 3 * len(self._names))
        self._state = self.DeclareDiscreteState(initial)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / fps, 0.0, self._Retarget)
        self.DeclareVectorOutputPort("positions", size, self._CalcPositions)

    def frame(self, context) -> dict[str, np.ndarray]:
        values = self.get_input_port(0).Eval(context).reshape(-1, 3)
        return {name: values[i : i + 1] for i, name in enumerate(self._names)}

    def _Retarget(self, context, discrete_state) -> None:
        frame = self.frame(context)
        if self._stream is None:  # the first frame sets the body-size ratio
            self._stream = RetargetStream(self._retargeter, self._fps, frame)
        q, rotation, position = self._stream.push(frame)
        if self._floating:
            q = np.concatenate([matrix_to_quat(rotation), position, q])
        discrete_state.set_value(self._state, q)

    def _CalcPositions(self, context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value())
