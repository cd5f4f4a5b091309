"""`python -m hotu_drake.retarget`: runs `hotu_drake.commands.retarget` (see its --help)."""

import sys

from hotu_drake.cli import run_cli
from hotu_drake.commands.retarget import main

if __name__ == "__main__":
    sys.exit(run_cli(main))
