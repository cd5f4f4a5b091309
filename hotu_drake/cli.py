"""Shared command-line behaviour: one-line errors and non-zero exit codes.

Bad input (`InputError`, unreadable or unwritable files) is one `error:`
line and exit code 2. Anything else is a bug: one `error: internal error`
line and exit code 70, and the traceback only with `HOTU_DRAKE_DEBUG=1`.
"""

import argparse
import logging
import math
import os
import sys
from collections.abc import Callable

from hotu_drake.errors import InputError

EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 70  # sysexits' EX_SOFTWARE


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one `error:` line (exit 2)."""

    def error(self, message: str):
        raise InputError(f"{self.prog}: {message} (see --help)")


def positive_float(text: str) -> float:
    """An argparse type: a finite number greater than zero."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """An argparse type: a whole number greater than zero."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def show_notes() -> None:
    """Print what the readers decide (`hotu_drake.input` logger) as `note:`
    and `warning:` lines on standard error."""
    logger = logging.getLogger("hotu_drake.input")
    if not any(isinstance(h, _NoteHandler) for h in logger.handlers):
        logger.addHandler(_NoteHandler())
    logger.setLevel(logging.INFO)


class _NoteHandler(logging.StreamHandler):
    """`note: ...` and `warning: ...` lines on standard error (the stream of the moment)."""

    def emit(self, record: logging.LogRecord) -> None:
        kind = "warning" if record.levelno >= logging.WARNING else "note"
        print(f"{kind}: {record.getMessage()}", file=sys.stderr)


def run_cli(main: Callable[[list[str] | None], int], argv: list[str] | None = None) -> int:
    """Run `main`, turning bad input into one `error: ...` line and exit code 2."""
    try:
        return main(argv)
    except InputError as error:
        print(f"error: {_one_line(error)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as error:  # unwritable output, missing input, ...
        where = f"{error.filename}: " if error.filename else ""
        print(f"error: {where}{error.strerror or error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except Exception as error:  # a bug: say so in one line, keep the traceback for developers
        if os.environ.get("HOTU_DRAKE_DEBUG"):
            raise
        print(
            f"error: internal error ({type(error).__name__}: {_one_line(error)}); rerun with HOTU_DRAKE_DEBUG=1 "
            "for the traceback and please report it",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


def _one_line(error: Exception) -> str:
    lines = str(error).strip().splitlines()
    return lines[0] if lines else type(error).__name__
