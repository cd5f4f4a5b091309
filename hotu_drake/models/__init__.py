"""The model files of the six embodiments and the task objects: the DoF table and what `models/` holds.

`python -m hotu_drake.models` is the command line over these.
"""

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
