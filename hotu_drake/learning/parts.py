"""Part groups: which columns of the AMP observation each discriminator sees.

An environment's `info["amp"]` maps keys (`root` and the functional parts
of Table I that the robot has: neck, torso, shoulder, ...) to the last K
AMP frames of that key. `AmpLayout` names each column of each key
(`left_elbow_y:q`, `left_elbow_y:v`, `left_hand:x`, `root:height`, ...), so
a group can take whole keys (`"hip"`) or one side of a key
(`"shoulder:left"`: the columns whose label starts with `left_`).

Groupings:

- `default`: lower body (root, hip, knee, ankle), torso (torso, neck), left
  arm and right arm (shoulder, elbow, wrist of one side, the hand's key
  body with the wrist), hands (finger);
- `table`: Table I's nine parts, one group each (the root with the hips);
- `whole`: one group with every column (AMP, ASE).

A group none of whose selectors matches a column of the robot (fingers on a
robot without hands, a neck on H1) is left out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hotu_drake.errors import InputError

TABLE_PARTS = ("neck", "torso", "shoulder", "elbow", "wrist", "finger", "hip", "knee", "ankle")
SIDES = ("left", "right")

GROUPINGS: dict[str, dict[str, list[str]]] = {
    "default": {
        "lower_body": ["root", "hip", "knee", "ankle"],
        "torso": ["torso", "neck"],
        "left_arm": ["shoulder:left", "elbow:left", "wrist:left"],
        "right_arm": ["shoulder:right", "elbow:right", "wrist:right"],
        "hands": ["finger"],
    },
    "table": {part: ([part, "root"] if part == "hip" else [part]) for part in TABLE_PARTS},
    "whole": {"whole_body": ["root", *TABLE_PARTS]},
}


@dataclass(frozen=True)
class AmpLayout:
    """Column labels of every key of `info["amp"]`, in the environment's order."""

    columns: dict[str, tuple[str, ...]]

    @staticmethod
    def anonymous(sizes: dict[str, int]) -> AmpLayout:
        """A layout for an environment that names no columns: `key:i`."""
        return AmpLayout({key: tuple(f"{key}:{i}" for i in range(size)) for key, size in sizes.items()})

    @property
    def keys(self) -> list[str]:
        return list(self.columns)

    def size(self, key: str) -> int:
        return len(self.columns[key])

    def to_dict(self) -> dict[str, list[str]]:
        return {key: list(labels) for key, labels in self.columns.items()}

    @staticmethod
    def from_dict(data: dict) -> AmpLayout:
        return AmpLayout({str(key): tuple(map(str, labels)) for key, labels in data.items()})


@dataclass(frozen=True)
class PartGroup:
    """A discriminator's input: per key of `info["amp"]`, the columns it takes."""

    name: str
    columns: dict[str, np.ndarray]  # key -> column indices into info["amp"][key]

    @property
    def frame_size(self) -> int:
        return sum(len(c) for c in self.columns.values())

    def gather(self, amp: dict[str, np.ndarray]) -> np.ndarray:
        """This group's features of AMP windows (..., K, d_key) per key, as (..., K, frame_size)."""
        return np.concatenate([np.asarray(amp[key])[..., cols] for key, cols in self.columns.items()], axis=-1)

    def to_dict(self) -> dict:
        return {"name": self.name, "columns": {k: v.tolist() for k, v in self.columns.items()}}

    @staticmethod
    def from_dict(data: dict) -> PartGroup:
        return PartGroup(data["name"], {k: np.asarray(v, dtype=np.int64) for k, v in data["columns"].items()})


def resolve_groups(
    layout: AmpLayout, grouping: str = "default", groups: dict[str, list[str]] | None = None
) -> list[PartGroup]:
    """The part groups of `grouping` (or of the explicit `groups`) on `layout`;
    groups that match no column are dropped."""
    spec = groups or GROUPINGS.get(grouping)
    if spec is None:
        raise InputError(f"unknown grouping {grouping!r} (known: {', '.join(GROUPINGS)})", field="style.grouping")
    resolved = []
    for name, selectors in spec.items():
        columns: dict[str, list[int]] = {}
        for selector in selectors:
            key, _, side = selector.partition(":")
            if side and side not in SIDES:
                raise InputError(f"group {name!r}: {selector!r} names no side (left or right)", field="style.groups")
            if key not in layout.columns:
                continue
            picked = [i for i, label in enumerate(layout.columns[key]) if not side or label.startswith(f"{side}_")]
            if picked:
                columns.setdefault(key, []).extend(picked)
        if columns:
            resolved.append(
                PartGroup(name, {k: np.asarray(sorted(set(v)), dtype=np.int64) for k, v in columns.items()})
            )
    if not resolved:
        raise InputError(f"no group of {grouping!r} matches the environment's AMP keys {layout.keys}", field="style")
    return resolved
