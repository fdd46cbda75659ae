"""Reference 004's position filters on real fixes (examples/positions_real.py) and the GSDC
2022 reader, on the copies in tests/data."""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.io.gsdc import read_gsdc_truth, read_gsdc_wls
from gnssframework.io.nmea import read_nmea

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
DEVICE, TRUTH = DATA / "gsdc2022_device_gnss.csv", DATA / "gsdc2022_ground_truth.csv"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("positions_real", ROOT / "examples" / "positions_real.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_wls_fixes_are_one_per_epoch_and_match_the_ecef_columns():
    wls = read_gsdc_wls(DEVICE)
    with open(DEVICE, newline="") as fh:
        rows = list(csv.DictReader(fh))
    epochs = sorted({float(r["utcTimeMillis"]) for r in rows})
    assert wls.utc_ms.tolist() == epochs
    first = rows[0]
    x, y, z = (float(first[f"WlsPosition{a}EcefMeters"]) for a in "XYZ")
    # Geodetic latitude from ECEF by Bowring's closed form on WGS 84 (independent of pymap3d's iteration).
    a, f = 6378137.0, 1 / 298.257223563
    b, e2 = a * (1 - f), f * (2 - f)
    ep2 = (a**2 - b**2) / b**2
    p = np.hypot(x, y)
    th = np.arctan2(z * a, p * b)
    lat = np.degrees(np.arctan2(z + ep2 * b * np.sin(th) ** 3, p - e2 * a * np.cos(th) ** 3))
    assert wls.lat_deg[0] == pytest.approx(lat, abs=1e-9)
    assert wls.lon_deg[0] == pytest.approx(np.degrees(np.arctan2(y, x)), abs=1e-12)


def test_truth_rows_and_a_bad_value_names_its_line(tmp_path):
    truth = read_gsdc_truth(TRUTH)
    assert truth.utc_ms.size == len(TRUTH.read_text().splitlines()) - 1
    lines = TRUTH.read_text().splitlines()
    lines[5] = lines[5].replace("37.39", "3x.39", 1)
    bad = tmp_path / "gt.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(gf.DataFileError, match=r"gt.csv:6: expected numbers"):
        read_gsdc_truth(bad)
    with pytest.raises(gf.DataFileError, match=r"gsdc2022_ground_truth.csv:1: not a GSDC 2022 file of this kind"):
        read_gsdc_wls(TRUTH)


def test_the_example_reports_errors_against_the_stated_truths(example, tmp_path):
    data = tmp_path / "data"
    (data / "nmea").mkdir(parents=True)
    (data / "phone").mkdir()
    (data / "nmea" / "ublox-zed-f9p-nmea.log").symlink_to(DATA / "ublox-zed-f9p-nmea.log")
    for f in (DEVICE, TRUTH):
        (data / "phone" / f.name).symlink_to(f)
    assert example.main(["--data", str(data), "--out", str(tmp_path / "out")]) == 0
    s = json.loads((tmp_path / "out" / "positions_real.json").read_text())
    assert s["zed-f9p"]["epochs"] == 29 and s["gsdc2022"]["epochs"] == 6
    # Raw F9P error by an equirectangular approximation (metres per degree on the WGS 84
    # ellipsoid at 45.9 S): independent of pymap3d, good to 1e-3 over metres.
    fixes = read_nmea(DATA / "ublox-zed-f9p-nmea.log")
    lat0, lon0 = -45.877591500, 170.500124833
    a, e2 = 6378137.0, 6.69437999014e-3
    s2 = np.sin(np.radians(lat0)) ** 2
    m_per_deg_lat = np.radians(1) * a * (1 - e2) / (1 - e2 * s2) ** 1.5
    m_per_deg_lon = np.radians(1) * a * np.cos(np.radians(lat0)) / np.sqrt(1 - e2 * s2)
    err = np.hypot((fixes.lat_deg - lat0) * m_per_deg_lat, (fixes.lon_deg - lon0) * m_per_deg_lon)
    assert s["zed-f9p"]["raw"]["rms_m"] == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-3)
    assert "values only" in (tmp_path / "out" / "positions_real.md").read_text()


def test_the_pages_table_is_what_the_script_writes_from_its_summary(example):
    # CI regenerates both with --docs from ../shared/data; the committed table must be the
    # script's rendering of the committed summary (never edited by hand).
    generated = ROOT / "docs" / "experiments" / "generated"
    summary = json.loads((generated / "positions_real.json").read_text())
    assert (generated / "positions_real.md").read_text() == example.markdown(summary)
    assert set(summary) == set(example.TRACKS)
