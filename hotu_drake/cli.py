"""Shared command-line behaviour: one-line errors and non-zero exit codes."""

import argparse
import math
import sys
from collections.abc import Callable


class UserError(Exception):
    """A problem with the user's input: reported in one line, no traceback."""


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one `error:` line (exit 2)."""

    def error(self, message: str):
        raise UserError(f"{self.prog}: {message} (see --help)")


def positive_float(text: str) -> float:
    """An argparse type: a finite number greater than zero."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def run_cli(main: Callable[[list[str] | None], int], argv: list[str] | None = None) -> int:
    """Run `main`, turning user errors into one `error: ...` line and exit code 2."""
    try:
        return main(argv)
    except UserError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except OSError as error:  # unwritable output, missing input, ...
        where = f"{error.filename}: " if error.filename else ""
        print(f"error: {where}{error.strerror or error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
