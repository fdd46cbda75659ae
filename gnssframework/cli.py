"""Command-line interface: ``gnssframework <command>``."""

from __future__ import annotations

import argparse
import errno
import re
import sqlite3
import sys
import warnings
from contextlib import contextmanager
from pathlib import Path
from collections.abc import Callable, Iterable, Iterator, Sequence

from . import registry
from .errors import ConfigError, DataFileError, GnssFrameworkError, GnssFrameworkWarning
from .io.nmea import MAX_ABS_HEIGHT_M, MAX_SPEED_MPS
from .io.rinex import PSEUDORANGE_MAX_M, PSEUDORANGE_MIN_M
from .io.skipped import EXIT_STATUS_HELP
from .signal.gps_l1ca import GPS_L1CA
from .signal.spec import SignalSpec
from .io.smoothing import MAX_CMC_RATE_MPS, SMOOTHERS

__all__ = ["main"]


def _cmd_plugins(args: argparse.Namespace) -> int:
    if args.describe:
        from .plugin_docs import describe_plugin

        matches = [k for k in ([args.kind] if args.kind else registry.kinds()) if args.describe in registry.names(k)]
        if not matches:
            if args.kind:  # the registry words it: known names of that kind, the closest one
                registry.get(args.kind, args.describe)
            every = sorted({n for k in registry.kinds() for n in registry.names(k)})
            from .suggest import did_you_mean

            raise ConfigError(
                "--describe", f"no plugin named {args.describe!r}{did_you_mean(args.describe, every, cutoff=0.4)}"
            )
        print("\n\n".join(plain_text(describe_plugin(k, registry.get(k, args.describe))) for k in matches))
        return 0
    rows = [("KIND", "NAME", "DESCRIPTION", "SOURCE")]
    for info in registry.describe():
        if args.kind and info.kind != args.kind:
            continue
        rows.append((info.kind, info.name, plain_text(info.description), f"{info.distribution} {info.version}".strip()))
    if len(rows) == 1:
        print(f"no {args.kind} plugin is registered" if args.kind else "no plugin is registered")
        for failure in registry.failures():
            print(f"failed to load: {failure}", file=sys.stderr)
        return 0
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    for r in rows:
        print(f"{r[0]:<{widths[0]}}  {r[1]:<{widths[1]}}  {r[2]:<{widths[2]}}  {r[3]}")
    for failure in registry.failures():
        print(f"failed to load: {failure}", file=sys.stderr)
    return 0


def _cmd_compare(args: argparse.Namespace) -> int:
    from .experiments import load_config, run_comparison

    try:
        config = load_config(args.file, runs=args.runs, seed=args.seed)
    except ConfigError as exc:  # the case or candidate named as written, beside its index
        from .experiments.config import with_names
        from .experiments.config_base import read_config_data

        try:
            data = read_config_data(args.file)
        except ConfigError:  # the error is the file's own or its [base]'s: as it is
            data = {}
        raise with_names(exc, data) from None
    if args.dask_address:  # a scheduler address comes from the person running the comparison, not the config
        config.executor = config.executor.model_copy(update={"kind": "dask", "address": args.dask_address})
    out = args.out or f"results/{config.name}"
    if args.check:  # a claim over too few runs, undeclared, is refused before the work, not after
        from .experiments.claims import small_n_refusal, unstated_small_n_claims

        refused = unstated_small_n_claims(config)
        for i in refused:
            print(
                f"error: {small_n_refusal(config.name, i, config.claims[i].statement(), config.runs)}", file=sys.stderr
            )
        if refused:
            return 1
    _print_work_estimate(config)
    try:
        # A bar on a terminal, a line per tenth of the batches in a log or a pipe.
        summary = run_comparison(
            config,
            out,
            progress=not args.quiet,
            replicate=args.replicate,
            trials_from=args.trials_from,
            figures=(lambda name: False) if args.no_plots else None,
        )
    except sqlite3.DatabaseError as exc:  # sqlite3 does not say which file: name the store
        raise _store_error(exc, Path(out) / "results.sqlite") from None
    plots = "" if args.no_plots else f" and {summary.parent / 'plots'}/"
    print(f"wrote {summary}, {summary.parent / 'report.md'}{plots}")
    return _report_claims(summary, args.check)


#: A comparison of more batches than this says how much work it is before it starts.
LONG_COMPARISON_BATCHES = 100


def _print_work_estimate(config) -> None:
    """One line before a long comparison: its batches and filter runs (from scratch)."""
    from .experiments.runner import work_estimate

    batches, runs = work_estimate(config)
    if batches > LONG_COMPARISON_BATCHES:
        print(
            f"work: {batches:,} batches, {runs:,} filter runs ({len(config.cases)} cases x "
            f"{len(config.candidates)} candidates x {config.runs} runs, {len(config.sweeps)} sweeps"
            + (", tuning" if config.tuning is not None else "")
            + (", refined sweeps add points after their grids" if any(s.refine for s in config.sweeps) else "")
            + "); finished batches are kept, Ctrl-C and the "
            "same command resumes",
            flush=True,
        )


def _report_claims(summary, check: bool) -> int:
    """Print the claims' outcomes (all with ``--check``, else a tally); 1 if checked and one
    does not hold, was stated to replicate and does not hold on the replicate runs
    (`replication_failed`), or is over fewer than 12 runs without declaring ``small_n``."""
    from .experiments.claims import claim_line, claim_where, replication_failed, small_n_refusal, unstated_small_n
    from .io.files import loads_strict

    data = loads_strict(summary.read_text())
    claims = data.get("claims", [])
    if not claims:
        if check:
            print("no [[claims]] in this config: nothing to check")
        return 0
    bad = [c for c in claims if c["outcome"] != "holds" or replication_failed(c)]
    one_set = sum(c.get("replicates") is False and "replicate_outcome" in c for c in claims)
    print(
        f"claims: {len(claims) - len(bad)} of {len(claims)} hold"
        + (" on both seed sets" if any("replicate_outcome" in c for c in claims) else "")
        + (f" as stated ({one_set} stated to hold on the evaluation runs only)" if one_set else "")
    )
    for c in claims if check else bad:
        print("  " + claim_line(c))
    for c in claims:  # a claim that cannot be tested: one line naming it
        if c["outcome"] == "refused":
            print(f"error: claims[{c['claim']}] in {claim_where(c)} refused: {c.get('reason', '')}", file=sys.stderr)
    unstated = unstated_small_n(claims) if check else []
    for c in unstated:  # over fewer runs than the config's (missing values): one line per claim
        print(
            f"error: {small_n_refusal(data.get('name', summary.parent.name), c['claim'], c['statement'], c['n'])}",
            file=sys.stderr,
        )
    return 1 if check and (bad or unstated) else 0


def _store_error(exc: sqlite3.DatabaseError, store: Path) -> Exception:
    """An SQLite failure as the error that names the store: a full disk or a read-only
    store as the OS error it is, anything else as a damaged store."""
    text = str(exc)
    if "full" in text:
        return OSError(errno.ENOSPC, text, str(store))
    if "readonly" in text or "unable to open" in text:
        return OSError(errno.EACCES, text, str(store))
    return DataFileError(
        str(store), None, f"results store: {text} (a corrupted store: move it away or choose another --out)"
    )


def _cmd_filter_positions(args: argparse.Namespace) -> int:
    from .io.nmea import read_nmea
    from .io.positions import composition, filter_positions, write_positions_csv
    from .io.skipped import exit_status, print_skipped, write_skipped_report

    fixes = read_nmea(args.file, max_speed_mps=args.max_speed, strict=args.strict, max_abs_height_m=args.max_height)
    lat, lon, _, _ = filter_positions(fixes, composition(args.filter, args.noise_adapter, args.augmentation), args.psi)
    write_positions_csv(args.out, fixes, lat, lon)
    sidecar = write_skipped_report(args.out, args.file, fixes.skipped)
    print(
        f"{args.file}: {fixes.time_s.size} fixes filtered with {args.filter}, {len(fixes.skipped)} sentences "
        f"skipped; wrote {args.out}" + (f" and {sidecar}" if fixes.skipped else "")
    )
    if fixes.ignored or fixes.comments:
        kinds = ", ".join(f"{n} {kind}" for kind, n in fixes.ignored.items())
        print(f"  not used: {kinds or 'no sentences'}; {fixes.comments} comment lines")
    print_skipped(fixes.skipped)
    return exit_status(fixes.skipped)


def _cmd_smooth_positions(args: argparse.Namespace) -> int:
    from .io.nmea import read_nmea
    from .io.positions import composition, smooth_positions, write_smoothed_positions_csv
    from .io.skipped import exit_status, print_skipped, write_skipped_report

    fixes = read_nmea(args.file, max_speed_mps=args.max_speed, strict=args.strict, max_abs_height_m=args.max_height)
    track = smooth_positions(fixes, composition(args.filter, args.noise_adapter, args.augmentation), args.psi)
    write_smoothed_positions_csv(args.out, fixes, track)
    sidecar = write_skipped_report(args.out, args.file, fixes.skipped)
    print(
        f"{args.file}: {fixes.time_s.size} fixes smoothed (forward {args.filter}, then RTS), "
        f"{len(fixes.skipped)} sentences skipped; wrote {args.out}" + (f" and {sidecar}" if fixes.skipped else "")
    )
    print_skipped(fixes.skipped)
    return exit_status(fixes.skipped)


def _blank_nan(value: float, digits: int) -> str:
    """A CSV cell: the value, or empty where there is none."""
    return f"{value:.{digits}f}" if value == value else ""


def _cmd_smooth(args: argparse.Namespace) -> int:
    import csv

    import numpy as np

    from .io.files import atomic_open
    from .io.observations import normalise_select, read_observations
    from .io.skipped import exit_status, print_skipped, write_skipped_report
    from .io.skipped import EXIT_SKIPPED
    from .io.smoothing import smooth_observations

    args.prn = normalise_select(args.prn)
    obs = read_observations(
        args.file,
        args.prn,
        pseudorange_min_m=args.pseudorange_min,
        pseudorange_max_m=args.pseudorange_max,
        strict=args.strict,
    )
    name = SMOOTHERS[args.filter]["name"]
    takes = registry.get("channel_filter", name).Params.model_fields
    kw = {
        **{k: v for k, v in (("window", args.window), ("q", args.q), ("r", args.r)) if k in takes},
        **SMOOTHERS[args.filter]["params"],
    }
    if args.slip_threshold:
        kw["slip_threshold_m"] = args.slip_threshold
    registry.create("channel_filter", name, **kw)  # a bad parameter fails before the run
    result = smooth_observations(
        obs,
        lambda: registry.create("channel_filter", name, **kw),
        args.max_gap,
        reset_at_lli=not args.ignore_lli,
        max_cmc_rate_mps=args.max_cmc_rate,
    )
    valid = obs.valid
    with atomic_open(args.out, "w", newline="") as fh:  # a killed run leaves no half CSV
        w = csv.writer(fh)
        w.writerow(
            [
                "epoch",
                "sv",
                "time_s",
                "pseudorange_m",
                "carrier_m",
                "smoothed_m",
                "lli",
                "snr_dbhz",
                "arc_start",
                "slip_detected",
            ]
        )
        for k, j in zip(*np.nonzero(valid)):
            w.writerow(
                [
                    str(obs.epoch[k]),
                    obs.sv[j],
                    f"{obs.time_s[k]:.7f}",
                    f"{obs.pseudorange_m[k, j]:.3f}",
                    f"{obs.carrier_m[k, j]:.4f}",
                    _blank_nan(result.smoothed_m[k, j], 4),
                    int(obs.lli[k, j]),
                    _blank_nan(obs.snr_dbhz[k, j], 2),
                    int(result.arc_start[k, j]),
                    int(result.slip_detected[k, j]),
                ]
            )
    sidecar = write_skipped_report(args.out, args.file, obs.skipped)
    flagged = int(((obs.lli & 1) != 0)[valid].sum())
    print(
        f"{args.file} {args.prn}: {int(valid.sum())} epochs of {obs.sv.size} satellites smoothed with "
        f"{args.filter} in {result.arcs} arcs ({flagged} loss-of-lock flags"
        + (" ignored" if args.ignore_lli else "")
        + f", gaps over {result.max_gap_s:g} s)"
        + (
            f", {int(result.slip_detected.sum())} slips detected by the filter "
            f"({int((result.slip_detected & (obs.lli & 1 != 0)).sum())} of them at a receiver's flag)"
            if args.slip_threshold
            else ""
        )
        + f", {len(obs.skipped)} epochs or observations skipped; wrote {args.out}"
        + (f" and {sidecar}" if obs.skipped else "")
    )
    for sv, why in obs.dropped.items():
        print(f"  not read: {sv}: {why}")
    for sv, row, rate in result.inconsistent:
        print(
            f"  not smoothed (smoothed_m empty): {sv}'s arc from {obs.epoch[row]}: code minus carrier drifts "
            f"{rate:.3g} m/s (over --max-cmc-rate {args.max_cmc_rate:g}): its carrier does not follow the code"
        )
    if obs.truncated:
        print(f"  TRUNCATED FILE: {obs.truncated}; the output covers the epochs before the cut")
    print_skipped(obs.skipped)
    status = exit_status(obs.skipped, truncated=obs.truncated is not None)
    return EXIT_SKIPPED if status == 0 and result.inconsistent else status


def _cmd_schema(args: argparse.Namespace) -> int:
    import json

    from .config_schema import comparison_schema

    print(json.dumps(comparison_schema(), indent=2))
    return 0


def _open_recording_from_args(args: argparse.Namespace):
    from .receiver.frontend import open_recording
    from .receiver.frontend.stream_io import is_stream_address

    if hasattr(args, "realtime") and is_stream_address(args.recording):  # receive's live input
        return _open_stream_from_args(args)
    if not Path(args.recording).exists():  # the wording every command uses for a missing file
        raise DataFileError(args.recording, None, "no such file")
    if not Path(args.recording).is_file():
        raise DataFileError(
            args.recording, None, "not a regular file (a device, pipe or folder): give a file of recorded samples"
        )
    names = getattr(args, "signal", None)  # receive's may list several, all on one carrier
    return open_recording(
        args.recording,
        format=args.format,
        sample_rate_hz=args.fs,
        if_hz=args.if_hz,
        q_sign=args.q_sign,
        **({"signal": registry.signal_spec(names.split(",")[0])} if names else {}),
    )


def _open_stream_from_args(args: argparse.Namespace):
    """``receive``'s live input (`frontend.stream.open_stream`): --format and --fs needed
    (cu8 by default from rtl_tcp); overruns announced on standard error as they begin."""
    from .receiver.frontend.soapy_io import SOAPY_FORMAT, SOAPY_SCHEME, SoapySettings
    from .receiver.frontend.stream import open_stream
    from .receiver.frontend.stream_io import RTL_TCP_FORMAT, RtlTcpSettings

    rtl = args.recording.startswith("rtl_tcp://")
    soapy = args.recording.startswith(SOAPY_SCHEME)
    fmt = args.format or (RTL_TCP_FORMAT if rtl else SOAPY_FORMAT if soapy else None)
    if fmt is None or args.fs is None:
        raise ConfigError(
            "--format" if fmt is None else "--fs",
            f"{args.recording}: a stream has no SigMF metadata: give --format and --fs",
        )
    if not (rtl or soapy) and (args.center_freq is not None or args.gain is not None):
        raise ConfigError(
            "--center-freq" if args.center_freq is not None else "--gain",
            "tunes an rtl_tcp:// server or a soapy:// device only",
        )
    if args.tracking == "vector":
        raise ConfigError("--tracking", "live input runs scalar tracking (vector tracking reads a file)")
    announced = []

    def overrun(first: int, count: int) -> None:
        if not announced:
            announced.append(first)
            print(
                f"overrun: the receiver lags the stream: samples dropped from {first / args.fs:.3f} s of signal "
                "(counted; the channels re-acquire after each gap)",
                file=sys.stderr,
                flush=True,
            )

    settings = (
        RtlTcpSettings(args.center_freq, args.fs, None if args.gain is None else round(10 * args.gain)) if rtl else None
    )
    return open_stream(
        args.recording,
        fmt,
        args.fs,
        args.if_hz or 0.0,
        args.q_sign or 1,
        realtime=args.realtime,
        buffer_s=args.buffer_s,
        rtl_tcp=settings,
        soapy=SoapySettings(args.fs, args.center_freq, args.gain) if soapy else None,
        on_overrun=overrun,
    )


def _add_live_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("live input and output (docs: Live input)")
    g.add_argument(
        "--realtime",
        action="store_true",
        help="with a stream (-, a FIFO, tcp://HOST:PORT, rtl_tcp://HOST:PORT, soapy://ARGS): drop whole blocks the "
        "receiver cannot take in time, counted and reported as overruns, instead of holding the "
        "producer back (the default)",
    )
    g.add_argument(
        "--buffer-s",
        type=float,
        default=1.0,
        metavar="S",
        help="signal queued between the stream reader and the receiver (default %(default)s)",
    )
    g.add_argument("--center-freq", type=float, metavar="HZ", help="rtl_tcp or soapy: tune to HZ (e.g. 1575420000)")
    g.add_argument("--gain", type=float, metavar="DB", help="rtl_tcp or soapy: manual tuner gain (default automatic)")
    g.add_argument(
        "--nmea-out",
        metavar="DEST",
        help="send GGA and RMC as fixes come: - (standard output; the messages go to standard error) "
        "or tcp://[HOST]:PORT (a server for gpsd and other clients)",
    )


def _acquisition_from_args(args: argparse.Namespace):
    params = {
        k: v
        for k, v in (
            ("coherent_ms", args.coherent_ms),
            ("noncoherent", args.noncoherent),
            ("doppler_max_hz", args.doppler_max),
            ("pfa", args.pfa),
        )
        if v is not None
    }
    if getattr(args, "alternate_blocks", False):
        params["alternate_blocks"] = True
    if getattr(args, "weak", False):  # the weak search, where no option says otherwise
        params = {**WEAK_SEARCH, **params}
    if getattr(args, "code_doppler", False):
        params["code_doppler"] = True
    if getattr(args, "boc_search", None) is not None:
        params["boc_search"] = args.boc_search
    from .receiver.acquisition.search import check_contract

    return check_contract(registry.create("acquisition", args.acquisition, **params))


#: How the command line names a signal in its messages (else by `SignalSpec.name`).
_SIGNAL_LABEL = {"gps-l1ca": "GPS C/A"}


def _prns_from_args(args: argparse.Namespace, signal: SignalSpec = GPS_L1CA) -> tuple[int, ...]:
    """``--prns`` checked against ``signal``'s PRNs (all of them without the option)."""
    prns = tuple(args.prns) if args.prns else signal.prns
    bad = [p for p in prns if p not in signal.prns]
    if bad:
        raise ConfigError(
            "--prns",
            f"{_SIGNAL_LABEL.get(signal.name, signal.name)} PRNs are {min(signal.prns)}-{max(signal.prns)}, got {bad}",
        )
    repeated = sorted({p for p in prns if prns.count(p) > 1})
    if repeated:
        raise ConfigError(
            "--prns", f"PRN {', '.join(map(str, repeated))} given more than once: each PRN is searched once"
        )
    return prns


#: ``--signal``'s default: GPS L1 C/A.
DEFAULT_SIGNAL = "gps-l1ca"


def _signal_from_args(args: argparse.Namespace) -> SignalSpec:
    """The `SignalSpec` of ``--signal`` (a registered ``signal`` plugin; GPS L1 C/A by default)."""
    return registry.signal_spec(getattr(args, "signal", None) or DEFAULT_SIGNAL)


def _acquire_checked(rec, acq, prns: tuple[int, ...], signal: SignalSpec = GPS_L1CA) -> list:
    """The acquisition of ``prns`` of ``signal`` in ``rec`` (``acquire``, ``track`` and ``receive``),
    refused when the samples are too few or the result is implausible (`check_samples`,
    `check_acquisition`: a wrong --format "finds" 31 satellites), with a note of the
    non-finite samples zeroed."""
    from .receiver.acquisition.plausibility import check_acquisition, check_samples
    from .receiver.acquisition.report import acquire_recording

    check_samples(rec, acq, signal)
    results = acquire_recording(rec, acq, prns, signal=signal)
    _note_nonfinite(rec)
    check_acquisition(results, rec, acq, signal)
    return results


def _cmd_acquire(args: argparse.Namespace) -> int:
    from .receiver.acquisition.report import search_summary, write_acquisition_csv

    rec = _open_recording_from_args(args)
    acq = _acquisition_from_args(args)
    signal = _signal_from_args(args)
    prns = _prns_from_args(args, signal)
    results = _acquire_checked(rec, acq, prns, signal)
    if rec.trailing_bytes:
        print(f"note: {rec.path.name} ends with {rec.trailing_bytes} bytes of a cut sample, not read")
    if args.verbose:
        for r in results:
            print(
                f"PRN {r.prn:2d}: statistic {r.test_statistic:8.2f} (threshold {r.threshold:.2f}) "
                f"{'FOUND' if r.detected else 'no'}  doppler {r.doppler_hz:8.1f} Hz  code phase "
                f"{r.code_phase_chips:8.3f} chips  C/N0 {r.cn0_dbhz:5.1f} dB-Hz"
            )
    write_acquisition_csv(args.out, results)
    found = [r for r in results if r.detected]
    if not found:
        print(
            f"nothing found: {search_summary(rec, acq, prns, signal)}. Check the sample rate (--fs), the IF "
            "(--if), the format (--format) and, for a large frequency offset, --doppler-max; wrote an empty "
            f"{args.out}"
        )
        return 1
    print(f"{len(found)} satellites found ({', '.join(str(r.prn) for r in found)}); wrote {args.out}")
    return 0


def _note_nonfinite(rec) -> None:
    """Say how many NaN/inf values the reads so far zeroed (a float recording's gaps)."""
    if rec.nonfinite_zeroed:
        print(
            f"note: {rec.path.name}: {rec.nonfinite_zeroed} non-finite values (NaN or inf) in the samples read were "
            "set to 0"
        )


def _long_symbols(signal: SignalSpec) -> bool:
    """Whether ``signal``'s message is read from one code period a row (E1-B's 4 ms I/NAV
    symbols; L2 CM's CNAV; the overlaid 1 ms rows of L5 I5, E5a-I and B1I): its tracking then
    takes the settings its description implies (`_tracking_config_from_args`), where GPS L1
    C/A keeps the command's defaults."""
    from .receiver.navigation.cnav_stream import carries_cnav
    from .receiver.navigation.inav_stream import carries_d1, carries_d2, carries_fnav, carries_inav

    return any(f(signal) for f in (carries_inav, carries_cnav, carries_fnav, carries_d1, carries_d2))


def _tracking_config_from_args(args: argparse.Namespace, signal: SignalSpec | None = None):
    """The tracking settings of ``track`` and ``position`` (a command without an option
    leaves its default), and ``--duration`` checked. With ``signal``, what its description
    implies under the options given (`channels.signal_settings.signal_tracking_settings`:
    the coherent time dividing its data symbol, the pull-in loops of a long code period, the
    taps of a BOC or time-slotted component)."""
    import json

    from .receiver.channels import tracking_config
    from .receiver.channels.signal_settings import signal_tracking_settings

    try:
        params = json.loads(args.channel_params) if args.channel_params else {}
    except json.JSONDecodeError as exc:
        raise ConfigError("--channel-params", f"not JSON: {exc.msg}") from None
    settings = {"channel_filter": args.channel_filter, "channel_params": params}
    if getattr(args, "weak", False):  # the weak preset under every option given
        from .receiver.channels.config import weak_signal_settings

        settings = weak_signal_settings(settings)
    for option, key in (
        ("coherent_ms_track", "coherent_ms"),
        ("cn0_estimator", "cn0_estimator"),
        ("early_late_spacing", "early_late_spacing_chips"),
    ):
        if getattr(args, option, None) is not None:
            settings[key] = getattr(args, option)
    if signal is not None:
        settings = signal_tracking_settings(signal, settings)
    if args.duration is not None and not args.duration >= MIN_DURATION_S:
        raise ConfigError(
            "--duration", f"must be at least {MIN_DURATION_S:g} s (tracking's first intervals), got {args.duration:g}"
        )
    return tracking_config(**settings)


#: ``--weak``'s search: 10 ms blocks by parity following the code Doppler, 9 pairs (what
#: `threshold.blocks_for_detection` asks for 30 dB-Hz at Pd 0.9 and pfa 1e-3 over +-5 kHz
#: at 2.6 MHz, with 2.8 dB of worst straddle loss).
WEAK_SEARCH = {"coherent_ms": 10, "noncoherent": 18, "alternate_blocks": True, "code_doppler": True}

#: Shortest ``--duration`` of ``track`` and ``receive``: the pull-in stage's first
#: 1 ms intervals; less tracks nothing and reports NaN.
MIN_DURATION_S = 0.02


def max_rate_hz(signals: Iterable[SignalSpec]) -> float:
    """Largest ``--rate`` (solutions per second): one per code period of the slowest signal,
    the shortest interval its channels deliver a measurement at (1 kHz on GPS L1 C/A,
    250 Hz on Galileo E1)."""
    return min(1.0 / s.code_period_s for s in signals)


def _check_rate(rate_hz: float, signals: Iterable[SignalSpec]) -> None:
    """``--rate`` in (0, `max_rate_hz`], else a one-line error naming the limiting signal."""
    signals = tuple(signals)
    if not rate_hz > 0:
        raise ConfigError("--rate", f"must be > 0 Hz, got {rate_hz:g}")
    top = max_rate_hz(signals)
    if not rate_hz <= top:
        slowest = max(signals, key=lambda s: s.code_period_s)
        raise ConfigError(
            "--rate",
            f"must be at most {top:g} Hz (one solution per {slowest.code_period_s * 1e3:g} ms code period of "
            f"{slowest.name}), got {rate_hz:g}",
        )


def _both(first: Callable[[float], None] | None, second: Callable[[float], None] | None):
    """A progress callback calling both (either may be None)."""
    if first is None or second is None:
        return first or second
    return lambda fraction: (first(fraction), second(fraction))


@contextmanager
def _recording_progress(
    args: argparse.Namespace,
    rec=None,
    quiet: bool = False,
) -> Iterator[Callable[[float], None] | None]:
    """The tracker's progress callback (fraction of the recording done): a bar on a terminal,
    a line per tenth of the recording in a log or a pipe, none with ``--quiet`` (or
    ``quiet``: a live stream has no known length); with the recording ``rec``, the signal
    time processed and the real-time factor too."""
    from .progress import Progress

    if args.quiet or quiet:
        yield None
        return
    signal_s = None
    if rec is not None:
        signal_s = rec.duration_s if args.duration is None else min(float(args.duration), rec.duration_s)
    bar = Progress(100, Path(args.recording).name, "%", signal_s=signal_s)
    try:
        yield lambda fraction: bar.set(round(100 * fraction))
        bar.set(bar.total)  # the tracker reports up to its last block's start: the run is done
    finally:
        bar.close()


def _cmd_track(args: argparse.Namespace) -> int:
    from .receiver.acquisition.report import search_summary
    from .receiver.channels import SampleTracker
    from .receiver.channels.groups import track_in_groups
    from .receiver.channels.report import channel_summary, write_tracking_outputs
    from .receiver.navigation.cnav_stream import carries_cnav, write_cnav_report
    from .receiver.navigation.inav_stream import carries_d1, carries_d2, carries_fnav, carries_inav, write_inav_report
    from .receiver.navigation.sbas_stream import carries_sbas, write_sbas_report

    _threads_from_args(args)
    rec = _open_recording_from_args(args)
    acq = _acquisition_from_args(args)
    signal = _signal_from_args(args)
    prns = _prns_from_args(args, signal)
    config = _tracking_config_from_args(args, signal)
    tracker = SampleTracker(rec, config, acq, signal=signal)  # its stages' filters built once, here
    if rec.trailing_bytes:
        print(f"note: {rec.path.name} ends with {rec.trailing_bytes} bytes of a cut sample, not read")
    results = _acquire_checked(rec, acq, prns, signal)
    found = [r for r in results if r.detected]
    if not found:
        print(
            f"nothing found: {search_summary(rec, acq, prns, signal)}. Check the sample rate (--fs), the IF (--if), "
            "the format (--format) and --doppler-max; nothing tracked"
        )
        return 1
    with _recording_progress(args, rec) as progress:  # one process where there is one group
        result = track_in_groups(
            rec,
            config,
            acq,
            found,
            args.duration,
            workers=args.workers,
            signal=signal,
            filters=tracker.filters,
            progress=progress,
        )
    written = write_tracking_outputs(args.out, result, plots=not args.no_plots, signal=signal)
    print(f"tracked {len(found)} satellites for {result.duration_s:.3f} s with {config.channel_filter}:")
    for s in channel_summary(result, signal):
        print(
            f"  PRN {s['prn']:2d}: locked {100 * s['locked_fraction']:5.1f} % of {s['tracked_s']:.2f} s, "
            f"C/N0 {_or_none(s['cn0_dbhz_locked'], '5.1f')} dB-Hz, Doppler {_or_none(s['doppler_hz_last'], '9.1f')} "
            f"Hz, {s['final_stage']}"
        )
    # E1-B (4 ms symbols of I/NAV), E5a-I (20 ms of F/NAV), B1I (20 ms bits of D1)
    if carries_inav(signal) or carries_fnav(signal) or carries_d1(signal) or carries_d2(signal):
        path, inav_rows = write_inav_report(args.out, result, signal)
        message, kinds, time_name = (
            ("F/NAV", "page types", "GST")
            if carries_fnav(signal)
            else ("D1", "subframe IDs", "GPS time (BDT + 14 s)")
            if carries_d1(signal)
            else ("D2", "subframe IDs", "GPS time (BDT + 14 s)")
            if carries_d2(signal)
            else ("I/NAV", "word types", "GST")
        )
        written.append(path)
        for r in inav_rows:
            week = f"{time_name} week {r['gst_wn']} " if r["gst_wn"] != "" else f"{time_name} "  # F/NAV page 4: no week
            gst = (
                f"{week}TOW {r['gst_tow_s']} s at {float(r['gst_time_s']):.3f} s" if r["gst_tow_s"] != "" else "no GST"
            )
            print(
                f"  PRN {r['prn']:2d}: {message} {r['pages']} pages ({kinds} {r['word_types'] or 'none'}), "
                f"{r['crc_failures']} {'inconsistent' if message in ('D1', 'D2') else 'CRC failures'}, "
                f"{'AODE' if message in ('D1', 'D2') else 'IODnav'} {r['iodnav'] or 'none'}, {gst}"
                f"{', ephemeris complete' if r['ephemeris'] else ''}"
            )
    if carries_sbas(signal):  # SBAS L1: every 2 ms prompt after bit sync a symbol of the 250 bit/s message
        path, sbas_channels, notes = write_sbas_report(args.out, result, signal)
        written.append(path)
        for c in sbas_channels:
            good = c.good
            print(
                f"  PRN {c.prn:3d}: SBAS {len(good)} messages (types "
                f"{' '.join(str(m.message_type) for m in good) or 'none'}), {len(c.failures)} CRC failures"
            )
        for note in notes:
            print(f"note: {note}")
    if carries_cnav(signal):  # L2 CM: every 20 ms prompt a symbol of CNAV
        path, timings = write_cnav_report(args.out, result, signal)
        written.append(path)
        for t in timings:
            types = " ".join(str(m.msg_type) for m in t.messages)
            good = [m for m in t.messages if m.crc_ok]
            tow = f", TOW {good[-1].tow_s:.0f} s of the last" if good else ""
            print(
                f"  PRN {t.prn:2d}: CNAV {len(t.messages)} messages (types {types or 'none'}), "
                f"{len(t.failures)} CRC failures{tow}"
            )
    _note_nonfinite(rec)
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0


def _or_none(value: float, spec: str) -> str:
    """``value`` formatted, or ``"none"`` (right-aligned) where it is NaN (a channel that
    never locked has no locked C/N0): a summary line prints no ``nan``."""
    text = format(value, spec)
    return text if value == value and abs(value) != float("inf") else format("none", f">{len(text)}")


def _raim_from_args(args: argparse.Namespace):
    """``receive --raim [--raim-pfa P --raim-pmd P]`` as `integrity.RaimOptions` (None without --raim)."""
    if args.raim is None:
        for flag in ("raim_pfa", "raim_pmd"):
            if getattr(args, flag) is not None:
                raise ConfigError(f"--{flag.replace('_', '-')}", "is a setting of --raim: add --raim or drop it")
        return None
    from .navigation.integrity import RaimOptions

    given = {k: v for k, v in (("false_alarm", args.raim_pfa), ("missed_detection", args.raim_pmd)) if v is not None}
    return RaimOptions(method=args.raim, **given)


def _sbas_flag(args: argparse.Namespace) -> str | None:
    """The SBAS source flag given to ``receive`` (``--sbas-messages`` first), None for neither."""
    if getattr(args, "sbas_messages", None):
        return "--sbas-messages"
    return "--sbas-signal" if getattr(args, "sbas_signal", False) else None


def _sbas_from_args(args: argparse.Namespace):
    """``receive --sbas-messages FILE`` and/or ``--sbas-signal`` ``[--sbas-prn N --sbas-mode
    M --sbas-sigma-noise S]`` as `sbas_fixes.SbasOptions` (None without either)."""
    flag = _sbas_flag(args)
    if flag is None:
        for setting in ("sbas_prn", "sbas_mode", "sbas_sigma_noise"):
            if getattr(args, setting, None) is not None:
                raise ConfigError(
                    f"--{setting.replace('_', '-')}",
                    "is a setting of --sbas-messages or --sbas-signal: add one or drop this",
                )
        return None
    from .navigation.sbas_files import read_sbas_messages
    from .receiver.navigation.sbas_fixes import SbasOptions

    if args.raim or getattr(args, "tracking", None) == "vector" or getattr(args, "nav_filter", None):
        raise ConfigError(
            flag,
            "corrects the least-squares fixes of scalar tracking with DO-229's protection levels: "
            "not with --raim, --tracking vector or --nav-filter",
        )

    noise = {} if args.sbas_sigma_noise is None else {"sigma_noise_m": args.sbas_sigma_noise}
    records = tuple(read_sbas_messages(args.sbas_messages)) if args.sbas_messages else ()
    return SbasOptions(
        records, args.sbas_prn, args.sbas_mode or "pa", **noise, from_signal=bool(getattr(args, "sbas_signal", False))
    )


def _truth_from_args(args: argparse.Namespace) -> tuple[float, float, float] | None:
    if not args.truth:
        return None
    try:
        truth = tuple(float(v) for v in args.truth.split(","))
    except ValueError:
        truth = ()
    if len(truth) != 3:
        raise ConfigError("--truth", f"LAT,LON,H in degrees and metres, got {args.truth!r}")
    return _checked_position("--truth", truth)


#: Largest height of a --truth or --approx-position (m): above low Earth orbit is no receiver's place here.
MAX_POSITION_HEIGHT_M = 1.0e6


def _checked_position(option: str, where: tuple[float, float, float]) -> tuple[float, float, float]:
    """LAT, LON, H refused unless finite, |lat| <= 90, |lon| <= 180, |H| <= 1000 km."""
    lat, lon, h = where
    if not all(v == v and abs(v) != float("inf") for v in where):
        raise ConfigError(option, f"LAT,LON,H must be finite numbers, got {','.join(f'{v:g}' for v in where)}")
    if not -90 <= lat <= 90:
        raise ConfigError(option, f"latitude {lat:g} is outside [-90, 90] degrees")
    if not -180 <= lon <= 180:
        raise ConfigError(option, f"longitude {lon:g} is outside [-180, 180] degrees")
    if not abs(h) <= MAX_POSITION_HEIGHT_M:
        raise ConfigError(option, f"height {h:g} m is beyond +-{MAX_POSITION_HEIGHT_M:g} m")
    return where


def _assist_from_args(args: argparse.Namespace, nav_info=None):
    """`vector_tracking.Assistance` from ``--approx-position`` and ``--start-time`` (both or
    neither), with the Klobuchar coefficients of the ``--ephemeris`` file's header
    (``nav_info``, a `rinex_nav_header.NavFileInfo`) unless ``--no-iono``; a file whose
    records do not cover the start time is refused."""
    if not args.approx_position and not args.start_time:
        return None
    from .receiver.navigation.vector_tracking import assistance

    if not (args.approx_position and args.start_time):
        raise ConfigError("--approx-position", "give --approx-position and --start-time together")
    if args.tracking != "vector" or not args.ephemeris:
        raise ConfigError("--approx-position", "an assisted start is for --tracking vector with --ephemeris NAV")
    try:
        where = tuple(float(v) for v in args.approx_position.split(","))
    except ValueError:
        where = ()
    if len(where) != 3:
        raise ConfigError("--approx-position", f"LAT,LON,H in degrees and metres, got {args.approx_position!r}")
    where = _checked_position("--approx-position", where)
    try:
        week, tow = args.start_time.split(",")
        when = (int(week), float(tow))
    except ValueError:
        raise ConfigError(
            "--start-time", f"WEEK,TOW (full GPS week, seconds of week), got {args.start_time!r}"
        ) from None
    if nav_info is not None and not nav_info.covers(*when):
        raise ConfigError(
            "--ephemeris",
            f"the ephemeris does not cover the recording: its records span "
            f"{nav_info.dates()}, --start-time is week {when[0]}, tow {when[1]:g} s",
        )
    iono = nav_info.iono if nav_info is not None and not args.no_iono else None
    return assistance(where, *when, iono=iono)


def _rinex_version(args: argparse.Namespace) -> str | None:
    """navigation.rnx's RINEX version of ``--rinex-version`` (None: chosen by its records)."""
    chosen = getattr(args, "rinex_version", None)
    return None if chosen is None else {"3": "3.04", "4": "4.00"}[chosen]


def _cmd_receive(args: argparse.Namespace) -> int:
    if args.nmea_out == "-":  # standard output carries the sentences: the messages go to standard error
        import contextlib

        from .receiver.navigation.nmea_stream import NmeaWriter

        sink = NmeaWriter(sys.stdout)
        with contextlib.redirect_stdout(sys.stderr):
            return _receive(args, sink)
    return _receive(args, None)


def _receive(args: argparse.Namespace, stdout_sink) -> int:
    """``receive`` with its live input and NMEA sinks closed whatever happens."""
    from .receiver.navigation.live import LiveRun
    from .receiver.navigation.nmea_stream import open_nmea_sink

    from .receiver.navigation.receive_outputs import parse_outputs

    _threads_from_args(args)
    outputs = parse_outputs(args.outputs)  # refused before the recording is opened or tracked
    sinks = [stdout_sink] if stdout_sink is not None else [open_nmea_sink(args.nmea_out)] if args.nmea_out else []
    live = LiveRun(_open_recording_from_args(args), sinks)
    try:
        return _receive_run(args, live, outputs)
    finally:
        overruns = live.finish()
        if overruns:
            print(overruns, file=sys.stderr)


#: ``receive --ionosphere-free``'s second signal unless ``--second-signal`` names one.
SECOND_SIGNAL = "gps-l2c"


def _check_ionosphere_free(args: argparse.Namespace, signal):
    """The `DualFrequency` of ``--ionosphere-free`` (None without it), refused in one line with
    what it cannot be combined with."""
    from .navigation.dual_frequency import DualFrequency

    if not args.ionosphere_free:
        if args.second_if_hz is not None or args.second_signal is not None:
            raise ConfigError("--second-signal", "describes the --ionosphere-free recording: give that too")
        return None
    for flag, given in (
        ("--tracking vector", args.tracking == "vector"),
        ("--nav-filter", args.nav_filter is not None),
        ("--approx-position", getattr(args, "approx_position", None) is not None),
        ("--nmea-out", bool(getattr(args, "nmea_out", None))),
    ):
        if given:
            raise ConfigError("--ionosphere-free", f"solves by least squares per epoch after the run: drop {flag}")
    if not Path(args.ionosphere_free).is_file():
        raise DataFileError(args.ionosphere_free, None, "no such file")
    return DualFrequency(signal, registry.signal_spec(args.second_signal or SECOND_SIGNAL))


def _ionosphere_free(args: argparse.Namespace, dual, result, acq, prns, rinex, reference_week):
    """``result`` with the ionosphere-free fixes of its recording and the second's
    (`dual_observables`, ``dual`` of `_check_ionosphere_free`) as its positions; the second
    recording received as the first, from its own acquisition."""
    import dataclasses

    from .receiver.frontend import open_recording
    from .receiver.navigation.cnav_stream import carries_cnav
    from .receiver.navigation.dual_observables import ionosphere_free_fixes, second_observables
    from .receiver.navigation.inav_stream import carries_inav
    from .receiver.navigation.receive import receive

    signal, second = dual.first, dual.second
    if result.observables is None:  # the no-position path writes the tracking and says why
        print(f"note: ionosphere-free: no transmit time decoded from {signal.name}; nothing to combine")
        return dataclasses.replace(result, positions=None, least_squares=None)
    rec = open_recording(
        args.ionosphere_free,
        format=args.format,
        sample_rate_hz=args.fs,
        if_hz=args.second_if_hz,
        q_sign=args.q_sign,
        signal=second,
    )
    config = _tracking_config_from_args(args, second if carries_cnav(second) or carries_inav(second) else None)
    found = _acquire_checked(rec, acq, prns, second)
    other = receive(
        rec,
        acq,
        config,
        prns=prns,
        duration_s=args.duration,
        rate_hz=args.rate,
        rinex=rinex,
        reference_week=reference_week,
        signal=second,
        acquisitions=found,
    )
    obs2 = second_observables(other.tracking, dual, result.observables, args.rate)
    if obs2 is None:
        name = Path(args.ionosphere_free).name
        print(f"note: ionosphere-free: no transmit time decoded from {second.name} in {name}; nothing to combine")
        return dataclasses.replace(result, positions=None, least_squares=None)
    _, table = ionosphere_free_fixes(
        result.observables,
        obs2,
        dual,
        rinex,
        troposphere=args.troposphere,
        reference_week=reference_week,
        weighting=args.weighting,
    )
    print(
        f"ionosphere-free: {len(table)} fixes from {signal.name} and {second.name} "
        f"({len(other.tracking.channels)} satellites tracked in {Path(args.ionosphere_free).name})"
    )
    return dataclasses.replace(result, positions=table, least_squares=table)


def _receive_run(args: argparse.Namespace, live, outputs: frozenset[str]) -> int:
    import json
    import time

    from .navigation.ephemeris import SYSTEMS as EPHEMERIS_SYSTEMS, read_rinex_nav, require_records_with_clock
    from .receiver.acquisition.report import search_summary
    from .receiver.navigation.fixes import write_positions_csv
    from .receiver.navigation.nmea_out import nmea_talker, write_nmea
    from .receiver.navigation.receive import receive
    from .receiver.navigation.decoded import navigation_message
    from .receiver.navigation.decoded import require_positioning
    from .receiver.navigation.receiver_config import receiver_filters
    from .navigation.rinex_nav_header import WEEK_S, read_nav_file_info
    from .receiver.channels.report import write_tracking_outputs
    from .receiver.navigation.report import no_position_reason, write_no_position_report, write_receive_report
    from .receiver.navigation.rinex_obs import write_rinex_obs
    from .receiver.navigation.receive_outputs import sky_views, write_extra_outputs
    from .progress import phase

    rec = live.recording
    acq = _acquisition_from_args(args)
    if "," in args.signal:
        if args.ionosphere_free:
            raise ConfigError("--ionosphere-free", "combines one signal with --second-signal: give one --signal")
        if _sbas_flag(args):
            raise ConfigError(_sbas_flag(args), "SBAS L1 corrects GPS L1 C/A fixes: give --signal gps-l1ca alone")
        return _receive_several(args, live, outputs)
    signal = _signal_from_args(args)
    require_positioning(signal)  # dated from LNAV, I/NAV or CNAV: another message would be misread
    dual = _check_ionosphere_free(args, signal)  # refused before any tracking
    if dual is not None and _sbas_flag(args):
        raise ConfigError(_sbas_flag(args), "SBAS L1 corrects single-frequency fixes: not with --ionosphere-free")
    prns = _prns_from_args(args, signal)
    try:
        channel_params = json.loads(args.channel_params) if args.channel_params else None
    except json.JSONDecodeError as exc:
        raise ConfigError("--channel-params", f"not JSON: {exc.msg}") from None
    filters = receiver_filters(args.config, args.channel_filter, channel_params, args.nav_filter)
    args.channel_filter = filters.channel_filter.name
    args.channel_params = json.dumps(filters.channel_filter.params)
    # E1-B: one 4 ms code period a symbol, taps off BOC(1,1)'s side lobes (track's E1 defaults)
    # L2 CM: 20 ms periods, the pull-in's loops narrowed to them (track's L2C defaults)
    config = _tracking_config_from_args(args, signal if _long_symbols(signal) else None)
    _check_rate(args.rate, (signal,))
    if args.week is not None and not 0 <= args.week < 10_000:
        raise ConfigError("--week", f"a full GPS week (e.g. 2190), got {args.week}")
    truth = _truth_from_args(args)
    raim = _raim_from_args(args)
    sbas = _sbas_from_args(args)
    if args.ephemeris and signal.system not in EPHEMERIS_SYSTEMS:
        raise ConfigError(
            "--ephemeris",
            f"the records of {signal.name} (RINEX system {signal.system}) are not read "
            f"from a navigation file (systems read: {', '.join(EPHEMERIS_SYSTEMS)}); "
            "drop --ephemeris, the decoded LNAV ephemerides serve",
        )
    rinex = read_rinex_nav(args.ephemeris, systems=signal.system) if args.ephemeris else None
    if rinex is not None:
        rinex = require_records_with_clock(
            rinex,
            signal,
            "--ephemeris",
            args.ephemeris,
            ": give a file with F/NAV records, or none (the decoded ones serve)",
        )
    nav_info = read_nav_file_info(args.ephemeris) if args.ephemeris else None
    # Without --week, the ephemeris file's (placed at the recording's tow once known, below).
    reference_week = args.week
    if reference_week is None and nav_info is not None:
        reference_week = int(0.5 * (nav_info.first_s + nav_info.last_s) // WEEK_S)
    vector = None
    if args.smooth and filters.nav_filter is None:
        raise ConfigError(
            "--smooth", "smooths a navigation filter's positions (scalar tracking): give --nav-filter, e.g. ekf-pv"
        )
    if args.tracking == "vector":
        from .receiver.navigation.vector_tracking import vector_config

        if filters.nav_filter is not None:  # the vector loop closes its own ekf-pv
            raise ConfigError(
                "--tracking",
                "vector tracking runs its own navigation filter: drop --nav-filter "
                "(or the config's [nav_filter]) or use --tracking scalar",
            )
        monitor = {} if raim is None else {"monitor_false_alarm": raim.false_alarm}  # the channel fault monitor
        vector = vector_config(solution_rate_hz=args.rate, **_vector_channel_from_args(args), **monitor)
    elif args.vector_channel_filter or args.vector_channel_params:
        raise ConfigError("--vector-channel-filter", "the vector loop's channel filter is for --tracking vector")
    elif args.vector_accel_psd is not None:
        raise ConfigError("--vector-accel-psd", "the vector loop's navigation filter is for --tracking vector")
    assist = _assist_from_args(args, nav_info)
    started = time.monotonic()
    name = Path(args.recording).name
    acquisitions = _acquire_checked(rec, acq, prns, signal)  # checked before minutes of tracking
    if not args.quiet:  # a line as each phase ends (a refused one leaves its one error line alone)
        phase(
            name,
            f"acquisition found {sum(r.detected for r in acquisitions)} of {len(acquisitions)} PRNs; "
            f"tracking, decoding {navigation_message(signal).name}, positioning",
            started,
        )
    iono_fallback = nav_info.iono_for(signal.system) if nav_info is not None and not args.no_iono else None
    fixes = None
    if live.sinks and vector is None:
        fixes = live.start(
            rate_hz=args.rate,
            rinex=rinex,
            ionosphere=not args.no_iono,
            troposphere=args.troposphere,
            reference_week=reference_week,
            weighting=args.weighting,
            signal=signal,
            iono_fallback=iono_fallback,
        )
    elif live.sinks:
        print("note: with --tracking vector the NMEA sentences are sent at the end of the run")
        fixes = live.start(rate_hz=args.rate, signal=signal)
    streaming = rec.is_live
    with _recording_progress(args, rec, quiet=streaming) as progress:
        result = receive(
            rec,
            acq,
            config,
            prns=prns,
            duration_s=args.duration,
            rate_hz=args.rate,
            rinex=rinex,
            ionosphere=not args.no_iono,
            troposphere=args.troposphere,
            reference_week=reference_week,
            progress=_both(progress, fixes if vector is None else None),
            nav_filter=filters.nav_filter,
            vector=vector,
            assist=assist,
            acquisitions=acquisitions,
            iono_fallback=iono_fallback,
            weighting=args.weighting,
            signal=signal,
            raim=raim,
            sbas=sbas,
            observe=fixes.observe if fixes is not None and vector is None else None,
            smooth=args.smooth,
            workers=args.workers,
        )
    if dual is not None:
        result = _ionosphere_free(args, dual, result, acq, prns, rinex, reference_week)
    if fixes is not None:
        fixes.finish(result.positions, result.observables)
        print(f"NMEA: {fixes.sent} fixes sent to {', '.join(s.description for s in live.sinks)}")
    overruns = rec.overrun_summary() if streaming and (rec.realtime or rec.device_lost) else ""
    if result.vector is not None and result.vector.handover_s is not None:
        print(
            f"vector tracking from {result.vector.handover_s:.1f} s of PRN "
            f"{', '.join(str(p) for p in result.vector.prns)} (channel filter {vector.channel_filter})"
        )
    if not result.tracking.channels:
        print(
            f"nothing found: {search_summary(rec, acq, prns, signal)}. Check the sample rate (--fs), the IF "
            "(--if), the format (--format) and --doppler-max; no position"
        )
        return 1
    table = result.positions
    out = Path(args.out)
    if table is None or len(table) == 0:
        why = no_position_reason(result, nav_info, assist, reference_week, signal)
        if table is not None:
            why += _ephemeris_distance(rinex, result.observables)
        if overruns:  # samples dropped by --realtime may be why: said beside the reason
            why += f"; live input {rec.description}: {overruns}"
        out.mkdir(parents=True, exist_ok=True)
        written = write_tracking_outputs(out, result.tracking, plots=True, signal=signal)
        written += write_no_position_report(out, result, why, rinex, signal)
        print(
            f"no position: {why}; tracked {len(result.tracking.channels)} satellites for "
            f"{result.tracking.duration_s:.1f} s; wrote {', '.join(str(p) for p in written if p.parent == out)}"
        )
        return 1
    out.mkdir(parents=True, exist_ok=True)
    if not args.quiet:
        phase(name, f"{len(table)} fixes; writing the outputs", started)
    obs = result.observables
    if args.week is None and nav_info is not None and assist is None and (obs is None or obs.week is None):
        # No subframe 1: the week that puts the first fix's tow nearest the file's records.
        week_now = nav_info.week_at(float(table.columns["tow_s"][0]))
        for t in {id(t): t for t in (table, result.least_squares) if t is not None}.values():
            t.columns["gps_week"][:] = week_now
        print(
            f"note: no subframe 1 decoded: GPS week {week_now} from the --ephemeris file's records ({nav_info.dates()})"
        )
    written = [write_positions_csv(out / "positions.csv", table)]
    c = table.columns
    week = int(c["gps_week"][0])
    leap = obs.iono_utc.dt_ls_s if obs is not None and obs.iono_utc is not None else 18
    sky = sky_views(result, table, rinex, signal) if "gsv" in outputs else None
    if week >= 0 and obs is None:
        print("note: no LNAV subframe decoded, so no pseudoranges of the scalar channels: no observations.rnx")
        written.append(write_nmea(out / "nmea.txt", table, 18, nmea_talker(signal), sky, "gsa" in outputs))
    elif week >= 0:
        written += [
            write_rinex_obs(out / "observations.rnx", obs, week, table.ecef_m[-1], signal=signal),
            write_nmea(out / "nmea.txt", table, leap, nmea_talker(signal), sky, "gsa" in outputs),
        ]
    else:
        print(
            "note: no subframe 1 decoded, so the GPS week is unknown: no observations.rnx or nmea.txt "
            "(give it with --week)"
        )
    extra, notes = write_extra_outputs(out, result, table, outputs, week, leap, signal, _rinex_version(args))
    written += extra
    for note in notes:
        print(f"note: {note}")
    if result.sbas is not None:  # --sbas-signal: the GEOs' messages, a row each
        from .receiver.navigation.sbas_stream import write_sbas_csv

        written.append(write_sbas_csv(out, result.sbas))
        for channel in result.sbas:
            good = channel.good
            print(
                f"SBAS PRN {channel.prn}: {len(good)} messages (types "
                f"{' '.join(str(m.message_type) for m in good) or 'none'}), {len(channel.failures)} CRC failures"
            )
        for note in result.sbas_notes:
            print(f"note: {note}")
    nav_name = filters.nav_filter.name if filters.nav_filter is not None else None
    used = f"channel filter {config.channel_filter}, " + (
        f"nav filter {nav_name} from the first least-squares fix" if nav_name else "least squares per epoch"
    )
    written += write_receive_report(
        out,
        result,
        table,
        truth,
        rinex,
        f"Filters: {used}." + (f" Live input {rec.description}: {overruns}." if overruns else ""),
        signal=signal,
    )
    _print_fix_summary(table, truth, f"({used})")
    print(f"wrote {', '.join(str(p) for p in written if p.parent == out)} and {out / 'plots'}/")
    return 0


def _print_fix_summary(table, truth, what: str, more: str = "") -> None:
    """The summary ``receive`` prints of its fixes, with one signal or several: ``N fixes
    {what} from ...`` (first fix's time, satellites, last position and HDOP) with ``more``
    at its end, then, with ``--truth``, the horizontal and vertical RMS error (m)."""
    import numpy as np

    from .receiver.navigation.receive import position_errors

    c = table.columns
    print(
        f"{len(table)} fixes {what} from {table.sample_time_s[0]:.1f} s into the recording (GPS week "
        f"{int(c['gps_week'][0])}, tow {c['tow_s'][0]:.1f} s), {int(c['n_sats'].min())}-{int(c['n_sats'].max())} "
        f"satellites; last {c['lat_deg'][-1]:.7f} {c['lon_deg'][-1]:.7f} {c['height_m'][-1]:.2f} m, HDOP "
        f"{c['hdop'][-1]:.2f}{more}"
    )
    if truth is not None:
        err = position_errors(table, truth)
        print(
            f"against --truth: horizontal RMS {np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1))):.2f} m, "
            f"vertical RMS {np.sqrt(np.mean(err[:, 2] ** 2)):.2f} m"
        )


def _receive_several(args: argparse.Namespace, live, outputs: frozenset[str]) -> int:
    """``receive --signal A,B``: every signal tracked and dated by its own message, one fix
    per epoch of all their satellites with a receiver clock per time system
    (`multi_receive.receive_signals`); positions.csv (with ``system_offset_ns``), a mixed
    observations.rnx, nmea.txt (GN: GGA, RMC; GNGSA and GPGSV/GAGSV per system), the
    report and the ``--outputs`` files (`receive_outputs`: a mixed navigation.rnx, the
    track, tracking.parquet with a signal column, MSM7 per system)."""
    import json
    import time

    import numpy as np

    from .navigation.ephemeris import read_rinex_nav
    from .navigation.rinex_nav_header import WEEK_S, read_nav_file_info
    from .progress import phase
    from .receiver.channels.report import write_tracking_outputs
    from .receiver.navigation.fixes import SYSTEM_OFFSET_COLUMN, write_positions_csv
    from .receiver.navigation.multi_receive import SignalSet, receive_signals
    from .receiver.navigation.nmea_out import nmea_talker, write_nmea
    from .receiver.navigation.report import write_receive_report
    from .receiver.navigation.receiver_config import receiver_filters
    from .receiver.navigation.receive_outputs import sky_views, write_extra_outputs
    from .receiver.navigation.rinex_obs import write_rinex_obs

    signals = SignalSet(tuple(registry.signal_spec(n) for n in args.signal.split(",")))
    given = {
        "--prns": args.prns,
        "--tracking vector": args.tracking == "vector",
        "--nav-filter": args.nav_filter,
        "--config": args.config,
        "--nmea-out": args.nmea_out,
        "--approx-position": args.approx_position,
        "--vector-channel-filter": args.vector_channel_filter,
        "--raim": getattr(args, "raim", None),
        "--smooth": args.smooth,
    }
    for option, value in given.items():
        if value:
            raise ConfigError(option, f"not with several signals ({signals.name}): give one --signal for it")
    _check_rate(args.rate, signals.signals)
    if args.week is not None and not 0 <= args.week < 10_000:
        raise ConfigError("--week", f"a full GPS week (e.g. 2190), got {args.week}")
    try:
        channel_params = json.loads(args.channel_params) if args.channel_params else None
    except json.JSONDecodeError as exc:
        raise ConfigError("--channel-params", f"not JSON: {exc.msg}") from None
    filters = receiver_filters(None, args.channel_filter, channel_params, None)
    args.channel_filter = filters.channel_filter.name
    args.channel_params = json.dumps(filters.channel_filter.params)
    configs = [_tracking_config_from_args(args, s if _long_symbols(s) else None) for s in signals.signals]
    systems = "".join(s.system for s in signals.signals)
    rinex = read_rinex_nav(args.ephemeris, systems=systems) if args.ephemeris else None
    nav_info = read_nav_file_info(args.ephemeris) if args.ephemeris else None
    reference_week = args.week
    if reference_week is None and nav_info is not None:
        reference_week = int(0.5 * (nav_info.first_s + nav_info.last_s) // WEEK_S)
    truth = _truth_from_args(args)
    rec = live.recording
    started = time.monotonic()
    name = Path(args.recording).name
    with _recording_progress(args, rec) as progress:
        result = receive_signals(
            rec,
            _acquisition_from_args(args),
            configs,
            signals,
            duration_s=args.duration,
            rate_hz=args.rate,
            rinex=rinex,
            ionosphere=not args.no_iono,
            troposphere=args.troposphere,
            reference_week=reference_week,
            iono_fallback=nav_info.iono_for(systems) if nav_info is not None and not args.no_iono else None,
            weighting=args.weighting,
            progress=progress,
            workers=args.workers,
        )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = result.positions
    if table is None or len(table) == 0:
        written = write_tracking_outputs(out, result.tracking, plots=True, signal_of=signals.signal_of)
        print(
            f"no position from {signals.name}: tracked {len(result.tracking.channels)} satellites for "
            f"{result.tracking.duration_s:.1f} s (a fix needs 3 + one per time system of satellites with a "
            f"transmit time and an ephemeris); wrote {', '.join(str(p) for p in written if p.parent == out)}"
        )
        return 1
    if not args.quiet:
        phase(name, f"{len(table)} fixes; writing the outputs", started)
    c = table.columns
    week = int(c["gps_week"][0])
    obs = result.observables
    written = [write_positions_csv(out / "positions.csv", table)]
    leap = 18
    if obs is not None and obs.iono_utc is not None:
        leap = obs.iono_utc.dt_ls_s
    elif obs is not None and obs.galileo is not None and obs.galileo.utc is not None:
        leap = obs.galileo.utc.dt_ls_s  # word type 6's: the same GPS-UTC leap seconds
    if week >= 0 and obs is not None:
        sky = sky_views(result, table, rinex, signals) if "gsv" in outputs else None  # type: ignore[arg-type]
        written += [
            write_rinex_obs(out / "observations.rnx", obs, week, table.ecef_m[-1], signal=signals),  # type: ignore[arg-type]
            write_nmea(out / "nmea.txt", table, leap, nmea_talker(*signals.signals), sky, "gsa" in outputs, signals),
        ]
    else:
        print("note: the GPS week is unknown: no observations.rnx or nmea.txt (give it with --week)")
    extra, notes = write_extra_outputs(out, result, table, outputs, week, leap, signals, _rinex_version(args))  # type: ignore[arg-type]
    written += extra
    for note in notes:
        print(f"note: {note}")
    written += write_receive_report(
        out,
        result,
        table,
        truth,
        rinex,
        f"Filters: least squares per epoch, a receiver clock per time system ({signals.name}).",
        signal=signals,
    )  # type: ignore[arg-type]
    offsets = c.get(SYSTEM_OFFSET_COLUMN, np.full(len(table), np.nan))
    # One system (BeiDou B1I's D1 and GEO satellites): no inter-system offset to report.
    offset = (
        f"; inter-system clock offset {np.nanmedian(offsets):.1f} ns (median)" if np.isfinite(offsets).any() else ""
    )
    _print_fix_summary(table, truth, f"of {signals.name}", offset)
    print(f"wrote {', '.join(str(p) for p in written if p.parent == out)}")
    return 0


def _ephemeris_distance(rinex, obs) -> str:
    """``"; the --ephemeris records are 26.0 h from ..."`` when none of the navigation
    file's GPS records is within the 4-hour fit of the recording's time, else ``""``."""
    import numpy as np

    from .navigation.ephemeris import _wrap_week
    from .receiver.navigation.fixes import MAX_EPHEMERIS_AGE_S

    if rinex is None or obs is None or not np.size(obs.rx_time_s):
        return ""
    gps = np.char.startswith(rinex.sv.astype(str), "G")
    t0 = float(np.nanmin(obs.rx_time_s))
    if not gps.any() or not np.isfinite(t0):
        return ""
    nearest = float(np.min(np.abs(_wrap_week(t0 - rinex.elements["Toe"][gps]))))
    if nearest <= MAX_EPHEMERIS_AGE_S:
        return ""
    return (
        f"; the --ephemeris file's nearest GPS record is {nearest / 3600:.1f} h from the recording's time of week "
        f"{t0:.0f} s (a record is used within {MAX_EPHEMERIS_AGE_S / 3600:g} h of its Toe): give the navigation "
        "file of the recording's day"
    )


def _vector_channel_from_args(args: argparse.Namespace) -> dict:
    """`VectorConfig` fields of ``--vector-channel-filter``, ``--vector-channel-params`` and
    ``--vector-accel-psd`` (the ``ekf-pv`` navigation filter's ``accel_psd``)."""
    import json

    out = {}
    if args.vector_accel_psd is not None:
        if not args.vector_accel_psd > 0:  # also refuses nan
            raise ConfigError("--vector-accel-psd", f"must be > 0 m²/s³, got {args.vector_accel_psd}")
        out["nav_params"] = {"accel_psd": args.vector_accel_psd}
    if args.vector_channel_filter:
        out["channel_filter"] = args.vector_channel_filter
    if args.vector_channel_params:
        try:
            out["channel_params"] = json.loads(args.vector_channel_params)
        except json.JSONDecodeError as exc:
            raise ConfigError("--vector-channel-params", f"not JSON: {exc.msg}") from None
        if not isinstance(out["channel_params"], dict):
            raise ConfigError("--vector-channel-params", "a JSON object of the filter's parameters")
    return out


#: ``receive --weighting``: `navigation.pvt.WEIGHTINGS` (written out: that module costs 0.6 s to import).
WEIGHTINGS = ("elevation", "uniform", "rtklib")
#: ``receive --raim``: `navigation.integrity.RAIM_METHODS` (written out, as WEIGHTINGS).
RAIM_METHODS = ("chi2", "ss")
#: ``position --tracking``: the scalar receiver, or vector tracking from the first fix.
TRACKING_MODES = ("scalar", "vector")


def _add_threads_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--threads",
        type=int,
        metavar="N",
        help="threads correlating the channels (default: the cores available); the results do not depend on it",
    )


def _workers(text: str) -> int | str:
    """``--workers``: a whole number of at least 1, or ``auto`` (`groups.check_workers`)."""
    from .receiver.channels.groups import check_workers

    value: int | str = int(text) if text.strip().lstrip("+-").isdigit() else text
    try:
        check_workers(value)
    except ConfigError as err:
        raise argparse.ArgumentTypeError(err.detail) from None
    return value


def _add_workers_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--workers",
        type=_workers,
        default="auto",
        metavar="N",
        help="processes tracking the scalar channels, each a share of them (a number, or auto: the cores "
        "available; default: auto); the records do not depend on it",
    )


def _threads_from_args(args: argparse.Namespace) -> None:
    from .backend import set_threads

    if args.threads is not None and args.threads < 1:
        raise ConfigError("--threads", f"must be at least 1, got {args.threads}")
    set_threads(args.threads)


def _signal_names(text: str) -> str:
    """``receive --signal``: one registered signal name or several, comma-separated, each checked."""
    names = [n.strip() for n in text.split(",")]
    known = registry.names("signal")
    bad = [n for n in names if n not in known]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown signal {', '.join(map(repr, bad))} (choose from {', '.join(known)})")
    return ",".join(names)


def _add_recording_options(p: argparse.ArgumentParser, several_signals: bool = False) -> None:
    p.add_argument(
        "recording",
        help="sample file (a SigMF .sigmf-meta beside it gives format, rate and IF); "
        "receive also reads a stream: - (standard input), a FIFO, tcp://HOST:PORT, "
        "rtl_tcp://HOST:PORT, soapy://KEY=VALUE,... (a SoapySDR device, e.g. soapy://driver=rtlsdr)",
    )
    p.add_argument(
        "--format",
        help="sample format: ri8, ci8, cu8, ci16_le, cf32_le (SigMF names), ri2/ci2 (2-bit packed) or a plugin's",
    )
    p.add_argument("--fs", type=float, metavar="HZ", help="sample rate")
    p.add_argument("--if", dest="if_hz", type=float, metavar="HZ", help="intermediate frequency (default 0)")
    p.add_argument("--q-sign", type=int, choices=[1, -1], help="-1 for a front end whose Q branch is inverted")
    p.add_argument("--acquisition", default="pcps", help="acquisition plugin (default %(default)s)")
    p.add_argument("--coherent-ms", type=int, help="coherent integration (code periods)")
    p.add_argument("--noncoherent", type=int, help="non-coherent sums")
    p.add_argument("--doppler-max", type=float, metavar="HZ", help="Doppler search range +-")
    p.add_argument("--pfa", type=float, help="false-alarm probability of one PRN's search")
    p.add_argument(
        "--alternate-blocks",
        action="store_true",
        help="sum even and odd coherent blocks apart, keep the larger (with --coherent-ms 10: one of them "
        "is free of data-bit transitions; weak signals)",
    )
    p.add_argument(
        "--weak",
        action="store_true",
        help="weak signals, down to about 30 dB-Hz from a cold start: the search of 10 ms blocks by parity, "
        "18 of them, following the code Doppler, and tracking without FLL assist, with 200 ms lock detectors "
        "and bit synchronisation by energy (each option given explicitly still applies)",
    )
    p.add_argument(
        "--code-doppler",
        action="store_true",
        help="follow the code Doppler across the non-coherent blocks (long weak-signal searches: at 5 kHz "
        "the L1 code moves half a chip in 154 ms)",
    )
    p.add_argument(
        "--boc-search",
        choices=["full", "bpsk-like"],
        help="a BOC signal's search: full (its spreading waveform, the default) or bpsk-like (the code on "
        "both sub-carrier side bands: one peak a chip wide, no side peaks, less lost to a narrow front end)",
    )
    if several_signals:  # receive: several signals positioned together
        p.add_argument(
            "--signal",
            default=DEFAULT_SIGNAL,
            type=_signal_names,
            metavar="NAME[,NAME]",
            help="the signal searched and tracked: a registered signal plugin (`gnssframework plugins "
            f"--kind signal`: {', '.join(registry.names('signal'))}; default %(default)s); "
            "gps-l1ca,galileo-e1b-boc11 tracks both and solves them together",
        )
    else:
        p.add_argument(
            "--signal",
            default=DEFAULT_SIGNAL,
            choices=registry.names("signal"),
            metavar="NAME",
            help="the signal searched and tracked: a registered signal plugin (`gnssframework plugins "
            "--kind signal`: %(choices)s; default %(default)s)",
        )
    p.add_argument("--prns", type=int, nargs="+", help="PRNs to search, the signal's (default all: 1-32 on gps-l1ca)")


_ROLE = re.compile(r":[a-z]+(?::[a-z]+)?:`~?([^`<]*?)\s*(?:<[^>]*>)?`")


def plain_text(text: str) -> str:
    """``text`` without reST inline markup, for a terminal: ````x```` -> ``x``,
    ``:class:`~a.B``` -> ``B``, ``:func:`name <a.f>``` -> ``name``.

    Examples
    --------
    >>> plain_text("composes a ``channel_filter`` (:class:`~gnssframework.interfaces.NavFilter`)")
    'composes a channel_filter (NavFilter)'
    """
    text = _ROLE.sub(lambda m: m.group(1).rsplit(".", 1)[-1] if m.group(0).count("~") else m.group(1), text)
    return text.replace("``", "")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps descriptions' line breaks and shows each option's default, unless its help
    already says it or there is none to show (a flag, an option without a default)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if (
            "default" in text
            or action.default in (None, False, argparse.SUPPRESS)
            or action.option_strings == []
            or isinstance(action, argparse._VersionAction)
        ):
            return text
        return f"{text} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """A subcommand's parser: the same help formatter as the top level."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def parse_known_args(self, args=None, namespace=None):
        """The command's arguments, its options (``command_options``) for the errors' fields
        and the option of each argument (``command_flags``, ``dest`` -> longest option)."""
        namespace, extras = super().parse_known_args(args, namespace)
        namespace.command_options = frozenset(o for a in self._actions for o in a.option_strings)
        namespace.command_flags = {a.dest: max(a.option_strings, key=len) for a in self._actions if a.option_strings}
        return namespace, extras


def _add_position_log_options(p: argparse.ArgumentParser, adapter_use: str) -> None:
    """The options ``filter-positions`` and ``smooth-positions`` share: the filter's adapter,
    augmentation and AR(1) coefficient, and how the NMEA log's bad sentences are skipped."""
    p.add_argument(
        "--noise-adapter",
        default=None,
        metavar="NAME",
        help=f"a registered noise adapter{adapter_use} (replaces the label's own)",
    )
    p.add_argument(
        "--augmentation",
        default=None,
        metavar="NAME",
        help="a registered augmentation, e.g. colored-ar1 with --psi (replaces the label's own)",
    )
    p.add_argument("--psi", type=float, default=0.95, help="AR(1) coefficient for the colored filters")
    p.add_argument(
        "--max-speed",
        type=float,
        default=MAX_SPEED_MPS,
        metavar="M/S",
        help="jump check: skip a fix further from the last accepted one than this speed allows "
        "(default %(default)g m/s)",
    )
    p.add_argument(
        "--max-height",
        type=float,
        default=MAX_ABS_HEIGHT_M,
        metavar="M",
        help="skip a GGA whose altitude is not a number or above this in magnitude (default %(default)g m)",
    )
    p.add_argument("--strict", action="store_true", help="refuse the file at the first bad sentence (exit 2)")


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="gnssframework", description=plain_text(__doc__), formatter_class=HelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"gnssframework {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    p = sub.add_parser("plugins", help="list the registered plugins")
    p.add_argument("--kind", choices=registry.kinds(), help="only this kind")
    p.add_argument("--describe", metavar="NAME", help="one plugin's description, contract and parameter table")
    p.set_defaults(func=_cmd_plugins)
    p = sub.add_parser("compare", help="run a Monte Carlo comparison from a TOML config")
    p.add_argument("file", help="comparison config (TOML)")
    p.add_argument("--runs", type=int, help="override the number of runs")
    p.add_argument("--seed", type=int, help="override the seed")
    p.add_argument("--out", help="output directory (default: results/<name>)")
    p.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, a line per tenth elsewhere)")
    p.add_argument(
        "--check", action="store_true", help="print every [[claims]] outcome and exit 1 unless every claim holds"
    )
    p.add_argument(
        "--replicate",
        action="store_true",
        help="also run every case and candidate on a second, disjoint set of runs (the replicate streams, "
        "at the tuned values) and re-check every claim there; with --check, a claim must hold on both",
    )
    p.add_argument(
        "--no-plots",
        action="store_true",
        help="write the summary, report and tables but draw no figure (report.md still names them; "
        "the same command without the flag draws them from the store, nothing rerun)",
    )
    p.add_argument(
        "--trials-from",
        metavar="FILE",
        help="a tuned config: seed its tuning with the trials another run of the same config recorded "
        "(its tuning_trials.json); they are not rerun, and the best selects the tuned values",
    )
    p.add_argument(
        "--dask-address",
        metavar="ADDR",
        help="run on this Dask scheduler (executor kind dask; also GNSSFRAMEWORK_DASK_ADDRESS). Dask's "
        "protocol carries pickles: give only a scheduler you trust; a config file cannot name one",
    )
    p.set_defaults(
        func=_cmd_compare, interrupt_hint="; finished batches are kept in --out and the same command resumes"
    )
    p = sub.add_parser(
        "filter-positions",
        help="filter an NMEA position log (Liu et al. 2020's filters)",
        description="Filter the horizontal track of an NMEA log. Corrupted sentences, impossible "
        "positions, duplicated or backwards timestamps and implausible jumps are skipped "
        "and listed (line and reason) on stdout and in <out>.skipped.csv.",
        epilog=EXIT_STATUS_HELP,
    )
    p.add_argument("file", help="NMEA log with GGA and/or RMC sentences")
    p.add_argument("--out", required=True, help="output CSV")
    p.add_argument(
        "--filter",
        default="AUKF1",
        metavar="NAME",
        help="a position filter of Liu et al. 2020 (UKF, UKF1, AUKF, AUKF1) or a registered estimator "
        "(`gnssframework plugins --kind estimator`) in the constant-acceleration position model",
    )
    _add_position_log_options(p, "")
    p.set_defaults(func=_cmd_filter_positions)
    p = sub.add_parser(
        "smooth-positions",
        help="smooth an NMEA position log forward-backward (filter, then RTS)",
        description="Run a position filter forward over an NMEA log, then the fixed-interval "
        "Rauch-Tung-Striebel pass backward: each position given the whole log, with its "
        "variance, beside the forward filter's. Bad sentences are skipped and listed as "
        "by filter-positions.",
        epilog=EXIT_STATUS_HELP,
    )
    p.add_argument("file", help="NMEA log with GGA and/or RMC sentences")
    p.add_argument("--out", required=True, help="output CSV (smoothed and filtered positions, variances)")
    p.add_argument(
        "--filter",
        default="UKF",
        metavar="NAME",
        help="the forward filter: a label of Liu et al. 2020 (UKF, UKF1, AUKF, AUKF1) or a registered "
        "estimator in the constant-acceleration position model (default %(default)s)",
    )
    _add_position_log_options(p, " for the forward pass")
    p.set_defaults(func=_cmd_smooth_positions)
    p = sub.add_parser(
        "smooth",
        help="carrier-smooth code from a RINEX observation file, arc by arc",
        description="Carrier-smooth each selected satellite's code with its carrier (GPS C1C/L1C, "
        "Galileo E1, BDS B1I, GLONASS L1), restarting at the receiver's loss-of-lock "
        "flags and at gaps. Duplicated and backwards epochs, "
        "pseudoranges outside the plausibility bounds and an epoch cut by a truncated "
        "file are skipped and listed (line and reason) on stdout and in "
        "<out>.skipped.csv.",
        epilog=EXIT_STATUS_HELP,
    )
    p.add_argument("file", help="RINEX 2.1x, 3.0x or 4.0x observation file (plain, .gz, Hatanaka .crx or .crx.gz)")
    p.add_argument(
        "--prn", required=True, help="satellites (G08 or G08,C11; g8 and 8 mean G08) or systems (G, GEC, all)"
    )
    p.add_argument("--out", required=True, help="output CSV")
    p.add_argument(
        "--filter",
        default="hatch",
        choices=list(SMOOTHERS),
        help="smoother: Hatch filter, Kalman smoother, or Kalman smoother with ml-q adaptive Q",
    )
    p.add_argument("--window", type=int, default=100, help="Hatch window (epochs)")
    p.add_argument("--q", type=float, default=1e-3, help="Kalman smoother Q (m^2)")
    p.add_argument("--r", type=float, default=1.25, help="Kalman smoother R (m^2)")
    p.add_argument("--slip-threshold", type=float, default=0.0, help="code-minus-carrier slip test (m), 0: off")
    p.add_argument(
        "--max-gap",
        type=float,
        default=None,
        metavar="S",
        help="a longer step between a satellite's epochs ends its arc (default 1.5 epoch intervals)",
    )
    p.add_argument(
        "--max-cmc-rate",
        type=float,
        default=MAX_CMC_RATE_MPS,
        metavar="M/S",
        help="leave an arc unsmoothed (and exit 3) when its code minus carrier drifts faster than this, "
        "least-squares slope over the arc (default %(default)g m/s; a phone's carrier can drift tens of m/s)",
    )
    p.add_argument(
        "--ignore-lli",
        action="store_true",
        help="do not restart at the receiver's loss-of-lock flags (gaps still end arcs)",
    )
    p.add_argument(
        "--pseudorange-min",
        type=float,
        default=PSEUDORANGE_MIN_M,
        metavar="M",
        help="skip a pseudorange below this (default %(default)g m)",
    )
    p.add_argument(
        "--pseudorange-max",
        type=float,
        default=PSEUDORANGE_MAX_M,
        metavar="M",
        help="skip a pseudorange above this (default %(default)g m)",
    )
    p.add_argument(
        "--strict",
        action="store_true",
        help="refuse the file at the first bad epoch or observation, or a truncation (exit 2)",
    )
    p.set_defaults(func=_cmd_smooth)
    p = sub.add_parser(
        "acquire",
        help="find the satellites of a signal (GPS L1 C/A by default) in a recording of front-end samples",
        description="FFT parallel code-phase search of every PRN; one CSV row per satellite found. "
        "Exit 1 when nothing is found (the message says what was searched), 2 for bad "
        "options or files.",
    )
    _add_recording_options(p)
    p.add_argument("--out", required=True, help="output CSV")
    p.add_argument("-v", "--verbose", action="store_true", help="a line per PRN searched")
    p.set_defaults(func=_cmd_acquire)
    p = sub.add_parser(
        "track",
        help="acquire and track the satellites of a recording with a channel filter",
        description="Acquire, then track every satellite found with the chosen channel_filter plugin "
        "(pull-in, FLL-assisted PLL, bit synchronisation, extended integration; a channel "
        "that loses lock goes back to acquisition). Writes DIR/tracking.csv, "
        "DIR/summary.csv, DIR/events.txt and DIR/plots/; with --signal galileo-e1b(-boc11) "
        "DIR/inav.csv, with --signal sbas-l1 DIR/sbas.csv (one row a message). Exit 1 when "
        "nothing is found, 2 for bad options or files.",
    )
    _add_recording_options(p)
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--duration", type=float, metavar="S", help="seconds of the recording to track (default: all)")
    p.add_argument("--channel-filter", default="scalar", help="channel_filter plugin (default %(default)s)")
    p.add_argument("--channel-params", metavar="JSON", help="its parameters, e.g. '{\"pll_bandwidth_hz\": 10}'")
    p.add_argument(
        "--coherent-ms-track",
        type=int,
        metavar="MS",
        help="coherent integration after bit synchronisation (1, 2, 4, 5, 10 or 20; default 10)",
    )
    p.add_argument(
        "--cn0-estimator",
        help="C/N0 estimator of the lock detector: nwpr (default), moments, or a "
        "cn0_estimator plugin reading the prompt only (snv, beaulieu, m2m4)",
    )
    p.add_argument(
        "--early-late-spacing", type=float, metavar="CHIPS", help="early-to-late correlator spacing (default 1.0)"
    )
    p.add_argument("--no-plots", action="store_true", help="no plots")
    _add_threads_option(p)
    _add_workers_option(p)
    p.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, a line per tenth elsewhere)")
    p.set_defaults(func=_cmd_track)
    p = sub.add_parser(
        "receive",
        aliases=["position"],
        help="positions from a recording: acquire, track, decode LNAV, solve each epoch",
        description="Acquire and track (as track does), decode each satellite's LNAV (TOW, ephemeris, "
        "Klobuchar), form pseudoranges and Dopplers at common epochs and solve each epoch "
        "(weighted least squares, one bad satellite excluded) or, with --nav-filter, run a "
        "registered navigation filter on them from the first fix. Writes DIR/positions.csv, "
        "DIR/observations.rnx (RINEX 3.04), DIR/nmea.txt (GGA, RMC; GSA, GSV), "
        "DIR/navigation.rnx (the decoded ephemerides), DIR/track.geojson, DIR/report.md "
        "and DIR/plots/, and the --outputs asked for. `position` is the same command (its former name). "
        "Exit 1 when no position is found, 2 for bad options or files.",
    )
    _add_recording_options(p, several_signals=True)
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--duration", type=float, metavar="S", help="seconds of the recording to use (default: all)")
    p.add_argument(
        "--config",
        metavar="TOML",
        help="receiver config: [channel_filter] and [nav_filter], each {name, params} (the options below override it)",
    )
    p.add_argument("--channel-filter", metavar="NAME", help="channel_filter plugin (default scalar)")
    p.add_argument("--channel-params", metavar="JSON", help="its parameters")
    p.add_argument(
        "--nav-filter",
        metavar="NAME",
        help="nav_filter plugin run on the pseudoranges and Dopplers, e.g. ekf-pv (default: least squares per epoch)",
    )
    p.add_argument(
        "--smooth",
        action="store_true",
        help="with --nav-filter: write its forward-backward (RTS) positions, each using the whole run",
    )
    p.add_argument("--rate", type=float, default=1.0, metavar="HZ", help="solutions per second (default 1)")
    p.add_argument("--ephemeris", metavar="NAV", help="RINEX navigation file for satellites not yet decoded")
    p.add_argument(
        "--week",
        type=int,
        metavar="WEEK",
        help="full GPS week of the recording (places the decoded "
        "10-bit week; without it, the --ephemeris file's week; "
        "needed without either and a decoded subframe 1)",
    )
    p.add_argument(
        "--no-iono",
        action="store_true",
        help="no Klobuchar correction (by default the decoded page 18's, else the --ephemeris file header's)",
    )
    p.add_argument("--troposphere", action="store_true", help="apply the Saastamoinen troposphere")
    p.add_argument(
        "--ionosphere-free",
        metavar="FILE",
        help="a second recording of the same front end, started together, on another carrier: "
        "positions.csv then holds the ionosphere-free fixes of the two signals (GPS/QZSS, "
        "scalar tracking, least squares); opened with --format, --fs and --q-sign, its IF "
        "from its SigMF metadata or --second-if",
    )
    p.add_argument(
        "--second-signal",
        metavar="NAME",
        help=f"with --ionosphere-free: the second recording's signal (default {SECOND_SIGNAL})",
    )
    p.add_argument("--second-if", type=float, dest="second_if_hz", metavar="HZ", help="with --ionosphere-free: its IF")
    p.add_argument(
        "--weighting",
        choices=WEIGHTINGS,
        default="elevation",
        help="least-squares weights: elevation (sin²E/σ²), uniform, or rtklib (RTKLIB's single-point "
        "error model: with the same corrections, e.g. --troposphere against RTKLIB's brdc "
        "ionosphere and saas troposphere, its fixes agree; default %(default)s)",
    )
    p.add_argument(
        "--raim",
        nargs="?",
        const="chi2",
        choices=RAIM_METHODS,
        metavar="METHOD",
        help="integrity monitoring of the fixes: fault detection and exclusion and protection levels "
        "(positions.csv columns hpl_m, vpl_m, raim); chi2 (the residual test, slope levels; the "
        "default method) or ss (solution separation); with --nav-filter: its innovation test and "
        "levels from its covariance; with --tracking vector: also the vector loop's channel fault "
        "monitor at --raim-pfa, and the vector rows' levels from its navigation filter's covariance "
        "(raim: excluded where the monitor left a channel out)",
    )
    p.add_argument(
        "--raim-pfa", type=float, metavar="P", help="with --raim: false-alarm probability of its tests (default 1e-5)"
    )
    p.add_argument(
        "--raim-pmd",
        type=float,
        metavar="P",
        help="with --raim: missed-detection probability of the protection levels (default 1e-3)",
    )
    p.add_argument(
        "--sbas-messages",
        metavar="FILE",
        help="SBAS messages (RTKLIB .sbs log or EGNOS Message Server .ems file) correcting the GPS L1 C/A "
        "least-squares fixes as RTCA DO-229 says (positions.csv columns hpl_m, vpl_m, sbas_sats; an "
        "epoch the corrections do not cover keeps its broadcast fix with sbas_sats 0)",
    )
    p.add_argument(
        "--sbas-signal",
        action="store_true",
        help="track the recording's SBAS L1 GEOs too (PRN 120-158, or --sbas-prn's) and correct the GPS L1 "
        "C/A fixes with the messages they carry, each dated by the GPS channels' epochs (DIR/sbas.csv: "
        "one row a message); with --sbas-messages the file's and the signal's together",
    )
    p.add_argument(
        "--sbas-prn",
        type=int,
        metavar="PRN",
        help="with --sbas-messages or --sbas-signal: the GEO followed (default: the one with the most messages)",
    )
    p.add_argument(
        "--sbas-sigma-noise",
        type=float,
        metavar="M",
        help="with --sbas-messages or --sbas-signal: the code noise (m) in the protection levels' sigma_air (default 0.36, "
        "DO-229's airborne bound for carrier-smoothed code; this receiver's unsmoothed code has about "
        "1.7 m at 45 dB-Hz)",
    )
    p.add_argument(
        "--sbas-mode",
        choices=("pa", "npa"),
        help="with --sbas-messages or --sbas-signal: the horizontal protection level's factor, precision approach (6.0, "
        "the default) or en route to non-precision approach (6.18)",
    )
    p.add_argument("--truth", metavar="LAT,LON,H", help="known position: print and report the errors")
    p.add_argument(
        "--tracking",
        choices=TRACKING_MODES,
        default="scalar",
        help="vector: from the first fix the ekf-pv navigation filter drives every channel's code and "
        "carrier NCOs (default %(default)s)",
    )
    p.add_argument(
        "--vector-channel-filter",
        metavar="NAME",
        help="with --tracking vector: the error-output channel_filter of the vector channels, "
        "discriminator (default) or iq-filter",
    )
    p.add_argument("--vector-channel-params", metavar="JSON", help="its parameters")
    p.add_argument(
        "--vector-accel-psd",
        type=float,
        metavar="M2_S3",
        help="with --tracking vector: white-acceleration PSD (m²/s³) of the navigation filter's "
        "constant-velocity model; raise it for a moving receiver (default: ekf-pv's 0.1)",
    )
    p.add_argument(
        "--approx-position",
        metavar="LAT,LON,H",
        help="with --tracking vector and --ephemeris: approximate position (within ~100 km); with "
        "--start-time, vector tracking starts from acquisition, without waiting for LNAV",
    )
    p.add_argument(
        "--start-time",
        metavar="WEEK,TOW",
        help="GPS week and time of week (s) of the first sample (to ~1 ms), for --approx-position",
    )
    _add_threads_option(p)
    _add_workers_option(p)
    p.add_argument(
        "--outputs",
        metavar="LIST",
        help="comma-separated files for other tools: rinex-nav (navigation.rnx), gsa, gsv (in nmea.txt), "
        "geojson (track.geojson), kml (track.kml), parquet (tracking.parquet, needs pyarrow), rtcm "
        "(observations.rtcm3, RTCM 3 MSM7 observations); default stands for "
        "rinex-nav,gsa,gsv,geojson, the set written without this option",
    )
    p.add_argument(
        "--rinex-version",
        choices=("3", "4"),
        help="navigation.rnx as RINEX 3.04 or 4.00 (default: 3.04, or 4.00 where a record is from CNAV, "
        "which RINEX 3.04 cannot hold)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, a line per tenth elsewhere)")
    _add_live_options(p)
    p.set_defaults(func=_cmd_receive)
    p = sub.add_parser("schema", help="print the JSON schema of comparison configs")
    p.set_defaults(func=_cmd_schema)
    return parser


#: OS errors caused by a path the user gave (exit 2, like other input errors); any other
#: OS error (a full disk...) exits 1.
_PATH_ERRNOS = {
    errno.EACCES,
    errno.EPERM,
    errno.EROFS,
    errno.ENOENT,
    errno.ENOTDIR,
    errno.EISDIR,
    errno.EEXIST,
    errno.ENAMETOOLONG,
    errno.ELOOP,
}
_HINTS = {
    errno.EACCES: "not writable or readable by this user; choose another path",
    errno.EPERM: "not permitted; choose another path",
    errno.EROFS: "on a read-only file system; choose another path",
    errno.ENOSPC: "no space left on the device; free some or choose another --out (finished batches are "
    "kept and a rerun resumes)",
    errno.EDQUOT: "disk quota exceeded; free some or choose another --out",
}


def os_error_message(exc: OSError) -> str:
    """One line for an OS-level failure: the path, what went wrong, what to do."""
    message = exc.strerror or str(exc) or type(exc).__name__
    if exc.filename is not None:
        message = f"{exc.filename}: {message}"
    hint = _HINTS.get(exc.errno or 0)
    return f"{message} ({hint})" if hint else message


#: The library names a bad value by its parameter (``sample_rate_hz``); the command line
#: reports it by the option that gives it (``--fs``). One table for every command: a
#: command reports an option only if it has it, and an error of a field the table does not
#: hold (a config file's ``nav_filter.params.accel_psd``) keeps its name.
OPTION_OF_PARAMETER = {
    "format": "--format",
    "sample_rate_hz": "--fs",
    "if_hz": "--if",
    "q_sign": "--q-sign",
    "acquisition": "--acquisition",
    "signal": "--signal",
    "out": "--out",
    "channel_filter": "--channel-filter",
    "channel_params": "--channel-params",
    "nav_filter": "--nav-filter",
    "approx_position": "--approx-position",
    "start_time": "--start-time",
    "rate_hz": "--rate",
    "filter_name": "--filter",
    "noise_adapter": "--noise-adapter",
    "augmentation": "--augmentation",
    "psi": "--psi",
    "max_speed_mps": "--max-speed",
    "max_abs_height_m": "--max-height",
    "select": "--prn",
    "max_gap_s": "--max-gap",
    "pseudorange_min_m": "--pseudorange-min",
    "pseudorange_max_m": "--pseudorange-max",
    "raim": "--raim",
    "sbas": "--sbas-messages",
    "sbas_messages": "--sbas-messages",
    "sbas_signal": "--sbas-signal",
    "sbas_mode": "--sbas-mode",
    "sbas_prn": "--sbas-prn",
    "sbas_sigma_noise": "--sbas-sigma-noise",
    "smooth": "--smooth",
    "raim_false_alarm": "--raim-pfa",
    "raim_missed_detection": "--raim-pmd",
    "outputs": "--outputs",
    "rinex_version": "--rinex-version",
    "threads": "--threads",
    "tracking.coherent_ms": "--coherent-ms-track",
}
#: Parameters that take a table of values: the path below them is kept
#: (``channel_params.pll_bandwidth_hz`` is ``--channel-params.pll_bandwidth_hz``).
TABLE_PARAMETERS = ("channel_params",)


#: Every option `OPTION_OF_PARAMETER` names: `option_field`'s default.
ALL_OPTIONS = frozenset(OPTION_OF_PARAMETER.values())


def option_field(field: str, options: frozenset[str] | set[str] = ALL_OPTIONS) -> str:
    """The field of a library error as the command line names it: each parameter of
    ``field`` (several joined by ``/``) replaced by its option (`OPTION_OF_PARAMETER`)
    when the command has that option (``options``); ``field`` itself otherwise.

    Examples
    --------
    >>> option_field("sample_rate_hz"), option_field("channel_params.pll_bandwidth_hz")
    ('--fs', '--channel-params.pll_bandwidth_hz')
    >>> option_field("pseudorange_min_m/pseudorange_max_m"), option_field("nav_filter.name")
    ('--pseudorange-min/--pseudorange-max', 'nav_filter.name')
    """
    out = []
    for part in field.split("/"):
        head, dot, rest = part.partition(".")
        key = head if (not dot or head in TABLE_PARAMETERS) else part
        option = OPTION_OF_PARAMETER.get(key)
        if option is None or option not in options:
            return field
        out.append(option + (dot + rest if key == head else ""))  # a dotted key maps whole
    return "/".join(out)


def _error_message(exc: GnssFrameworkError, options: frozenset[str]) -> str:
    """One line for a library error: a `ConfigError` with its field named as the command's option."""
    if isinstance(exc, ConfigError) and exc.field:
        field = option_field(exc.field, options)
        if field != exc.field:
            return f"{field}: {exc.detail}"
    return str(exc)


@contextmanager
def _one_line_warnings() -> Iterator[None]:
    """The library's own warnings (`GnssFrameworkWarning`) as one ``warning:`` line on
    standard error each, once per message, without Python's file, line and source line;
    any other warning as Python shows it."""
    shown = warnings.showwarning
    said: set[str] = set()  # Python's "default" is once per place in the code, not per message

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, GnssFrameworkWarning):
            if str(message) not in said:
                said.add(str(message))
                print(f"warning: {message}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        warnings.simplefilter("default", GnssFrameworkWarning)
        warnings.showwarning = show
        yield


def _fail(message: str, status: int) -> int:
    print(f"error: {message}", file=sys.stderr)
    return status


class _QuietPipe:
    """stdout that stops writing, without an error, once its reader has gone (``| head``).

    The command still runs to its end and returns its own exit status: its output file is
    written whatever happened to the summary on stdout.
    """

    def __init__(self, stream) -> None:
        self.stream, self.closed_by_reader = stream, False

    def _quiet(self) -> None:
        import os

        self.closed_by_reader = True
        try:  # the interpreter flushes fd 1 again at exit: point it at /dev/null
            os.dup2(os.open(os.devnull, os.O_WRONLY), self.stream.fileno())
        except (OSError, ValueError):  # no real descriptor (captured output)
            pass

    def write(self, text: str) -> int:
        if self.closed_by_reader:
            return len(text)
        try:
            return self.stream.write(text)
        except BrokenPipeError:
            self._quiet()
            return len(text)

    def flush(self) -> None:
        if not self.closed_by_reader:
            try:
                self.stream.flush()
            except BrokenPipeError:
                self._quiet()

    def __getattr__(self, name: str):
        return getattr(self.stream, name)


#: Options whose value is a list of numbers that may start with a minus sign (southern
#: latitudes, western longitudes): argparse takes ``-33.4,-70.6,500`` for an option.
COORDINATE_OPTIONS = ("--truth", "--approx-position")
_NUMBER_LIST = re.compile(r"-\.?\d")


def attach_negative_values(argv: Sequence[str]) -> list[str]:
    """``argv`` with each `COORDINATE_OPTIONS` option followed by a value that starts with a
    negative number joined to it (``--truth -33.4,-70.6,500`` -> ``--truth=-33.4,-70.6,500``),
    as argparse parses it; every other token unchanged."""
    out: list[str] = []
    tokens = list(argv)
    k = 0
    while k < len(tokens):
        if (
            tokens[k] in COORDINATE_OPTIONS
            and k + 1 < len(tokens)
            and "--" not in tokens[:k]
            and _NUMBER_LIST.match(tokens[k + 1])
        ):
            out.append(f"{tokens[k]}={tokens[k + 1]}")
            k += 2
            continue
        out.append(tokens[k])
        k += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code. Library errors print one line, no traceback:
    exit 2 for configuration and input errors (a bad path included), 1 for other OS
    failures (a full disk), 130 for Ctrl-C; a closed pipe on stdout ends the printing
    quietly. Coordinate options take negative values (`attach_negative_values`); a
    non-finite number option is refused."""
    parser = build_parser()
    args = parser.parse_args(attach_negative_values(sys.argv[1:] if argv is None else argv))
    bad = _non_finite_option(args)
    if bad:
        return _fail(bad, 2)
    stdout, sys.stdout = sys.stdout, _QuietPipe(sys.stdout)
    interrupted = _CtrlC()
    try:
        with _one_line_warnings():
            return int(args.func(args) or 0)
    except GnssFrameworkError as exc:
        return _fail(_error_message(exc, getattr(args, "command_options", frozenset())), 2)
    except KeyboardInterrupt:
        return _fail("interrupted (Ctrl-C)" + getattr(args, "interrupt_hint", ""), 130)
    except OSError as exc:
        return _fail(os_error_message(exc), 2 if exc.errno in _PATH_ERRNOS else 1)
    except Exception:
        # A Ctrl-C inside a library that swallows it and fails otherwise (numba cut in the
        # middle of compiling a kernel raises "no compiled object yet"): still an interruption.
        if interrupted.seen:
            return _fail("interrupted (Ctrl-C)" + getattr(args, "interrupt_hint", ""), 130)
        raise
    finally:
        interrupted.restore()
        sys.stdout.flush()
        sys.stdout = stdout


def _non_finite_option(args: argparse.Namespace) -> str | None:
    """``"--fs: must be a finite number, got nan"`` for the first number option given as
    NaN or infinity (no option of any command means anything there), else ``None``; the
    option named as the command has it (``command_flags``, `_Parser.parse_known_args`)."""
    import math

    flags: dict[str, str] = getattr(args, "command_flags", {})
    for dest, value in vars(args).items():
        values = value if isinstance(value, list) else [value]
        for v in values:
            if isinstance(v, float) and not math.isfinite(v):
                return f"{flags.get(dest, dest)}: must be a finite number, got {v}"
    return None


class _CtrlC:
    """Remembers a SIGINT (then raises KeyboardInterrupt as Python's default handler does)."""

    def __init__(self) -> None:
        import signal

        self.seen = False
        self._previous = None
        if _is_main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handle)

    def _handle(self, signum, frame) -> None:
        self.seen = True
        raise KeyboardInterrupt

    def restore(self) -> None:
        import signal

        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


def _is_main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
