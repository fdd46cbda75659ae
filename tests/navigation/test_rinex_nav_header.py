"""A navigation file's header Klobuchar model and the dates its records span
(`navigation.rinex_nav_header`), against the files' own lines."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import DataFileError
from gnssframework.navigation.rinex_nav_header import read_nav_file_info

DATA = Path(__file__).parents[1] / "data"


def test_rinex2_header_and_span():
    info = read_nav_file_info(DATA / "07590920.05n")
    # ION ALPHA / ION BETA / LEAP SECONDS lines of the file, read by eye.
    assert info.iono.alpha == (1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08)
    assert info.iono.beta == (8.8060e04, 1.6380e04, -1.9660e05, -1.3110e05)
    assert info.iono.dt_ls_s == 13
    # First record 2005-04-01 23:59:44, last 2005-04-03 00:00:00: GPS week 1316 began 2005-03-27.
    assert info.dates() == "2005-04-01 23:59:44 to 2005-04-03 00:00:00 GPS"
    saturday_noon = 6 * 86400 + 12 * 3600.0
    assert info.week_at(saturday_noon) == 1316 and info.covers(1316, saturday_noon)
    assert info.week_at(3600.0) == 1317  # Sunday 01:00: the following week's, nearest the records
    assert not info.covers(1316, 4 * 86400.0)  # Thursday: a day before the first record
    first = 6 * 86400.0 - 16.0  # Friday 23:59:44 (Sunday is day 0)
    assert info.covers(1316, first - 7000.0) and not info.covers(1316, first - 7300.0)  # the 2 h fit


def test_rinex3_header_takes_the_gps_lines():
    info = read_nav_file_info(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx")
    assert info.iono.alpha == (5.5879e-09, 1.4901e-08, -5.9605e-08, -1.1921e-07)
    assert info.iono.beta == (8.3968e04, 9.8304e04, -6.5536e04, -5.2429e05)
    assert info.iono.dt_ls_s == 18
    assert info.dates().startswith("2018-06-19 00:00:00")
    assert info.week_at(2 * 86400 + 3600.0) == 2006  # Tuesday 2018-06-19 is in GPS week 2006


def test_a_missing_or_malformed_file_is_named(tmp_path):
    with pytest.raises(DataFileError, match="no such file"):
        read_nav_file_info(tmp_path / "none.nav")
    bad = tmp_path / "bad.05n"
    bad.write_text((DATA / "07590920.05n").read_text().replace("1.1180D-08", "1.1180X-08"))
    with pytest.raises(DataFileError, match="ION ALPHA"):
        read_nav_file_info(bad)


def test_the_ggto_lines_of_rinex3_headers():
    # VILL (RINEX 3.03): "GPGA  2.2322637960E-08-1.021405183E-14 259200 2006", read by eye.
    vill = read_nav_file_info(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx")
    assert vill.ggto == (2.2322637960e-08, -1.021405183e-14, 259200.0, 2006)
    assert vill.ggto_s(2006, 259200.0) == 2.2322637960e-08
    assert vill.ggto_s(2007, 0.0) == pytest.approx(2.2322637960e-08 - 1.021405183e-14 * 345600.0, abs=1e-20)
    # BRDC (RINEX 3.04): "GAGP  2.2700987756E-09 1.287858709E-14 432000 2105".
    brdc = read_nav_file_info(DATA / "BRDC00IGS_R_20201361400_02H_EN.rnx")
    assert brdc.ggto == (2.2700987756e-09, 1.287858709e-14, 432000.0, 2105)
    # A GPS-only RINEX 2 file has none.
    gps = read_nav_file_info(DATA / "07590920.05n")
    assert gps.ggto is None and np.isnan(gps.ggto_s(1316, 0.0))
    # The sign (GST - GPST): the same header's GAUT - GPUT (GST - UTC less GPST - UTC, each
    # system's UTC realisation within a few ns of the other's) has GGTO's sign and size:
    # 32.9 ns against 22.3 ns at t0G.
    gaut = 3.3527612686e-08 - 1.243449788e-14 * (259200 - 172800)
    gput = -9.3132257462e-10 - 3.552713679e-15 * (259200 - 405504)
    assert (gaut - gput) * vill.ggto_s(2006, 259200.0) > 0 and abs(gaut - gput - vill.ggto[0]) < 15e-9
