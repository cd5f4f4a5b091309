"""`python -m hotu_drake.demo`: runs `hotu_drake.commands.demo` (see its --help)."""

import sys

from hotu_drake.cli import run_cli
from hotu_drake.commands.demo import main

if __name__ == "__main__":
    sys.exit(run_cli(main))
