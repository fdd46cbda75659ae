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


def _cmd_compare(args: argparse.Namespace) -> int:
    from .experiments import load_config, run_comparison

    config = load_config(args.file, runs=args.runs, seed=args.seed)
    out = args.out or f"results/{config.name}"
    summary = run_comparison(config, out, progress=not args.quiet)
    print(f"wrote {summary}, {summary.parent / 'report.md'} and {summary.parent / 'plots'}/")
    return 0


def _cmd_filter_positions(args: argparse.Namespace) -> int:
    from .io.nmea import read_nmea
    from .io.positions import filter_positions, write_positions_csv

    fixes = read_nmea(args.file)
    lat, lon, _, _ = filter_positions(fixes, args.filter, args.psi)
    write_positions_csv(args.out, fixes, lat, lon)
    print(f"{args.file}: {fixes.time_s.size} fixes filtered with {args.filter}, {len(fixes.skipped)} sentences "
          f"skipped; wrote {args.out}")
    for line, reason in fixes.skipped[:20]:
        print(f"  skipped line {line}: {reason}")
    if len(fixes.skipped) > 20:
        print(f"  ... and {len(fixes.skipped) - 20} more")
    return 0


def _cmd_schema(args: argparse.Namespace) -> int:
    import json

    from .experiments import ComparisonConfig

    print(json.dumps(ComparisonConfig.model_json_schema(), indent=2))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="gnssframework", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("plugins", help="list the registered plugins")
    p.add_argument("--kind", choices=registry.kinds(), help="only this kind")
    p.set_defaults(func=_cmd_plugins)
    p = sub.add_parser("compare", help="run a Monte Carlo comparison from a TOML config")
    p.add_argument("file", help="comparison config (TOML)")
    p.add_argument("--runs", type=int, help="override the number of runs")
    p.add_argument("--seed", type=int, help="override the seed")
    p.add_argument("--out", help="output directory (default: results/<name>)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_compare)
    p = sub.add_parser("filter-positions", help="filter an NMEA position log (reference 004's filters)")
    p.add_argument("file", help="NMEA log with GGA and/or RMC sentences")
    p.add_argument("--out", required=True, help="output CSV")
    p.add_argument("--filter", default="AUKF1", choices=["UKF", "UKF1", "AUKF", "AUKF1"])
    p.add_argument("--psi", type=float, default=0.95, help="AR(1) coefficient for the colored filters")
    p.set_defaults(func=_cmd_filter_positions)
    p = sub.add_parser("schema", help="print the JSON schema of comparison configs")
    p.set_defaults(func=_cmd_schema)
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
