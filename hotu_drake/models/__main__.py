"""Model files of the six embodiments.

python -m hotu_drake.models list [--json]
python -m hotu_drake.models export NAME --format sdf|urdf|mjcf [--hands full|none] --out FILE
python -m hotu_drake.models generate [--out DIR] [--check]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from hotu_drake import embodiment
from hotu_drake.cli import ArgumentParser, positive_float, run_cli
from hotu_drake.errors import InputError
from hotu_drake.embodiment.embodiment import EXPORT_SUFFIX
from hotu_drake.io import write_text_atomic
from hotu_drake.models import dof_table, format_table, generated_files, same_model_text
from hotu_drake.resources import models_dir


def _parser() -> ArgumentParser:
    parser = ArgumentParser(
        prog="python -m hotu_drake.models",
        description="List the six embodiments (UDH, NAVIAI, H1, BRUCE, Walker, CURI) "
        "and export their models as SDF, URDF or MJCF.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    listing = sub.add_parser("list", help="print the per-part DoF table")
    listing.add_argument("--json", action="store_true", help="print JSON: {name: {part: dof, total: n}}")
    listing.add_argument("--hands", choices=embodiment.HANDS_VARIANTS, default="full")
    export = sub.add_parser("export", help="write one embodiment's model file")
    export.add_argument("name", help=f"one of {', '.join(embodiment.EMBODIMENT_NAMES)}")
    export.add_argument("--format", choices=sorted(EXPORT_SUFFIX), required=True)
    export.add_argument("--hands", choices=embodiment.HANDS_VARIANTS, default="full")
    export.add_argument("--height", type=positive_float, help="UDH only: body height in metres")
    export.add_argument("--out", required=True, help="output file")
    generate = sub.add_parser("generate", help="regenerate every file under models/")
    generate.add_argument("--out", help="folder to write (default: the repository's models/)")
    generate.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 1 if any file means another model (numbers compared to 6 digits)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "list":
        table = dof_table(args.hands)
        print(json.dumps(table, indent=2) if args.json else format_table(table))
        return 0
    if args.command == "export":
        if args.name not in embodiment.EMBODIMENT_NAMES:
            raise InputError(f"unknown embodiment '{args.name}'; choose from {', '.join(embodiment.EMBODIMENT_NAMES)}")
        options = {}
        if args.height is not None:
            if args.name != "udh":
                raise InputError("--height applies to the UDH only")
            options["height"] = args.height
        try:
            emb = embodiment.load(args.name, args.hands, **options)
        except ValueError as error:
            raise InputError(str(error)) from None
        out = Path(args.out)
        if out.is_dir():
            raise InputError(f"{out}: is a folder; give a file name")
        write_text_atomic(out, emb.model_text(args.format))
        print(f"wrote {out}")
        return 0
    root = Path(args.out) if args.out else models_dir()
    if root.exists() and not root.is_dir():
        raise InputError(f"{root}: is a file; give a folder")
    stale = []
    for relative, text in generated_files().items():
        path = root / relative
        old = path.read_text(encoding="utf-8") if path.exists() else None
        # --check asks whether a file says another model; generate writes the specs' canonical text.
        if old is not None and (same_model_text(old, text) if args.check else old == text):
            continue
        stale.append(relative)
        if not args.check:
            write_text_atomic(path, text)
    if args.check:
        for relative in stale:
            print(f"differs: {relative}", file=sys.stderr)
        return 1 if stale else 0
    print(f"{len(stale)} file(s) updated under {root}")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
