"""`python -m hotu_drake.simulate`: runs `hotu_drake.commands.simulate` (see its --help)."""

import sys

from hotu_drake.cli import run_cli
from hotu_drake.commands.simulate import main

if __name__ == "__main__":
    sys.exit(run_cli(main))
