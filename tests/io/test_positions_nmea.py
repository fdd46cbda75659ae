"""NMEA reading (pynmea2), corrupted sentences, and the filter-positions command."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pymap3d
import pytest

import gnssframework as gf
from gnssframework.io.nmea import read_nmea
from gnssframework.io.positions import filter_positions

LOG = Path(__file__).resolve().parents[2] / "examples" / "data" / "static_receiver.nmea"
LAT0, LON0 = 30.5281, 114.3545  # the static truth the log was generated about


def _corrupt(tmp_path):
    lines = LOG.read_text().splitlines()
    lines[4] = lines[4][:-2] + ("00" if not lines[4].endswith("00") else "11")  # bad checksum
    lines[9] = lines[9][:30]  # truncated
    lines[15] = "$GNGGA,garbage*00"
    body = "GPGSV,3,1,12,01,40,083,46"
    checksum = 0
    for ch in body:
        checksum ^= ord(ch)
    lines.insert(20, f"${body}*{checksum:02X}")  # a valid sentence of another type: ignored, not counted
    path = tmp_path / "corrupt.nmea"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_reads_the_generated_log():
    fixes = read_nmea(LOG)
    assert fixes.time_s.size == 500 and fixes.skipped == []
    np.testing.assert_allclose(np.diff(fixes.time_s), 1.0)
    assert abs(np.mean(fixes.lat_deg) - LAT0) < 1e-4


def test_corrupted_sentences_are_skipped_and_counted_with_their_lines(tmp_path):
    fixes = read_nmea(_corrupt(tmp_path))
    lines = [line for line, _ in fixes.skipped]
    assert lines == [5, 10, 16]
    reasons = dict(fixes.skipped)
    assert reasons[5] == "bad checksum" and "truncated" in reasons[10]
    # Epochs whose GGA was lost still have their RMC fix (no height).
    assert fixes.time_s.size == 500 and np.isnan(fixes.height_m).sum() >= 1


def test_a_file_without_fixes_names_the_file(tmp_path):
    bad = tmp_path / "empty.nmea"
    bad.write_text("$GPGSV,3,1,12,01,40,083,46*7B\n")
    with pytest.raises(gf.DataFileError, match="empty.nmea: no valid GGA or RMC fix"):
        read_nmea(bad)


def test_filtering_reduces_the_error_of_the_static_track():
    fixes = read_nmea(LOG)
    e, n, _ = pymap3d.geodetic2enu(fixes.lat_deg, fixes.lon_deg, 0, LAT0, LON0, 0)
    raw = np.sqrt(np.mean(n**2 + e**2))
    # AUKF1 is not asserted: with the colored-ar1 + adapter defect fixed (issue 10) it is
    # no better than raw on this one track (3.95 m vs 3.92 m); an ordering needs many runs.
    for name in ("UKF1",):
        lat, lon, _, _ = filter_positions(fixes, name)
        fe, fn, _ = pymap3d.geodetic2enu(lat, lon, 0, LAT0, LON0, 0)
        assert np.sqrt(np.mean(fn**2 + fe**2)) < raw


@pytest.mark.slow
def test_cli_filter_positions_writes_csv_and_lists_skipped_lines(tmp_path):
    out = tmp_path / "filtered.csv"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gnssframework",
            "filter-positions",
            str(_corrupt(tmp_path)),
            "--out",
            str(out),
            "--filter",
            "AUKF1",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 3, proc.stderr  # output written, lines skipped
    assert "3 sentences skipped" in proc.stdout and "skipped line 10:" in proc.stdout
    rows = out.read_text().splitlines()
    assert rows[0].startswith("time_s,nmea_line,lat_deg") and len(rows) == 501


def test_filter_positions_takes_registry_names_as_well_as_the_papers_labels():
    from gnssframework.io.positions import CANDIDATES, composition

    assert composition("ukf1") == CANDIDATES["UKF1"]  # labels in any case
    comp = composition("ckf", noise_adapter="sage-husa", augmentation="colored-ar1")
    assert comp["estimator"]["name"] == "ckf" and comp["noise_adapter"]["name"] == "sage-husa"
    assert comp["augmentation"]["name"] == "colored-ar1" and comp["nav_filter"]["name"] == "position-ca"
    # On the linear position model every Gaussian engine is the Kalman filter: the registry's
    # kf and ckf give the same track, up to rounding.
    fixes = read_nmea(LOG)
    lat_kf, lon_kf, _, _ = filter_positions(fixes, "kf")
    lat_ckf, lon_ckf, _, _ = filter_positions(fixes, "ckf")
    np.testing.assert_allclose(lat_ckf, lat_kf, rtol=0, atol=1e-9)  # 1e-9 deg ~ 0.1 mm
    np.testing.assert_allclose(lon_ckf, lon_kf, rtol=0, atol=1e-9)
    e, n, _ = pymap3d.geodetic2enu(fixes.lat_deg, fixes.lon_deg, 0, LAT0, LON0, 0)
    fe, fn, _ = pymap3d.geodetic2enu(lat_kf, lon_kf, 0, LAT0, LON0, 0)
    assert np.sqrt(np.mean(fn**2 + fe**2)) < np.sqrt(np.mean(n**2 + e**2))


@pytest.mark.slow
def test_filter_positions_names_the_option_of_an_unknown_name(tmp_path):
    from gnssframework.errors import ConfigError
    from gnssframework.io.positions import composition

    with pytest.raises(ConfigError, match=r"^filter_name: .*'ukff'.*did you mean 'UKF'"):
        composition("ukff")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gnssframework",
            "filter-positions",
            str(LOG),
            "--out",
            str(tmp_path / "f.csv"),
            "--filter",
            "ckf",
            "--noise-adapter",
            "sage-hus",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2 and "--noise-adapter" in proc.stderr and "sage-husa" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
