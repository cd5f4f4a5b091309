"""The UDH's landmarks at rest: the human standing straight that the
retargeting measures its fixed offsets against (the thumb hand frame's
turn, each embodiment's neutral-pose calibration)."""

from functools import cache

import numpy as np


@cache
def udh_rest_landmarks() -> dict[str, np.ndarray]:
    """The UDH's landmarks at rest: a human standing straight, hands open."""
    from hotu_drake import embodiment as embodiments
    from hotu_drake.embodiment.landmarks import landmark_placements
    from hotu_drake.retarget.targets import Landmarks
    from hotu_drake.retarget.tree import Tree

    udh = embodiments.load("udh", "full")
    tree = Tree(udh.spec)
    return Landmarks(tree, landmark_placements(udh.spec)).all_positions(tree.forward(np.zeros(len(tree.joint_names))))
