"""Figures of the command lines: matplotlib without a display, PNGs written whole."""

from __future__ import annotations

import sys
from pathlib import Path

from hotu_drake.errors import InputError
from hotu_drake.io import atomic_output


def pyplot(command: str):
    """matplotlib's pyplot without a display, or the error that says how to get it."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError(f"{command} needs matplotlib (pip install matplotlib)") from None
    return plt


def save_figure(plt, figure, out: Path, dpi: int) -> None:
    """`figure` as a PNG at `out`, written whole or not at all."""
    figure.tight_layout()
    with atomic_output(out) as tmp:
        figure.savefig(tmp, format="png", dpi=dpi)
    plt.close(figure)
    print(f"wrote {out}", file=sys.stderr)
