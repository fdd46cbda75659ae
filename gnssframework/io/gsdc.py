"""Google Smartphone Decimeter Challenge 2022 files: the baseline WLS fixes of
``device_gnss.csv`` and the reference trajectory of ``ground_truth.csv``.

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

__all__ = ["GsdcFixes", "read_gsdc_wls", "read_gsdc_truth", "DEVICE_COLUMNS", "TRUTH_COLUMNS"]

#: Columns of device_gnss.csv used: the epoch and the baseline WLS position (ECEF, m).
DEVICE_COLUMNS = ("utcTimeMillis", "WlsPositionXEcefMeters", "WlsPositionYEcefMeters", "WlsPositionZEcefMeters")
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


def _rows(path: Path, columns: tuple[str, ...]) -> list[tuple[int, list[float]]]:
    """``(line, values)`` of every data row; refuse a missing column or a bad number."""
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
            raise DataFileError(str(path), 1, f"not a GSDC 2022 file of this kind: no column {', '.join(missing)}")
        index = [header.index(c) for c in columns]
        out = []
        for no, row in enumerate(reader, 2):
            if not row:
                continue
            try:
                values = [float(row[i]) for i in index]
            except (ValueError, IndexError):
                raise DataFileError(str(path), no, f"expected numbers in {', '.join(columns)}") from None
            if not np.all(np.isfinite(values)):
                raise DataFileError(str(path), no, f"non-finite value in {', '.join(columns)}")
            out.append((no, values))
    if not out:
        raise DataFileError(str(path), None, "no data rows")
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
    return GsdcFixes(utc, np.asarray(lat), np.asarray(lon), np.asarray(h),
                     np.array([epochs[t][0] for t in utc]))


def read_gsdc_truth(path: str | Path) -> GsdcFixes:
    """The reference trajectory of a ``ground_truth.csv``."""
    rows = _rows(Path(path), TRUTH_COLUMNS)
    arr = np.array([v for _, v in rows])
    order = np.argsort(arr[:, 0], kind="stable")
    return GsdcFixes(arr[order, 0], arr[order, 1], arr[order, 2], arr[order, 3],
                     np.array([no for no, _ in rows])[order])
