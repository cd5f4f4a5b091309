"""`python -m hotu_drake.train`: runs `hotu_drake.commands.train` (see its --help)."""

import sys

from hotu_drake.cli import run_cli
from hotu_drake.commands.train import main

if __name__ == "__main__":
    sys.exit(run_cli(main))
