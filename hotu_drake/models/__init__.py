"""The model files of the six embodiments and the task objects: the DoF table and what `models/` holds.

`python -m hotu_drake.models` is the command line over these.
"""

import math
import re

from hotu_drake import embodiment
from hotu_drake.embodiment.embodiment import EXPORT_SUFFIX
from hotu_drake.embodiment.spec import PARTS
from hotu_drake.objects import OBJECTS, object_sdf


def dof_table(hands: str = "full") -> dict[str, dict[str, int]]:
    """{name: {part: dof, ..., "total": n}} for the six embodiments."""
    return {name: embodiment.load(name, hands).part_dof for name in embodiment.EMBODIMENT_NAMES}


def format_table(table: dict[str, dict[str, int]]) -> str:
    columns = [*PARTS, "total"]
    lines = ["embodiment".ljust(11) + "".join(c.rjust(9) for c in columns)]
    for name, row in table.items():
        lines.append(name.ljust(11) + "".join(str(row[c]).rjust(9) for c in columns))
    return "\n".join(lines)


def generated_files() -> dict[str, str]:
    """Relative path -> text of every model file that `models/` should hold."""
    files = {}
    for name in embodiment.EMBODIMENT_NAMES:
        for hands in embodiment.HANDS_VARIANTS:
            emb = embodiment.load(name, hands)
            for fmt, suffix in EXPORT_SUFFIX.items():
                files[f"{name}/{name}_hands_{hands}{suffix}"] = emb.model_text(fmt)
    for name in OBJECTS:
        files[f"objects/{name}.sdf"] = object_sdf(name)
    return files


_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
# One unit in the sixth significant digit (the writers' precision) is at most 1e-5 of the value.
SIXTH_DIGIT = 2e-5


def same_model_text(a: str, b: str) -> bool:
    """Whether two model files say the same: equal text between the
    numbers, and the numbers equal to within the writers' precision (a
    value that rounds the other way in its sixth significant digit on
    another machine is the same model)."""
    words_a, words_b = _NUMBER.split(a), _NUMBER.split(b)
    if words_a != words_b:
        return False
    return all(
        math.isclose(float(x), float(y), rel_tol=SIXTH_DIGIT, abs_tol=1e-9)
        for x, y in zip(_NUMBER.findall(a), _NUMBER.findall(b))
    )
