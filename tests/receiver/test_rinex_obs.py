"""The RINEX 3.04 observation file of a receiver's observables reads back through georinex
(an independent reader) with the same values, epochs and satellites."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.receiver.navigation.observables import Observables
from gnssframework.receiver.navigation.rinex_obs import write_rinex_obs


def _observables():
    rng = np.random.default_rng(7)
    epochs = 518_400.0 + np.arange(4.0)
    prn = np.array([5, 13, 24])
    pr = 2.2e7 + rng.uniform(0, 3e6, (4, 3))
    pr[1, 2] = np.nan  # PRN 24 missing at the second epoch
    cyc = rng.uniform(-1e6, 1e6, (4, 3))
    dop = rng.uniform(-4000, 4000, (4, 3))
    cn0 = rng.uniform(30, 50, (4, 3))
    return Observables(epochs, epochs - epochs[0], prn, epochs[:, None] - pr / 3e8, pr, dop, cyc, cn0, {}, None, 142)


def test_georinex_reads_back_the_values(tmp_path):
    import georinex

    obs = _observables()
    path = write_rinex_obs(tmp_path / "observations.rnx", obs, 2190, np.array([-3959617.5, 3350136.6, 3699531.5]))
    with warnings.catch_warnings():  # georinex's xarray concat warns of a future default
        warnings.simplefilter("ignore", FutureWarning)
        data = georinex.load(path)
    assert list(data.sv.values) == ["G05", "G13", "G24"]
    times = (data.time.values - np.datetime64("1980-01-06")) / np.timedelta64(1, "s") - 2190 * 604800
    assert np.allclose(times, obs.rx_time_s)
    for name, values in (
        ("C1C", obs.pseudorange_m),
        ("L1C", obs.carrier_cycles),
        ("D1C", obs.doppler_hz),
        ("S1C", obs.cn0_dbhz),
    ):
        got = data[name].values
        values = np.where(np.isnan(obs.pseudorange_m), np.nan, values)  # a satellite without a range is not written
        assert np.array_equal(np.isnan(got), np.isnan(values))
        assert np.nanmax(np.abs(got - values)) <= 0.0005 + 1e-9
    assert np.allclose(data.position, [-3959617.5, 3350136.6, 3699531.5])


def test_the_same_observables_give_the_same_bytes_and_bad_input_is_refused(tmp_path):
    obs = _observables()
    a = write_rinex_obs(tmp_path / "a.rnx", obs, 2190).read_bytes()
    assert a == write_rinex_obs(tmp_path / "b.rnx", obs, 2190).read_bytes()
    with pytest.raises(ConfigError, match="week"):
        write_rinex_obs(tmp_path / "c.rnx", obs, -1)
    empty = Observables(
        obs.rx_time_s,
        obs.sample_time_s,
        obs.prn,
        obs.transmit_s,
        np.full((4, 3), np.nan),
        obs.doppler_hz,
        obs.carrier_cycles,
        obs.cn0_dbhz,
        {},
        None,
        None,
    )
    with pytest.raises(ConfigError, match="no epoch holds a pseudorange"):
        write_rinex_obs(tmp_path / "d.rnx", empty, 2190)


def test_nmea_sentences_read_back_through_the_projects_reader(tmp_path):
    from gnssframework.io.nmea import read_nmea
    from gnssframework.receiver.navigation.fixes import PositionTable
    from gnssframework.receiver.navigation.nmea_out import nmea_sentences, write_nmea

    n = 3
    cols = {
        "gps_week": np.full(n, 2190),
        "tow_s": 518_418.0 + np.arange(n),  # 18 leap seconds: 00:00:00 UTC on
        "lat_deg": np.array([35.681298, -33.8688197, 35.9999999999]),
        "lon_deg": np.array([139.766247, 151.2092955, -0.5]),
        "height_m": np.array([10.0, 58.25, -20.5]),
        "vel_e_mps": np.array([1.0, 0.0, np.nan]),
        "vel_n_mps": np.array([1.0, -2.0, np.nan]),
        "vel_u_mps": np.zeros(n),
        "clock_bias_m": np.zeros(n),
        "n_sats": np.array([10, 7, 4]),
        "hdop": np.array([0.81, 1.5, 3.0]),
        "vdop": np.ones(n),
    }
    table = PositionTable(cols, np.zeros((n, 3)), np.arange(n, dtype=float), [(1,)] * n, np.zeros(n, int))
    path = write_nmea(tmp_path / "nmea.txt", table, leap_seconds=18)
    fixes = read_nmea(path, max_speed_mps=1e8)  # the fixes jump across the globe on purpose
    assert not fixes.skipped and len(fixes.time_s) == n
    assert np.allclose(fixes.lat_deg, cols["lat_deg"], atol=1e-5 / 60 / 2)  # half the last digit of ddmm.mmmmm
    assert np.allclose(fixes.lon_deg, cols["lon_deg"], atol=1e-5 / 60 / 2)
    assert np.allclose(fixes.height_m, cols["height_m"], atol=5e-4)
    gga, rmc = nmea_sentences(table)[:2]
    assert gga.startswith("$GPGGA,000000.00,") and ",1,10,0.81," in gga
    assert rmc.split(",")[7:10] == [f"{np.hypot(1, 1) / (1852 / 3600):.3f}", "45.00", "010122"]


def test_loss_of_lock_and_strength_indicators_read_back_through_georinex(tmp_path):
    """RINEX 3.04 5.3 and 5.7: the LLI digit after the phase (bit 0 lost lock, bit 1 half
    cycle), the strength digit 1-9 (C/N0 / 6 dB-Hz) after the range, phase and Doppler."""
    import georinex

    obs = _observables()
    lli = np.zeros((4, 3), dtype=int)
    lli[2, 0], lli[3, 1], lli[1, 1] = 1, 2, 3
    obs = Observables(
        *(
            getattr(obs, f)
            for f in (
                "rx_time_s",
                "sample_time_s",
                "prn",
                "transmit_s",
                "pseudorange_m",
                "doppler_hz",
                "carrier_cycles",
                "cn0_dbhz",
                "ephemeris",
                "iono_utc",
                "week",
            )
        ),
        lli,
    )
    path = write_rinex_obs(tmp_path / "observations.rnx", obs, 2190)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        data = georinex.load(path, useindicators=True)
    got_lli = np.nan_to_num(data["L1Clli"].values, nan=0.0)
    want = np.where(np.isnan(obs.pseudorange_m), 0, lli)
    assert np.array_equal(got_lli, want)
    written = ~np.isnan(obs.pseudorange_m)
    # RINEX 3.04 5.7's table: 1 below 12 dB-Hz, 2 for 12-17, ..., 8 for 48-53, 9 from 54 on.
    strength = np.digitize(obs.cn0_dbhz, [12, 18, 24, 30, 36, 42, 48, 54]) + 1
    for name in ("C1Cssi", "L1Cssi", "D1Cssi"):
        assert np.array_equal(data[name].values[written], strength[written])
    assert "C1Clli" not in data or np.all(np.nan_to_num(data["C1Clli"].values) == 0)  # LLI on the phase only


def test_a_qzss_file_names_its_system_and_satellites_as_rinex_does(tmp_path):
    """QZSS L1 C/A observables: system J, PRN 193 -> J01 (RINEX 3.04 sec. 3.5), read back by georinex."""
    import georinex

    from gnssframework.signal.qzss_l1ca import QZSS_L1CA

    obs = _observables()
    obs = Observables(
        obs.rx_time_s,
        obs.sample_time_s,
        np.array([193, 195, 199]),
        obs.transmit_s,
        obs.pseudorange_m,
        obs.doppler_hz,
        obs.carrier_cycles,
        obs.cn0_dbhz,
        {},
        None,
        142,
    )
    path = write_rinex_obs(tmp_path / "qzss.rnx", obs, 2190, signal=QZSS_L1CA)
    assert "J    4 C1C L1C D1C S1C" in path.read_text()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        data = georinex.load(path)
    assert list(data.sv.values) == ["J01", "J03", "J07"]
    got = data["C1C"].values
    assert np.nanmax(np.abs(got - obs.pseudorange_m)) <= 0.0005 + 1e-9


def test_the_nmea_talker_follows_the_signals_systems(tmp_path):
    """NMEA 0183 4.11 talkers: GP alone for GPS, GQ for QZSS, GN for a fix from both; a GN file
    reads back through the project's reader (any talker)."""
    from gnssframework.io.nmea import read_nmea
    from gnssframework.receiver.navigation.fixes import PositionTable
    from gnssframework.receiver.navigation.nmea_out import nmea_talker, write_nmea
    from gnssframework.signal.gps_l1ca import GPS_L1CA
    from gnssframework.signal.qzss_l1ca import QZSS_L1CA

    assert nmea_talker() == nmea_talker(GPS_L1CA) == "GP"
    assert nmea_talker(QZSS_L1CA) == "GQ" and nmea_talker(GPS_L1CA, QZSS_L1CA) == "GN"
    cols = {
        "gps_week": np.full(1, 2190),
        "tow_s": np.array([518_418.0]),
        "lat_deg": np.array([35.681298]),
        "lon_deg": np.array([139.766247]),
        "height_m": np.array([10.0]),
        "vel_e_mps": np.zeros(1),
        "vel_n_mps": np.zeros(1),
        "vel_u_mps": np.zeros(1),
        "clock_bias_m": np.zeros(1),
        "n_sats": np.array([9]),
        "hdop": np.array([0.9]),
        "vdop": np.ones(1),
    }
    table = PositionTable(cols, np.zeros((1, 3)), np.zeros(1), [(1,)], np.zeros(1, int))
    path = write_nmea(tmp_path / "nmea.txt", table, talker=nmea_talker(GPS_L1CA, QZSS_L1CA))
    assert path.read_text().startswith("$GNGGA,000000.00,")
    fixes = read_nmea(path)
    assert len(fixes.time_s) == 1 and np.allclose(fixes.lat_deg, cols["lat_deg"], atol=1e-5 / 60 / 2)
