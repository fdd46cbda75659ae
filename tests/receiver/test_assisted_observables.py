"""Observables and RINEX of an assisted vector start (no LNAV decoded): each vector channel's
rows dated from its resolved transmit time (`observables.assisted_timing`), the receiver
clock at the assistance's start time.

On the project's own generator (`lnav_recordings`: real broadcast orbits seen from a known
station, light time and Earth rotation, the receiver clock exact) the pseudoranges must be
the generator's geometry within the navigation filter's own uncertainty once the hand-over's
transient has passed: the replica a vector channel runs is then the filter's prediction,
so its error is the state's, projected on the line of sight. (The channels go over from
pull-in a quarter chip, tens of metres, off; the loop steers that out within about 1.5 s.)"""

from __future__ import annotations

import warnings

import numpy as np
import pymap3d
import pytest

from gnssframework import registry
from gnssframework.navigation import lnav
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.receiver.channels import STAGES, ChannelRecord, TrackingResult, tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.observables import LLI_HALF_CYCLE, assisted_timing
from gnssframework.receiver.navigation.receive import assisted_observables, receive
from gnssframework.receiver.navigation.rinex_obs import write_rinex_obs
from gnssframework.receiver.navigation.vector_tracking import VectorSolution, assistance, vector_config
from gnssframework.signal.constants import CA_CHIP_RATE_HZ, L1_FREQ_HZ
from lnav_recordings import C, NAV, STATION, TOW0, WEEK, _satellite_time, _strongest, write_lnav_recording

CN0_DBHZ = 35.0
#: Not the generator's 2.046 MHz: at two samples a chip the code discriminator has a dead band
#: of a quarter chip (`receiver.channels.sampling`), its errors are not the white noise the
#: filter's covariance assumes, and they reached 5 of its sigmas (one satellite, 10 m, for
#: seconds); at 2.2 MHz (2200/1023 samples a chip) they stay under 2.
SAMPLE_RATE_HZ = 2.2e6
DURATION_S = 5.0
#: Recording time (s) after the hand-over from which the channels follow the filter's prediction.
SETTLED_S = 2.0
RATE_HZ = 5.0
#: The approximate position: the station moved 30 km east and 20 km north, 500 m up.
OFFSET_ENU_M = (30e3, 20e3, 500.0)


def _record(
    prn: int, tx_s: np.ndarray, time_s: np.ndarray, prompt_i: np.ndarray, doppler_hz: float, coherent_ms: int = 20
) -> ChannelRecord:
    """A record of vector rows: a replica at transmit time ``tx_s`` at each row's start."""
    chips = (tx_s * 1e3 % 1.0) * 1023.0
    vector = STAGES.index("vector")
    rows = [
        (t, 40.0, 1.0, doppler_hz, p, 0.0, 1, vector, i, 0.0, coherent_ms) for t, p, i in zip(time_s, chips, prompt_i)
    ]
    return ChannelRecord(prn, rows)


@pytest.fixture(scope="module")
def lnav_rows():
    """14 s of 20 ms rows of one satellite's LNAV from a whole 20 ms of satellite time on,
    at a Doppler of 2 kHz (satellite time runs at 1 + D / f_L1 of the rows' time)."""
    nav = read_rinex_nav(NAV)
    record = nav.select(["G20"], TOW0)
    first_tx = np.ceil(TOW0 / 0.02) * 0.02 + 0.3 / CA_CHIP_RATE_HZ  # 0.3 chip past a bit edge
    symbols, into = lnav.lnav_symbols(record, WEEK, first_tx, 700)
    assert into == pytest.approx(0.3 / CA_CHIP_RATE_HZ, abs=1e-9)  # (seconds of week in doubles: 1e-10 s)
    doppler = 2000.0
    k = np.arange(700)
    time_s = 0.5 + k * 0.02 / (1 + doppler / L1_FREQ_HZ)  # receive times of the bit edges
    tx = first_tx + k * 0.02
    end_s = time_s[-1] + 0.02 / (1 + doppler / L1_FREQ_HZ)
    return _record(20, tx, time_s, 1000.0 * symbols, doppler), tx, end_s, tx[-1] + 0.02


def test_rows_are_dated_to_the_replica_transmit_time(lnav_rows):
    rec, tx, end_s, end_tx = lnav_rows
    tm = assisted_timing(rec, end_s, end_tx)
    # Carried back 14 s at the row's Doppler and rounded to the millisecond: exact.
    np.testing.assert_allclose(tm.transmit_s, tx, rtol=0, atol=1e-9)
    assert tm.arc_start[0] and not tm.arc_start[1:].any() and not tm.polarity_known.any()


def test_a_decoded_tow_checks_the_assisted_time(lnav_rows):
    rec, _, end_s, end_tx = lnav_rows
    assert assisted_timing(rec, end_s, end_tx).tow_offset_s == pytest.approx(0.0, abs=1e-9)
    # A start time one second late dates every row a second late: the TOW says so.
    assert assisted_timing(rec, end_s, end_tx + 1.0).tow_offset_s == pytest.approx(-1.0, abs=1e-9)


def test_a_channel_whose_tow_disagrees_is_left_out(lnav_rows):
    rec, tx, end_s, end_tx = lnav_rows
    tracking = TrackingResult({20: rec}, [], float(end_s), "scalar")
    good = VectorSolution(prns=(20,), rx_offset_s=TOW0, replica_tx={20: (end_s, end_tx)})
    obs = assisted_observables(tracking, good, 1.0)
    assert list(obs.prn) == [20] and not good.events
    # Pseudoranges of a receiver clock at TOW0 + recording time: c (t_rx - t_SV) at the rows.
    k = np.searchsorted(rec.column("time_s"), obs.sample_time_s[3])
    t0, t1 = rec.column("time_s")[k - 1 : k + 1]
    t_sv = np.interp(obs.sample_time_s[3], [t0, t1], tx[k - 1 : k + 1])
    assert obs.pseudorange_m[3, 0] == pytest.approx(C * (TOW0 + obs.sample_time_s[3] - t_sv), abs=1e-3)
    late = VectorSolution(prns=(20,), rx_offset_s=TOW0, replica_tx={20: (end_s, end_tx + 1.0)})
    assert assisted_observables(tracking, late, 1.0) is None
    assert "decoded TOW is -1.000 s" in late.events[-1][1]


def test_scalar_rows_are_not_dated(lnav_rows):
    rec, _, end_s, end_tx = lnav_rows
    rec.rows[-1] = rec.rows[-1][:7] + (STAGES.index("extended"),) + rec.rows[-1][8:]
    assert assisted_timing(rec, end_s, end_tx) is None  # the channel left the vector loop


@pytest.fixture(scope="module")
def assisted(tmp_path_factory):
    nav = read_rinex_nav(NAV)
    sats = _strongest(nav, TOW0, 5)
    path = write_lnav_recording(
        tmp_path_factory.mktemp("assisted_rinex") / "weak.sigmf-data",
        sats,
        TOW0,
        DURATION_S,
        seed=11,
        cn0_dbhz=CN0_DBHZ,
        sample_rate_hz=SAMPLE_RATE_HZ,
    )
    lat, lon, h = pymap3d.ecef2geodetic(*STATION)
    approx = pymap3d.enu2geodetic(*OFFSET_ENU_M, lat, lon, h)
    acq = registry.create("acquisition", "pcps", coherent_ms=10, noncoherent=8, alternate_blocks=True)
    result = receive(
        open_recording(path),
        acq,
        tracking_config(),
        rate_hz=RATE_HZ,
        rinex=nav,
        vector=vector_config(solution_rate_hz=RATE_HZ),
        assist=assistance(approx, WEEK, TOW0),
    )
    return result, sats


@pytest.mark.slow
def test_assisted_pseudoranges_are_the_generator_geometry(assisted):
    result, sats = assisted
    obs, solution = result.observables, result.vector
    assert set(obs.prn) == set(solution.prns) == {int(s[1:]) for s in sats.sv}
    # The receiver clock is the start time: the generator's clock, exactly.
    np.testing.assert_allclose(obs.rx_time_s - obs.sample_time_s, TOW0, rtol=0, atol=1e-6)
    order = [list(sats.sv).index(f"G{p:02d}") for p in obs.prn]
    nav_t = np.asarray(solution.sample_time_s)
    checked = 0
    for e in np.flatnonzero(obs.sample_time_s > solution.handover_s + SETTLED_S):
        t_rx = TOW0 + obs.sample_time_s[e]
        t_sv = _satellite_time(sats, t_rx)[order]
        err = obs.pseudorange_m[e] - C * (t_rx - t_sv)
        # The filter's 1-sigma range error at the nearest nav epoch: h = [-e_los, 1] on (r, b).
        cov = solution.cov[int(np.clip(np.searchsorted(nav_t, obs.sample_time_s[e]), 0, nav_t.size - 1))]
        los = satellite_state(sats, t_sv).position_m[order] - STATION
        h = np.c_[-los / np.linalg.norm(los, axis=1, keepdims=True), np.ones(len(order))]
        pc = np.r_[0:3, 6]
        sigma = np.sqrt(np.einsum("si,ij,sj->s", h, cov[np.ix_(pc, pc)], h))
        assert np.all(np.abs(err) < 4 * sigma), (obs.sample_time_s[e], err, sigma)
        checked += 1
    assert checked >= (DURATION_S - SETTLED_S - 0.5) * RATE_HZ


@pytest.mark.slow
def test_assisted_rinex_reads_back_with_the_half_cycle_flag(assisted, tmp_path):
    import georinex

    result, _ = assisted
    obs = result.observables
    path = write_rinex_obs(tmp_path / "observations.rnx", obs, WEEK)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        data = georinex.load(path, useindicators=True)
    rows = np.flatnonzero(np.isfinite(obs.pseudorange_m).any(axis=1))
    assert data.time.size == rows.size
    for j, prn in enumerate(obs.prn):
        sv = f"G{int(prn):02d}"
        np.testing.assert_allclose(data["C1C"].sel(sv=sv).values, obs.pseudorange_m[rows, j], atol=5e-4 + 1e-9)
        np.testing.assert_allclose(data["D1C"].sel(sv=sv).values, obs.doppler_hz[rows, j], atol=5e-4 + 1e-9)
        lli = np.nan_to_num(data["L1Clli"].sel(sv=sv).values, nan=0.0)
        valid = np.isfinite(obs.pseudorange_m[rows, j])
        assert np.all(lli[valid].astype(int) & LLI_HALF_CYCLE)  # no preamble has fixed the polarity
