"""Which self-collisions an embodiment ignores.

Adjacent bodies (a link and the nearest ancestor that has collision
geometry, skipping the light links between the axes of one joint), the
links within one functional part of one side, and the links of one limb
(an arm with its hand, a leg) never collide. Every exporter writes these
groups.
"""

from __future__ import annotations

from hotu_drake.embodiment.spec import EmbodimentSpec

# Links of one limb never collide with each other (a Panda arm folds onto
# itself; a hand closes onto its palm).
_LIMBS = {
    "shoulder": "arm",
    "elbow": "arm",
    "wrist": "arm",
    "finger": "arm",
    "hip": "leg",
    "knee": "leg",
    "ankle": "leg",
}


def filter_groups(spec: EmbodimentSpec) -> dict[str, list[str]]:
    """Group name -> member links; collisions within a group are ignored."""
    colliding = {link.name for link in spec.links if link.collisions}
    parent_of = {j.child: j.parent for j in spec.joints}
    groups: dict[str, list[str]] = {}

    for link in spec.links:
        if link.name not in colliding:
            continue
        ancestor = parent_of.get(link.name)
        while ancestor is not None and ancestor not in colliding:
            ancestor = parent_of.get(ancestor)
        if ancestor is not None and ancestor != "world":
            groups[f"adjacent_{link.name}"] = [ancestor, link.name]

    by_part: dict[str, list[str]] = {}
    for link in spec.links:
        if link.name in colliding and link.side:
            by_part.setdefault(f"{link.side}_{link.part}", []).append(link.name)
            limb = _LIMBS.get(link.part)
            if limb:
                by_part.setdefault(f"{link.side}_{limb}", []).append(link.name)
    for name, members in by_part.items():
        if len(members) > 1:
            groups[f"part_{name}"] = members
    return groups
