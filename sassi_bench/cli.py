"""The ``sassi-bench`` command line: a thin layer over the package.

Each command group lives beside the code it drives and registers itself here through a
``register(subparsers)`` function, so this module only assembles the parser.

Examples
--------
>>> main(["rig", "show", "--rig", "sim"])  # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from sassi_bench import __version__
from sassi_bench.errors import SassiBenchError


def build_parser() -> argparse.ArgumentParser:
    """Assemble the full argument parser from every command group."""
    from sassi_bench.bundle import cli as bundle_cli
    from sassi_bench.export import cli as export_cli
    from sassi_bench.rig import cli as rig_cli
    from sassi_bench.spectra import cli as scan_cli
    from sassi_bench.validate import cli as validate_cli
    from sassi_bench.workflows import cli as workflow_cli

    parser = argparse.ArgumentParser(
        prog="sassi-bench",
        description=(
            "Calibrate a SASSI hyperspectral camera, on real hardware or the virtual bench."
        ),
    )
    parser.add_argument("--version", action="version", version=f"sassi-bench {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    rig_cli.register(sub)
    workflow_cli.register(sub)
    scan_cli.register(sub)
    bundle_cli.register(sub)
    export_cli.register(sub)
    validate_cli.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SassiBenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
