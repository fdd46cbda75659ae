"""The per-satellite rows of a GSDC 2022 ``device_gnss.csv`` (`io.gsdc.read_gsdc_measurements`)
against the file's own text read by the csv module, and its one-line errors."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import DataFileError
from gnssframework.io.gsdc import read_gsdc_measurements

DEVICE = Path(__file__).resolve().parents[1] / "data" / "gsdc2022_device_gnss.csv"


def test_rows_are_read_as_the_file_writes_them():
    m = read_gsdc_measurements(DEVICE)
    with open(DEVICE, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert m.line.tolist() == list(range(2, 2 + len(rows))) and len(rows) == 234
    letters = {"1": "G", "3": "R", "4": "J", "5": "C", "6": "E"}
    assert m.system.tolist() == [letters[r["ConstellationType"]] for r in rows]
    assert m.signal.tolist() == [r["SignalType"] for r in rows]
    for i in (0, 21, 233):  # a GPS L1, a BeiDou B1I and a Galileo E5a row
        r = rows[i]
        assert m.pseudorange_m[i] == float(r["RawPseudorangeMeters"])
        assert m.sv_position_ecef_m[i].tolist() == [float(r[f"SvPosition{a}EcefMeters"]) for a in "XYZ"]
        assert (m.sv_clock_m[i], m.isrb_m[i], m.iono_m[i], m.tropo_m[i]) == tuple(
            float(r[k])
            for k in ("SvClockBiasMeters", "IsrbMeters", "IonosphericDelayMeters", "TroposphericDelayMeters")
        )
        assert m.utc_ms[i] == int(r["utcTimeMillis"]) and m.svid[i] == int(r["Svid"])
    # A satellite seen but not measured: empty fields read as NaN.
    assert rows[5]["RawPseudorangeMeters"] == "" and np.isnan(m.pseudorange_m[5])


@pytest.mark.parametrize(
    ("column", "value", "message"),
    [
        ("RawPseudorangeMeters", "abc", r"gnss.csv:3: RawPseudorangeMeters: not a number: 'abc'"),
        ("SvClockBiasMeters", "inf", r"gnss.csv:3: SvClockBiasMeters: expected a finite number, got 'inf'"),
        ("Svid", "2.5", r"gnss.csv:3: Svid: expected an integer, got '2.5'"),
        ("ConstellationType", "9", r"gnss.csv:3: ConstellationType: unknown type 9"),
    ],
)
def test_a_bad_value_names_the_file_line_and_column(tmp_path, column, value, message):
    lines = DEVICE.read_text().splitlines()
    header = lines[0].split(",")
    fields = lines[2].split(",")
    fields[header.index(column)] = value
    lines[2] = ",".join(fields)
    bad = tmp_path / "device_gnss.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFileError, match=message):
        read_gsdc_measurements(bad)


def test_a_truth_file_is_not_a_device_file():
    with pytest.raises(DataFileError, match=r"gsdc2022_ground_truth.csv:1: not a GSDC 2022 device_gnss file"):
        read_gsdc_measurements(DEVICE.parent / "gsdc2022_ground_truth.csv")
