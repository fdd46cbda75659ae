"""Command-line interface: ``gnssframework <command>``."""

from __future__ import annotations

import argparse
import sys
from typing import Sequence

from . import registry
from .errors import GnssFrameworkError

__all__ = ["main"]


def _cmd_plugins(args: argparse.Namespace) -> int:
    rows = [("KIND", "NAME", "DESCRIPTION", "SOURCE")]
    for info in registry.describe():
        if args.kind and info.kind != args.kind:
            continue
        rows.append((info.kind, info.name, info.description, f"{info.distribution} {info.version}".strip()))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    for r in rows:
        print(f"{r[0]:<{widths[0]}}  {r[1]:<{widths[1]}}  {r[2]:<{widths[2]}}  {r[3]}")
    for failure in registry.failures():
        print(f"failed to load: {failure}", file=sys.stderr)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="gnssframework", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("plugins", help="list the registered plugins")
    p.add_argument("--kind", choices=registry.kinds(), help="only this kind")
    p.set_defaults(func=_cmd_plugins)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code. Library errors print one line, no traceback."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except GnssFrameworkError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
