"""The `receive` command on Galileo E1-B: the project's generated I/NAV recording
(`inav_recordings`: five satellites of real broadcast records seen from VILL, 45 dB-Hz)
through ``receive --signal galileo-e1b-boc11`` with those records as ``--ephemeris``; its
files read back by independent parsers (georinex, pynmea2) and checked against the
generator's geometry. The navigation file of decoded I/NAV records: a record of the test
file sent as I/NAV, decoded, written and read back by georinex against the file's fields.
"""

from __future__ import annotations

import csv
import warnings
from datetime import datetime, timedelta

import numpy as np
import pynmea2
import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation import inav
from gnssframework.receiver.navigation.decoded import require_positioning
from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav
from gnssframework.signal.constants import L1_FREQ_HZ
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11, GALILEO_E1C_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.qzss_l1ca import QZSS_L1CA

from inav_recordings import GPS_WEEK, NAV, STATION, WN, galileo_records, highest, write_inav_recording
from light_time import signal_flight

TOW0 = 18024.5  # as test_inav_fix: word 5's page (GST 18025 s) has arrived 2.43 s in
DURATION_S = 3.0
C = 299_792_458.0
#: The Doppler's noise: 0.54 Hz RMS over the 70 values of this run (PLL at 45 dB-Hz, 4 ms
#: integrations); 3 Hz is 5.5 of those.
DOPPLER_TOL_HZ = 3.0


def _georinex(path):
    import georinex

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        return georinex.load(path)


@pytest.fixture(scope="module")
def galileo_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("galileo")
    sats = highest(galileo_records(), TOW0, 5)
    path = write_inav_recording(folder / "gal.sigmf-data", sats, TOW0, DURATION_S, seed=7)
    out = folder / "out"
    prns = [str(int(s[1:])) for s in sats.sv]
    code = main(
        [
            "receive",
            str(path),
            "--signal",
            "galileo-e1b-boc11",
            "--prns",
            *prns,
            "--rate",
            "5",
            "--no-iono",
            "--ephemeris",
            str(NAV),
            "--out",
            str(out),
            "--quiet",
        ]
    )
    return code, out, sats


@pytest.mark.slow
def test_receive_galileo_writes_positions_near_the_station(galileo_run):
    code, out, sats = galileo_run
    assert code == 0
    with (out / "positions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) >= 10  # 5 Hz from the word-5 page on (about 2.4 s in)
    assert {int(r["gps_week"]) for r in rows} == {GPS_WEEK}
    assert all(int(r["n_sats"]) == sats.sv.size for r in rows)
    tow = np.array([float(r["tow_s"]) for r in rows])
    assert np.all((tow > TOW0) & (tow < TOW0 + DURATION_S))
    import pymap3d

    xyz = np.stack(
        pymap3d.geodetic2ecef(*(np.array([float(r[k]) for r in rows]) for k in ("lat_deg", "lon_deg", "height_m"))),
        axis=1,
    )
    hdop, vdop = (np.array([float(r[k]) for r in rows]) for k in ("hdop", "vdop"))
    # test_inav_fix's bound: 4 x (HDOP + VDOP) x 1.7 m (the code noise at 45 dB-Hz).
    assert np.all(np.linalg.norm(xyz - STATION, axis=1) < 4 * (hdop + vdop) * 1.7)


@pytest.mark.slow
def test_receive_galileo_observations_are_rinex_galileo_e1b_and_match_the_geometry(galileo_run):
    _, out, sats = galileo_run
    text = (out / "observations.rnx").read_text()
    assert text.splitlines()[0][40:41] == "E"  # RINEX VERSION / TYPE: satellite system
    first_obs = next(line for line in text.splitlines() if line[60:].strip() == "TIME OF FIRST OBS")
    assert first_obs[48:51] == "GAL"  # epochs in Galileo System Time (the I/NAV GST)
    obs = _georinex(out / "observations.rnx")
    assert sorted(obs.sv.values) == sorted(sats.sv)  # E01..E36 names
    # RINEX 3.04's Galileo E1 codes: B is the I/NAV data component (E1-B), C the pilot.
    assert {"C1B", "L1B", "D1B", "S1B"} <= set(obs.data_vars) and "C1C" not in obs.data_vars
    with (out / "positions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert obs.time.size == len(rows)
    bias_m = np.array([float(r["clock_bias_m"]) for r in rows])
    epoch_tow = (obs.time.values - np.datetime64("1980-01-06")).astype("timedelta64[ns]").astype(
        float
    ) / 1e9 - GPS_WEEK * 604_800.0
    for e in range(obs.time.size):
        t_true = epoch_tow[e] - bias_m[e] / C  # the receiver clock (the epoch) less its bias
        for k, sv in enumerate(sats.sv):
            flight = signal_flight(sats.subset(np.array([k])), t_true, STATION)
            # A satellite's clock reads t - tau + clock when it sends; the receiver's t + bias / c.
            expected = C * (flight.tau_s[0] - flight.clock_s[0]) + bias_m[e]
            pr = float(obs["C1B"].sel(sv=sv).values[e])
            # code noise (1.7 m, 1 sigma at 45 dB-Hz; 1.74 m RMS here) and the fix's clock: 5 sigma
            assert abs(pr - expected) < 5 * 1.7, (sv, e, pr - expected)
            # Doppler: the rate of the satellite time received, d(t - tau + clock)/dt - 1, times f_L1
            ahead = signal_flight(sats.subset(np.array([k])), t_true + 0.05, STATION)
            behind = signal_flight(sats.subset(np.array([k])), t_true - 0.05, STATION)
            rate = ((behind.tau_s[0] - ahead.tau_s[0]) + (ahead.clock_s[0] - behind.clock_s[0])) / 0.1
            doppler_hz = float(obs["D1B"].sel(sv=sv).values[e])
            assert abs(doppler_hz - L1_FREQ_HZ * rate) < DOPPLER_TOL_HZ, (sv, e, doppler_hz - L1_FREQ_HZ * rate)
    assert np.all((obs["S1B"].values > 38) & (obs["S1B"].values < 52))


@pytest.mark.slow
def test_receive_galileo_nmea_uses_the_ga_talker_and_galileo_satellite_ids(galileo_run):
    _, out, sats = galileo_run
    parsed = [pynmea2.parse(line, check=True) for line in (out / "nmea.txt").read_text().splitlines()]
    assert {p.talker for p in parsed} == {"GA"}
    with (out / "positions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    gga = [p for p in parsed if p.sentence_type == "GGA"]
    assert len(gga) == len(rows)
    for g, r in zip(gga, rows):
        assert g.latitude == pytest.approx(float(r["lat_deg"]), abs=1e-7)
        assert int(g.num_sats) == sats.sv.size
    # UTC = GST (steered to GPS time) - 18 leap seconds (2022)
    utc = datetime(1980, 1, 6) + timedelta(weeks=GPS_WEEK, seconds=float(rows[0]["tow_s"]) - 18)
    stamp = gga[0].timestamp
    # NMEA hhmmss.ss: the hundredths of the UTC second, cut
    assert (stamp.hour, stamp.minute, stamp.second, stamp.microsecond // 10_000) == (
        utc.hour,
        utc.minute,
        utc.second,
        utc.microsecond // 10_000,
    )
    gsa = [p for p in parsed if p.sentence_type == "GSA"]
    used = {int(getattr(gsa[0], f"sv_id{k:02d}")) for k in range(1, 13) if getattr(gsa[0], f"sv_id{k:02d}")}
    assert used == {int(s[1:]) for s in sats.sv}  # NMEA 4.11: GA satellite ID = Galileo PRN
    gsv_ids = {
        int(getattr(p, f"sv_prn_num_{k}"))
        for p in parsed
        if p.sentence_type == "GSV"
        for k in range(1, 5)
        if getattr(p, f"sv_prn_num_{k}", "")
    }
    assert gsv_ids == used


def test_receive_refuses_a_signal_it_cannot_position_with_in_one_line(tmp_path, capsys):
    from gnssframework.receiver.frontend import write_recording

    for ok in (GPS_L1CA, QZSS_L1CA, GALILEO_E1B_BOC11):
        require_positioning(ok)
    with pytest.raises(ConfigError) as exc:
        require_positioning(GALILEO_E1C_BOC11)  # the pilot: no I/NAV
    assert "galileo-e1c-boc11" in str(exc.value) and len(str(exc.value).splitlines()) == 1
    path = write_recording(tmp_path / "zeros.sigmf-data", np.zeros(4000, complex), "ci16_le", 4e6, 0.0)
    out = tmp_path / "out"
    assert main(["receive", str(path), "--signal", "galileo-e1c-boc11", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "galileo-e1c-boc11" in err[0]
    assert not out.exists()  # refused before anything is tracked or written
    # one solution per code period at most: 4 ms on E1 (250 Hz), not C/A's 1 ms
    for signal, rate in (("galileo-e1b-boc11", "500"), ("gps-l1ca,galileo-e1b-boc11", "300")):
        assert main(["receive", str(path), "--signal", signal, "--rate", rate, "--out", str(out), "--quiet"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--rate: must be at most 250 Hz" in err[0] and "galileo-e1b-boc11" in err[0], err
        assert not out.exists()


def test_decoded_inav_records_write_a_galileo_navigation_file_georinex_reads(tmp_path):
    """A record of the test file (E09: both BGDs non-zero) sent as I/NAV pages, decoded, written
    as RINEX 3.04 and read back by georinex: every field the broadcast holds as the file has it."""
    nav = galileo_records()
    k = int(np.flatnonzero(nav.sv == "E09")[0])
    record = nav.subset(np.array([k]))
    symbols, _ = inav.inav_symbols(record, WN, 18019.0, 9 * inav.PAGE_SYMBOLS)
    decoded = inav.decode_inav(symbols).ephemeris
    assert decoded is not None
    ready_tow = 18035.0
    path = write_rinex_nav(
        tmp_path / "navigation.rnx", [NavRecord(9, decoded, GPS_WEEK, ready_tow)], signal=GALILEO_E1B_BOC11
    )
    back = _georinex(path).sel(sv="E09").isel(time=0)
    original = _georinex(NAV).sel(sv="E09")
    original = original.isel(time=int(np.flatnonzero(np.isfinite(original["IODnav"].values))[0]))
    assert back.time.values == original.time.values  # the Toc
    for name in (
        "SVclockBias",
        "SVclockDrift",
        "SVclockDriftRate",
        "IODnav",
        "Crs",
        "DeltaN",
        "M0",
        "Cuc",
        "Eccentricity",
        "Cus",
        "sqrtA",
        "Toe",
        "Cic",
        "Omega0",
        "Cis",
        "Io",
        "Crc",
        "omega",
        "OmegaDot",
        "IDOT",
        "GALWeek",
        "SISA",
        "health",
        "BGDe5b",
    ):
        # the file's values are broadcast ones (the ICD's quantisation): D19.12 keeps 13 digits
        assert float(back[name]) == pytest.approx(float(original[name]), rel=1e-11, abs=1e-20), name
    assert float(back["BGDe5b"]) != 0.0
    assert int(back["DataSrc"]) == 513  # bits 0 (I/NAV E1-B) and 9 (clock for E5b,E1)
    assert float(back["TransTime"]) == ready_tow
