"""The one exception type for bad input, and the checks that raise it.

`InputError` (a `ValueError`) is what every reader, scenario, command line
and environment raises for input it cannot use: a file, a scenario field,
a keyword, a reset option. It carries where the input came from (`path`)
and which field (`field`); its message starts with both, so a command
line prints it as one `error:` line.

The `check_*` helpers are the validation layer at the boundaries: each
checks type, finiteness and a physically motivated range, and names the
file, the field and the value when it fails.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np


class InputError(ValueError):
    """Input the project cannot use, with where it came from and which field."""

    def __init__(self, message: str, path: str | Path | None = None, field: str | None = None):
        self.path = None if path is None else str(path)
        self.field = field
        self.problem = message
        prefix = "".join(f"{part}: " for part in (self.path, field) if part)
        super().__init__(prefix + message)


def _as_number(value) -> int | float | None:
    """`value` as a Python number (numpy scalars too), or None for anything else (bool included)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return value


def check_number(
    value,
    field: str,
    path: str | Path | None = None,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    integer: bool = False,
    unit: str = "",
) -> float:
    """A finite number (an int with `integer`) within [low, high]
    ((low, high] with `low_open`); else `InputError` naming the field."""
    number = _as_number(value)
    kind = "a whole number" if integer else "a number"
    if number is None or (integer and math.isfinite(number) and not float(number).is_integer()):
        raise InputError(f"{value!r} is not {kind}", path, field)
    if not math.isfinite(number):
        raise InputError(f"{value!r} is not a finite number", path, field)
    below = low is not None and (number <= low if low_open else number < low)
    if below or (high is not None and number > high):
        units = f" {unit}" if unit else ""
        if low is not None and high is not None:
            span = f"{'(' if low_open else '['}{_fmt(low)}, {_fmt(high)}]"
        else:
            span = f"{'>' if low_open else '>='} {_fmt(low)}" if low is not None else f"<= {_fmt(high)}"
        raise InputError(f"{_fmt(number)}{units} is out of range (must be {span}{units})", path, field)
    return int(number) if integer else float(number)


def check_vector(
    values, field: str, path: str | Path | None = None, *, size: int = 3, bound: float | None = None, unit: str = ""
) -> list[float]:
    """`size` finite numbers, each within +-`bound` if given."""
    if isinstance(values, str | bytes) or not isinstance(values, Iterable):
        raise InputError(f"{values!r} is not a list of {size} numbers", path, field)
    values = list(values)
    if len(values) != size:
        raise InputError(f"{values!r} has {len(values)} numbers, not {size}", path, field)
    low = None if bound is None else -bound
    return [check_number(v, f"{field}[{i}]", path, low=low, high=bound, unit=unit) for i, v in enumerate(values)]


def check_choice(value, field: str, choices: Sequence, path: str | Path | None = None) -> str:
    """One of `choices`."""
    if value not in choices:
        raise InputError(f"{value!r} is not one of {', '.join(map(str, choices))}", path, field)
    return value


def check_bool(value, field: str, path: str | Path | None = None) -> bool:
    if not isinstance(value, bool):
        raise InputError(f"{value!r} is not true or false", path, field)
    return value


def _fmt(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)
