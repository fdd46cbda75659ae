"""Acquisition of a recording and its CSV: what the ``acquire`` command does."""

from __future__ import annotations

import csv
from pathlib import Path

from ...io.files import atomic_open
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from ..frontend.recording import Recording
from .search import Acquisition, AcquisitionResult, check_contract

__all__ = ["acquire_recording", "write_acquisition_csv", "search_summary", "CSV_COLUMNS"]

CSV_COLUMNS = ("prn", "doppler_hz", "code_phase_chips", "code_phase_samples", "cn0_dbhz", "test_statistic")


def acquire_recording(
    recording: Recording,
    acquisition: Acquisition,
    prns: tuple[int, ...] | None = None,
    start_sample: int = 0,
    signal: SignalSpec = GPS_L1CA,
) -> list[AcquisitionResult]:
    """Run ``acquisition`` for ``signal`` (GPS L1 C/A by default; ``prns`` None: all of its
    PRNs) on the samples it needs from ``start_sample`` of ``recording``."""
    check_contract(acquisition)
    fs = recording.info.sample_rate_hz
    samples = recording.read(start_sample, acquisition.samples_needed(fs, signal))
    return acquisition.acquire(samples, fs, recording.info.if_hz, prns, signal)


def search_summary(
    recording: Recording, acquisition: Acquisition, prns: tuple[int, ...] | None, signal: SignalSpec = GPS_L1CA
) -> str:
    """What was searched, for the "nothing found" message (``prns`` None: all of ``signal``'s)."""
    prns = signal.prns if prns is None else prns
    p = acquisition.params
    what = ", ".join(f"{k} {v}" for k, v in p.model_dump().items() if v is not None)
    contiguous = list(prns) == list(range(min(prns), max(prns) + 1))
    which = f"{min(prns)}-{max(prns)}" if contiguous else ", ".join(str(p) for p in prns)
    return (
        f"searched PRN {which} ({len(prns)} PRNs) with {acquisition.name} ({what}) in "
        f"{recording.path.name} read as {recording.info.describe()}"
    )


def write_acquisition_csv(path: str | Path, results: list[AcquisitionResult]) -> None:
    """One row per detected satellite, columns `CSV_COLUMNS`."""
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for r in results:
            if r.detected:
                w.writerow(
                    [
                        r.prn,
                        f"{r.doppler_hz:.1f}",
                        f"{r.code_phase_chips:.3f}",
                        r.code_phase_samples,
                        f"{r.cn0_dbhz:.1f}",
                        f"{r.test_statistic:.2f}",
                    ]
                )
