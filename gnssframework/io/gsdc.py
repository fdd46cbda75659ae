"""Google Smartphone Decimeter Challenge 2022 files: the baseline WLS fixes and the
per-satellite measurement rows of ``device_gnss.csv``, and the reference trajectory of
``ground_truth.csv``.

Both are plain CSV with a header naming the columns (the challenge's data description);
the standard ``csv`` module reads them, and every row is checked so that a bad value names
its file and line.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d

from ..errors import DataFileError
from .text import check_input_file

__all__ = [
    "GsdcFixes",
    "GsdcMeasurements",
    "read_gsdc_wls",
    "read_gsdc_truth",
    "read_gsdc_measurements",
    "DEVICE_COLUMNS",
    "TRUTH_COLUMNS",
    "MEASUREMENT_COLUMNS",
    "CONSTELLATION_LETTERS",
]

#: Columns of device_gnss.csv used: the epoch and the baseline WLS position (ECEF, m).
DEVICE_COLUMNS = ("utcTimeMillis", "WlsPositionXEcefMeters", "WlsPositionYEcefMeters", "WlsPositionZEcefMeters")
#: Columns of device_gnss.csv's per-satellite rows read by `read_gsdc_measurements` (numbers;
#: an empty field, a signal not tracked, reads as NaN).
MEASUREMENT_COLUMNS = (
    "utcTimeMillis",
    "ConstellationType",
    "Svid",
    "RawPseudorangeMeters",
    "RawPseudorangeUncertaintyMeters",
    "SvPositionXEcefMeters",
    "SvPositionYEcefMeters",
    "SvPositionZEcefMeters",
    "SvClockBiasMeters",
    "IsrbMeters",
    "IonosphericDelayMeters",
    "TroposphericDelayMeters",
    "SvElevationDegrees",
    "WlsPositionXEcefMeters",
    "WlsPositionYEcefMeters",
    "WlsPositionZEcefMeters",
)
#: Android's ``GnssStatus`` constellation types as RINEX letters (0: unknown).
CONSTELLATION_LETTERS = {0: "?", 1: "G", 2: "S", 3: "R", 4: "J", 5: "C", 6: "E", 7: "I"}
#: Columns of ground_truth.csv used.
TRUTH_COLUMNS = ("UnixTimeMillis", "LatitudeDegrees", "LongitudeDegrees", "AltitudeMeters")


@dataclass
class GsdcFixes:
    """One position per epoch: ``utc_ms`` (Unix ms), geodetic ``lat_deg``, ``lon_deg``,
    ``height_m`` (WGS 84), and the CSV ``line`` each came from."""

    utc_ms: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    height_m: np.ndarray
    line: np.ndarray


def _csv_rows(path: Path, columns: tuple[str, ...], kind: str) -> tuple[list[int], list[tuple[int, list[str]]]]:
    """The header positions of ``columns`` and ``(line, fields)`` of every non-empty data
    row; refuse a file that cannot be read or lacks a column (``kind`` names the file kind)."""
    path = check_input_file(path)  # a device or a pipe would be read without end
    try:
        fh = open(path, newline="")
    except OSError as exc:
        raise DataFileError(str(path), None, f"cannot read: {exc.strerror}") from None
    with fh:
        reader = csv.reader(fh)
        header = next(reader, [])
        missing = [c for c in columns if c not in header]
        if missing:
            raise DataFileError(str(path), 1, f"not a GSDC 2022 {kind}: no column {', '.join(missing)}")
        rows = [(no, row) for no, row in enumerate(reader, 2) if row]
    if not rows:
        raise DataFileError(str(path), None, "no data rows")
    return [header.index(c) for c in columns], rows


def _rows(path: Path, columns: tuple[str, ...]) -> list[tuple[int, list[float]]]:
    """``(line, values)`` of every data row; refuse a missing column or a bad number."""
    index, rows = _csv_rows(path, columns, "file of this kind")
    out = []
    for no, row in rows:
        try:
            values = [float(row[i]) for i in index]
        except (ValueError, IndexError):
            raise DataFileError(str(path), no, f"expected numbers in {', '.join(columns)}") from None
        if not np.all(np.isfinite(values)):
            raise DataFileError(str(path), no, f"non-finite value in {', '.join(columns)}")
        out.append((no, values))
    return out


def read_gsdc_wls(path: str | Path) -> GsdcFixes:
    """The baseline weighted-least-squares fix of each epoch of a ``device_gnss.csv``
    (one per ``utcTimeMillis``; the file repeats it on every measurement row)."""
    rows = _rows(Path(path), DEVICE_COLUMNS)
    epochs: dict[float, tuple[int, list[float]]] = {}
    for no, values in rows:
        first = epochs.setdefault(values[0], (no, values))
        if first[1][1:] != values[1:]:
            raise DataFileError(str(path), no, f"WLS position differs from line {first[0]} of the same epoch")
    utc = np.array(sorted(epochs))
    xyz = np.array([epochs[t][1][1:] for t in utc])
    lat, lon, h = pymap3d.ecef2geodetic(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    return GsdcFixes(utc, np.asarray(lat), np.asarray(lon), np.asarray(h), np.array([epochs[t][0] for t in utc]))


def read_gsdc_truth(path: str | Path) -> GsdcFixes:
    """The reference trajectory of a ``ground_truth.csv``."""
    rows = _rows(Path(path), TRUTH_COLUMNS)
    arr = np.array([v for _, v in rows])
    order = np.argsort(arr[:, 0], kind="stable")
    return GsdcFixes(
        arr[order, 0], arr[order, 1], arr[order, 2], arr[order, 3], np.array([no for no, _ in rows])[order]
    )


@dataclass
class GsdcMeasurements:
    """The per-satellite rows of a ``device_gnss.csv`` (one entry a row, file order), NaN
    where a field is empty: ``utc_ms`` (Unix ms), ``system`` the RINEX letter of the
    ``ConstellationType``, ``svid``, ``signal`` the ``SignalType`` (``GPS_L1``, ``GAL_E1``,
    ``BDS_B1I``, ...; empty where the row has none), ``pseudorange_m`` and its
    ``pseudorange_sigma_m``, ``sv_position_ecef_m`` ``(N, 3)`` (at transmit time, ECEF),
    ``sv_clock_m`` (satellite clock bias times c), ``isrb_m`` (Google's inter-signal range
    bias), ``iono_m`` and ``tropo_m`` (delays), ``elevation_deg``, ``wls_ecef_m`` ``(N, 3)``
    Google's baseline fix of the row's epoch, and the CSV ``line`` of each."""

    utc_ms: np.ndarray
    system: np.ndarray
    svid: np.ndarray
    signal: np.ndarray
    pseudorange_m: np.ndarray
    pseudorange_sigma_m: np.ndarray
    sv_position_ecef_m: np.ndarray
    sv_clock_m: np.ndarray
    isrb_m: np.ndarray
    iono_m: np.ndarray
    tropo_m: np.ndarray
    elevation_deg: np.ndarray
    wls_ecef_m: np.ndarray
    line: np.ndarray


def read_gsdc_measurements(path: str | Path) -> GsdcMeasurements:
    """Every measurement row of a ``device_gnss.csv`` (`MEASUREMENT_COLUMNS` and ``SignalType``).

    Raises
    ------
    DataFileError
        Naming the file and the line: a missing column, a field that is not a number, an
        infinite value, an epoch or constellation that is empty or not an integer.
    """
    columns = MEASUREMENT_COLUMNS + ("SignalType",)
    index, rows = _csv_rows(Path(path), columns, "device_gnss file")
    values, signals, lines = [], [], []
    for no, row in rows:
        if len(row) <= max(index):
            raise DataFileError(
                str(path), no, f"{len(row)} fields, too few for column {columns[int(np.argmax(index))]}"
            )
        out = []
        for name, i in zip(MEASUREMENT_COLUMNS, index):
            text = row[i].strip()
            try:
                v = float(text) if text else float("nan")
            except ValueError:
                raise DataFileError(str(path), no, f"{name}: not a number: {text!r}") from None
            integer = name in MEASUREMENT_COLUMNS[:3]  # the epoch, constellation and satellite
            if np.isinf(v) or (integer and not (np.isfinite(v) and v == round(v))):
                kind = "an integer" if integer else "a finite number"
                raise DataFileError(str(path), no, f"{name}: expected {kind}, got {text!r}")
            out.append(v)
        if int(out[1]) not in CONSTELLATION_LETTERS:
            raise DataFileError(str(path), no, f"ConstellationType: unknown type {int(out[1])}")
        values.append(out)
        signals.append(row[index[-1]].strip())
        lines.append(no)
    a = np.array(values)
    return GsdcMeasurements(
        a[:, 0].astype(np.int64),
        np.array([CONSTELLATION_LETTERS[int(c)] for c in a[:, 1]]),
        a[:, 2].astype(np.int64),
        np.array(signals),
        a[:, 3],
        a[:, 4],
        a[:, 5:8],
        a[:, 8],
        a[:, 9],
        a[:, 10],
        a[:, 11],
        a[:, 12],
        a[:, 13:16],
        np.array(lines),
    )
