"""GPS L1 C/A with BeiDou B1I in one fix, from one wide-band recording: each signal searched
and tracked at its own IF (`Recording.tuned`: the file's IF plus the carriers' difference),
each satellite's Doppler, clock and ionosphere its own signal's (`SignalSet.carrier_freq_hz_of`
read by `pvt.solve_position`), BDT's offset from GPS time a clock state.

The recording (`mixed_recordings.write_gps_bds_recording`): four GPS satellites of the
project's moved 2005 orbits sending L1 C/A with LNAV, four of the relabelled BeiDou records
(`inav_recordings.bds_records`) sending B1I with D1, seen from VILL, 17.6 MHz complex int8
around 1567.75 MHz. Truths: the station; each satellite's SV time at every dated row; the
generator's BDT, exactly GPS time - 14 s (so the estimated offset is the noise's alone); each
satellite's Doppler from the geometry."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import Ephemerides
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import signal_tracking_config, tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.multi_receive import KEY_STEP, SignalSet, receive_signals
from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav
from gnssframework.signal.beidou_b1i import BEIDOU_B1I
from gnssframework.signal.gps_l1ca import GPS_L1CA
from inav_recordings import bds_records
from inav_recordings import highest as highest_bds
from light_time import position_dop
from mixed_recordings import GPS_WEEK, STATION, highest, moved_gps_records, satellite_time, write_gps_bds_recording

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

#: An LNAV subframe starts at GPS 18036 s (0.67 s in), a D1 one at GPS 18038 s (BDT 18024 s).
TOW0 = 18_036.0 - 0.6
DURATION_S = 9.5
C = 299_792_458.0
BOTH = SignalSet((GPS_L1CA, BEIDOU_B1I))


@pytest.fixture(scope="module")
def wide(tmp_path_factory):
    gps, bds = highest(moved_gps_records(), TOW0, 4), highest_bds(bds_records(), TOW0, 4)
    path = tmp_path_factory.mktemp("gb") / "gps_bds.sigmf-data"
    write_gps_bds_recording(path, gps, bds, TOW0, DURATION_S, seed=5)
    result = receive_signals(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        [tracking_config(), signal_tracking_config(BEIDOU_B1I)],
        BOTH,
        rate_hz=5.0,
        rinex=Ephemerides.concatenate([moved_gps_records(), bds_records()]),
        reference_week=GPS_WEEK,
    )
    return path, gps, bds, result


def _truth_errors_m(obs, sats, key_offset):
    """Each dated transmit time of the satellites ``sats`` less their SV time (m)."""
    out = []
    for j, key in enumerate(obs.prn):
        name = f"{sats.sv[0][0]}{int(key) - key_offset:02d}"
        if not 0 <= int(key) - key_offset < KEY_STEP or name not in list(sats.sv):
            continue
        k = list(sats.sv).index(name)
        ok = np.isfinite(obs.transmit_s[:, j])
        truth = satellite_time(sats.subset(np.array([k])), TOW0 + obs.sample_time_s[ok])
        out.append((obs.transmit_s[ok, j] - truth) * C)
    return np.concatenate(out)


def test_each_signal_is_found_at_its_own_if_with_the_geometrys_doppler(wide):
    """B1I read at the file's IF (L1's, +7.67 MHz) less 14.322 MHz; every satellite found.
    A B1I Doppler within 25 Hz of the geometry's: the 1 ms search alone was off by up to
    320 Hz under NH20 (measured on this file), and `fft_search.overlay_doppler` refines it;
    an L1 C/A one within 150 Hz, the 1 ms fine search's (no overlay to refine with; its
    tracking loop pulls in from there)."""
    path, gps, bds, _ = wide
    rec = open_recording(path)
    acq = registry.create("acquisition", "pcps")
    for signal, sats, shift, within_hz in (
        (GPS_L1CA, gps, 0.0, 150.0),
        (BEIDOU_B1I, bds, BOTH.if_offset_hz(1), 25.0),
    ):
        tuned = rec.tuned(rec.info.if_hz + shift)
        prns = tuple(int(s[1:]) for s in sats.sv)
        found = {r.prn: r for r in acquire_recording(tuned, acq, prns, signal=signal) if r.detected}
        assert sorted(found) == sorted(prns)
        t0, t1 = satellite_time(sats, np.array(TOW0)), satellite_time(sats, np.array(TOW0 + 0.01))
        doppler = signal.carrier_freq_hz * ((t1 - t0) / 0.01 - 1.0)
        for k, prn in enumerate(prns):
            assert abs(found[prn].doppler_hz - doppler[k]) < within_hz, (signal.name, prn, found[prn].doppler_hz)
    assert BOTH.if_offset_hz(1) == pytest.approx(-14.322e6)


def test_gps_and_beidou_fixes_use_all_eight_satellites_with_bdts_offset_near_zero(wide):
    """Fixes of the eight satellites once both messages date their rows (BeiDou's alone
    before: D1's subframe came first); transmit times within 2 % of each signal's chip of the
    truth; the fixes within three PDOPs of the larger error; the BDT - GPST offset estimated
    within three of its own sigmas (PDOP-scaled) of 0, the generator's."""
    _, gps, bds, result = wide
    obs, table = result.observables, result.positions
    assert table is not None
    both = [k for k, u in enumerate(table.used_prns) if len(u) == 8]
    assert len(both) >= 5
    sigma = {}
    for sats, offset, signal in ((gps, 0, GPS_L1CA), (bds, KEY_STEP, BEIDOU_B1I)):
        err = _truth_errors_m(obs, sats, offset)
        sigma[signal.name] = float(np.sqrt(np.mean(err**2)))
        assert sigma[signal.name] < 0.02 * signal.chip_length_m, (signal.name, sigma[signal.name])
    all_sats = Ephemerides.concatenate([gps, bds])
    pdop = position_dop(all_sats, TOW0 + 8.0, STATION)
    worst = max(sigma.values())
    err = np.linalg.norm(table.ecef_m[both] - STATION, axis=1)
    assert np.sqrt(np.mean(err**2)) < 3 * pdop * worst, (err, pdop, sigma)
    offset_ns = np.asarray(table.columns["system_offset_ns"], float)[both]
    assert np.all(np.abs(offset_ns) < 3 * pdop * worst / C * 1e9), offset_ns
    # The station is still: each Doppler taken on its own wavelength. On L1's, B1I's range
    # rates (here up to 350 m/s) would be 0.9 % off: measured on this file, a mean velocity of
    # 6.1 m/s, the same at every epoch, against 0.13 m/s with each its own (the epochs' noise,
    # about 0.7 m/s each, averages down).
    vel = np.stack([np.asarray(table.columns[f"vel_{a}_mps"], float)[both] for a in "enu"], axis=1)
    assert np.linalg.norm(vel.mean(axis=0)) < 0.5, vel


def test_a_set_on_two_carriers_gives_each_satellite_its_own_and_refuses_one_wavelength():
    letters = np.array(["G", "C", "C", "G"])
    np.testing.assert_array_equal(BOTH.carrier_freq_hz_of(letters), [1575.42e6, 1561.098e6, 1561.098e6, 1575.42e6])
    with pytest.raises(ConfigError, match="different carriers"):
        _ = BOTH.wavelength_m
    with pytest.raises(ConfigError, match="no signal of system E"):
        BOTH.carrier_freq_hz_of(np.array(["E"]))


def test_the_command_positions_both_and_writes_each_systems_codes_and_records(wide, tmp_path):
    """What a user types, with a mixed navigation file of the records sent (written by the
    project's writer: GPS's and BDS's layouts): fixes of all eight satellites; the mixed
    observation file holds C1C for GPS and C2I for BeiDou (RINEX 3.04: B1I is band 2), each
    satellite only its own; the NMEA fixes come from the GN talker."""
    import warnings

    import georinex

    path, gps, bds, _ = wide
    navs = [NavRecord(int(str(sv)[1:]), gps.subset(np.array([k])), GPS_WEEK, 18_000.0) for k, sv in enumerate(gps.sv)]
    navs += [
        NavRecord(KEY_STEP + int(str(sv)[1:]), bds.subset(np.array([k])), GPS_WEEK, 18_000.0)
        for k, sv in enumerate(bds.sv)
    ]
    nav = write_rinex_nav(tmp_path / "gps_bds.rnx", navs, signal=BOTH)  # type: ignore[arg-type]
    out = tmp_path / "out"
    args = ["receive", str(path), "--signal", "gps-l1ca,beidou-b1i", "--ephemeris", str(nav), "--rate", "5"]
    assert main([*args, "--out", str(out), "--quiet"]) == 0
    rows = (out / "positions.csv").read_text().splitlines()
    header = rows[0].split(",")
    used = [r.split(",")[header.index("n_sats")] for r in rows[1:]]
    assert sum(u == "8" for u in used) >= 5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        obs = georinex.load(out / "observations.rnx")
    assert sorted(obs.sv.values) == sorted(list(gps.sv) + list(bds.sv))
    for sv in obs.sv.values:
        own, other = ("C1C", "C2I") if sv[0] == "G" else ("C2I", "C1C")
        assert np.isfinite(obs[own].sel(sv=sv).values).any() and np.all(np.isnan(obs[other].sel(sv=sv).values))
    nmea = (out / "nmea.txt").read_text().splitlines()
    assert any(line.startswith("$GNGGA") for line in nmea)
