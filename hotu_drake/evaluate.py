"""`python -m hotu_drake.evaluate`: the method's tables and figures from run
folders, `hotu_drake.commands.tables` (see its --help)."""

import sys

from hotu_drake.cli import run_cli
from hotu_drake.commands.tables import main

if __name__ == "__main__":
    sys.exit(run_cli(main))
