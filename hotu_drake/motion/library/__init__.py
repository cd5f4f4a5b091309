"""The procedural demonstration library: the method's motion vocabulary,
generated on the unified digital human, so demos and tests need no download.

Each motion is planned in task space (pelvis, ankles, hand landmarks,
objects; see `hotu_drake.motion.synthesis`) and solved into UDH joint
angles with closed-form limb IK, so planted feet stay still and hands sit
on the objects they hold. `generate_udh` returns the UDH clip, `generate`
the human clip (its landmarks), `generate_library` writes `.npz` files.

Objects (poses x y z + w x y z, world frame):

- ``box``: a 0.3 m cube (`objects.BOX_SIZE`), pose of its centre, axes along its faces.
- ``drill``: pose of the centre of its grip (handle); x along the barrel,
  z up the handle; it stands on its battery, the grip centre
  `objects.DRILL_BASE` (0.09 m) above the resting surface.
- ``table`` (drill clips and the grasp set, static): centre of the table top, 0.6 m deep
  (x) by 0.8 m wide (y); its height scales with the UDH (`objects.TABLE_TOP`, 0.72 m, nominal).
- the grasp set's objects (``hand_grasp@<seed>``, `objects.GRASP_OBJECTS`): pose of their centre.

Contacts: ``left_foot`` and ``right_foot`` (sole within 1 cm of the floor
and the foot slower than 0.1 m/s) in every clip, plus hand-object contacts
(``left_hand_box``, ``right_hand_box``, ``right_hand_drill``,
``right_hand_<object>``) while held.
"""

from hotu_drake.motion.library.generate import (
    DURATIONS,
    MOTIONS,
    generate,
    generate_library,
    generate_udh,
    is_library_motion,
    split_motion_name,
)

__all__ = [
    "DURATIONS",
    "MOTIONS",
    "generate",
    "generate_library",
    "generate_udh",
    "is_library_motion",
    "split_motion_name",
]
