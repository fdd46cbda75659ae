"""Command-line interface: ``gnssframework <command>``."""

from __future__ import annotations

import argparse
import errno
import sqlite3
import sys
from pathlib import Path
from typing import Sequence

from . import registry
from .errors import ConfigError, DataFileError, GnssFrameworkError
from .io.nmea import MAX_ABS_HEIGHT_M, MAX_SPEED_MPS
from .io.rinex import PSEUDORANGE_MAX_M, PSEUDORANGE_MIN_M
from .io.skipped import EXIT_STATUS_HELP

__all__ = ["main"]


def _cmd_plugins(args: argparse.Namespace) -> int:
    if args.describe:
        from .plugin_docs import describe_plugin

        matches = [k for k in ([args.kind] if args.kind else registry.kinds())
                   if args.describe in registry.names(k)]
        if not matches:
            if args.kind:  # the registry words it: known names of that kind, the closest one
                registry.get(args.kind, args.describe)
            every = sorted({n for k in registry.kinds() for n in registry.names(k)})
            import difflib

            close = difflib.get_close_matches(args.describe, every, n=1, cutoff=0.4)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ConfigError("--describe", f"no plugin named {args.describe!r}{hint}")
        print("\n\n".join(describe_plugin(k, registry.get(k, args.describe)) for k in matches))
        return 0
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
    try:
        summary = run_comparison(config, out, progress=not args.quiet)
    except sqlite3.DatabaseError as exc:  # sqlite3 does not say which file: name the store
        raise _store_error(exc, Path(out) / "results.sqlite") from None
    print(f"wrote {summary}, {summary.parent / 'report.md'} and {summary.parent / 'plots'}/")
    return 0


def _store_error(exc: sqlite3.DatabaseError, store: Path) -> Exception:
    """An SQLite failure as the error that names the store: a full disk or a read-only
    store as the OS error it is, anything else as a damaged store."""
    text = str(exc)
    if "full" in text:
        return OSError(errno.ENOSPC, text, str(store))
    if "readonly" in text or "unable to open" in text:
        return OSError(errno.EACCES, text, str(store))
    return DataFileError(str(store), None, f"results store: {text} (a corrupted store: move it away or choose "
                         "another --out)")


def _cmd_filter_positions(args: argparse.Namespace) -> int:
    from .io.nmea import read_nmea
    from .io.positions import filter_positions, write_positions_csv
    from .io.skipped import exit_status, print_skipped, write_skipped_report

    fixes = read_nmea(args.file, max_speed_mps=args.max_speed, strict=args.strict, max_abs_height_m=args.max_height)
    lat, lon, _, _ = filter_positions(fixes, args.filter, args.psi)
    write_positions_csv(args.out, fixes, lat, lon)
    sidecar = write_skipped_report(args.out, args.file, fixes.skipped)
    print(f"{args.file}: {fixes.time_s.size} fixes filtered with {args.filter}, {len(fixes.skipped)} sentences "
          f"skipped; wrote {args.out}" + (f" and {sidecar}" if fixes.skipped else ""))
    print_skipped(fixes.skipped)
    return exit_status(fixes.skipped)


def _cmd_smooth(args: argparse.Namespace) -> int:
    import csv

    import numpy as np

    from .experiments.files import atomic_open
    from .interfaces import RunContext
    from .io.rinex import read_code_carrier
    from .io.skipped import exit_status, print_skipped, write_skipped_report

    data = read_code_carrier(args.file, args.prn, pseudorange_min_m=args.pseudorange_min,
                             pseudorange_max_m=args.pseudorange_max, strict=args.strict)
    params = {"hatch": ("hatch", {"window": args.window}),
              "kf": ("kf-smoother", {"q": args.q, "r": args.r}),
              "adaptive-kf": ("kf-smoother", {"q": args.q, "r": args.r, "adapter": "ml-q",
                                              "adapter_params": {"window": 10, "warmup": 20, "q_ceiling": 1e4}})}
    name, kw = params[args.filter]
    if args.slip_threshold:
        kw["slip_threshold_m"] = args.slip_threshold
    smoother = registry.create("channel_filter", name, **kw)
    steps = np.diff(np.asarray(data.time_s, float))
    interval = float(np.median(steps)) if steps.size and np.median(steps) > 0 else None
    smoother.reset((), RunContext(epoch_interval_s=interval))
    rows = [smoother.checked_step({"pseudorange_m": np.asarray(r), "carrier_m": np.asarray(c)})
            for r, c in zip(data.pseudorange_m, data.carrier_m)]
    with atomic_open(args.out, "w", newline="") as fh:  # a killed run leaves no half CSV
        w = csv.writer(fh)
        w.writerow(["epoch", "time_s", "pseudorange_m", "carrier_m", "smoothed_m", "slip_detected"])
        for ep, t, r, c, out in zip(data.epoch, data.time_s, data.pseudorange_m, data.carrier_m, rows):
            w.writerow([str(ep), f"{t:.3f}", f"{r:.3f}", f"{c:.4f}", f"{float(out['smoothed_m']):.4f}",
                        int(bool(out["slip_detected"]))])
    sidecar = write_skipped_report(args.out, args.file, data.skipped)
    slips = sum(int(bool(o["slip_detected"])) for o in rows)
    print(f"{args.file} {args.prn}: {len(rows)} epochs smoothed with {args.filter}"
          + (f", {slips} slips detected" if args.slip_threshold else "")
          + f", {len(data.skipped)} epochs or observations skipped; wrote {args.out}"
          + (f" and {sidecar}" if data.skipped else ""))
    if data.truncated:
        print(f"  TRUNCATED FILE: {data.truncated}; the output covers the epochs before the cut")
    print_skipped(data.skipped)
    return exit_status(data.skipped, truncated=data.truncated is not None)


def _cmd_schema(args: argparse.Namespace) -> int:
    import json

    from .config_schema import comparison_schema

    print(json.dumps(comparison_schema(), indent=2))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="gnssframework", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("plugins", help="list the registered plugins")
    p.add_argument("--kind", choices=registry.kinds(), help="only this kind")
    p.add_argument("--describe", metavar="NAME", help="one plugin's description, contract and parameter table")
    p.set_defaults(func=_cmd_plugins)
    p = sub.add_parser("compare", help="run a Monte Carlo comparison from a TOML config")
    p.add_argument("file", help="comparison config (TOML)")
    p.add_argument("--runs", type=int, help="override the number of runs")
    p.add_argument("--seed", type=int, help="override the seed")
    p.add_argument("--out", help="output directory (default: results/<name>)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_compare, interrupt_hint="; finished batches are kept in --out and the same command "
                                                     "resumes")
    p = sub.add_parser("filter-positions", help="filter an NMEA position log (Liu et al. 2020's filters)",
                       description="Filter the horizontal track of an NMEA log. Corrupted sentences, impossible "
                                   "positions, duplicated or backwards timestamps and implausible jumps are skipped "
                                   "and listed (line and reason) on stdout and in <out>.skipped.csv.",
                       epilog=EXIT_STATUS_HELP)
    p.add_argument("file", help="NMEA log with GGA and/or RMC sentences")
    p.add_argument("--out", required=True, help="output CSV")
    p.add_argument("--filter", default="AUKF1", choices=["UKF", "UKF1", "AUKF", "AUKF1"])
    p.add_argument("--psi", type=float, default=0.95, help="AR(1) coefficient for the colored filters")
    p.add_argument("--max-speed", type=float, default=MAX_SPEED_MPS, metavar="M/S",
                   help="jump check: skip a fix further from the last accepted one than this speed allows "
                        "(default %(default)g m/s)")
    p.add_argument("--max-height", type=float, default=MAX_ABS_HEIGHT_M, metavar="M",
                   help="skip a GGA whose altitude is not a number or above this in magnitude (default %(default)g m)")
    p.add_argument("--strict", action="store_true", help="refuse the file at the first bad sentence (exit 2)")
    p.set_defaults(func=_cmd_filter_positions)
    p = sub.add_parser("smooth", help="carrier-smooth one satellite's code from a RINEX observation file",
                       description="Carrier-smooth one satellite's C1C with its L1C. Duplicated and backwards epochs, "
                                   "pseudoranges outside the plausibility bounds and an epoch cut by a truncated "
                                   "file are skipped and listed (line and reason) on stdout and in "
                                   "<out>.skipped.csv.",
                       epilog=EXIT_STATUS_HELP)
    p.add_argument("file", help="RINEX 3 observation file with C1C and L1C")
    p.add_argument("--prn", required=True, help="satellite, e.g. G08")
    p.add_argument("--out", required=True, help="output CSV")
    p.add_argument("--filter", default="hatch", choices=["hatch", "kf", "adaptive-kf"])
    p.add_argument("--window", type=int, default=100, help="Hatch window (epochs)")
    p.add_argument("--q", type=float, default=1e-3, help="Kalman smoother Q (m^2)")
    p.add_argument("--r", type=float, default=1.25, help="Kalman smoother R (m^2)")
    p.add_argument("--slip-threshold", type=float, default=0.0, help="code-minus-carrier slip test (m), 0: off")
    p.add_argument("--pseudorange-min", type=float, default=PSEUDORANGE_MIN_M, metavar="M",
                   help="skip a pseudorange below this (default %(default)g m)")
    p.add_argument("--pseudorange-max", type=float, default=PSEUDORANGE_MAX_M, metavar="M",
                   help="skip a pseudorange above this (default %(default)g m)")
    p.add_argument("--strict", action="store_true",
                   help="refuse the file at the first bad epoch or observation, or a truncation (exit 2)")
    p.set_defaults(func=_cmd_smooth)
    p = sub.add_parser("schema", help="print the JSON schema of comparison configs")
    p.set_defaults(func=_cmd_schema)
    return parser


#: OS errors caused by a path the user gave (exit 2, like other input errors); any other
#: OS error (a full disk...) exits 1.
_PATH_ERRNOS = {errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOENT, errno.ENOTDIR, errno.EISDIR, errno.EEXIST,
                errno.ENAMETOOLONG, errno.ELOOP}
_HINTS = {errno.EACCES: "not writable or readable by this user; choose another path",
          errno.EPERM: "not permitted; choose another path",
          errno.EROFS: "on a read-only file system; choose another path",
          errno.ENOSPC: "no space left on the device; free some or choose another --out (finished batches are "
                        "kept and a rerun resumes)",
          errno.EDQUOT: "disk quota exceeded; free some or choose another --out"}


def os_error_message(exc: OSError) -> str:
    """One line for an OS-level failure: the path, what went wrong, what to do."""
    message = exc.strerror or str(exc) or type(exc).__name__
    if exc.filename is not None:
        message = f"{exc.filename}: {message}"
    hint = _HINTS.get(exc.errno or 0)
    return f"{message} ({hint})" if hint else message


def _fail(message: str, status: int) -> int:
    print(f"error: {message}", file=sys.stderr)
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code. Library errors print one line, no traceback:
    exit 2 for configuration and input errors (a bad path included), 1 for other OS
    failures (a full disk), 130 for Ctrl-C."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except GnssFrameworkError as exc:
        return _fail(str(exc), 2)
    except KeyboardInterrupt:
        return _fail("interrupted (Ctrl-C)" + getattr(args, "interrupt_hint", ""), 130)
    except OSError as exc:
        return _fail(os_error_message(exc), 2 if exc.errno in _PATH_ERRNOS else 1)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
