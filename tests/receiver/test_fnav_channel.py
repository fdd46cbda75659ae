"""Galileo F/NAV from a tracked E5a-I channel (`inav_stream.channel_inav` with
`galileo-e5ai`): 50 symbols/s, each twenty 1 ms code periods under CS20_1, 10 s pages.

Truth: the pages `fnav.fnav_symbols` encoded from a real broadcast F/NAV record (the VILL
file's), the overlay the test puts on each 1 ms prompt, and the GST it gives each row (the
first symbol starts at a known GST; a row starts every millisecond after it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation import fnav
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state, single_frequency_clock_s
from gnssframework.receiver.navigation.decoded import navigation_message, require_positioning
from gnssframework.receiver.navigation.inav_stream import carries_fnav, carries_inav, channel_inav, inav_channel_timing
from gnssframework.signal.galileo_e5a import GALILEO_E5AI, GALILEO_E5AQ
from gnssframework.signal.galileo_e5a_codes import E5AI_SECONDARY_CS20
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l5 import GPS_L5I

DATA = Path(__file__).parents[1] / "data"
GST0 = 345_603.21  # GST (s of week) of the stream's start
SKIP_ROWS = 7  # rows dropped before the record's first: it starts on CS20_1's chip 7


def _record():
    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="E")
    k = int(np.flatnonzero(nav.elements["FNAV"] == 1.0)[0])
    return nav.subset(np.array([k]))


def _e5a_prompts(rec, seconds: float, amplitude: float, rng: np.random.Generator):
    n_symbols = int(seconds / 0.02) + 2
    symbols, into = fnav.fnav_symbols(rec, 982, GST0, n_symbols)
    chips = np.repeat(symbols.astype(float), 20) * np.tile(E5AI_SECONDARY_CS20, n_symbols)
    prompts = amplitude * chips + rng.standard_normal(chips.size)
    rows = int(seconds / 1e-3)
    return prompts[SKIP_ROWS : SKIP_ROWS + rows], GST0 - into + SKIP_ROWS * 1e-3


def test_e5a_i_carries_fnav_and_the_receiver_positions_from_it():
    assert carries_fnav(GALILEO_E5AI) and not carries_inav(GALILEO_E5AI)
    assert not carries_fnav(GALILEO_E5AQ) and not carries_fnav(GPS_L5I)
    assert navigation_message(GALILEO_E5AI).name == "F/NAV"
    require_positioning(GALILEO_E5AI)  # no refusal
    with pytest.raises(ConfigError, match="galileo-e5aq: the receive command positions from"):
        require_positioning(GALILEO_E5AQ)


def test_a_channels_pages_are_decoded_and_every_row_dated(channel_record):
    """48 s of 1 ms rows at about 41 dB-Hz: the four pages that lie whole in the run pass their
    CRC and give the record (clock for E1,E5a); every row is dated to its GST within 1 ns."""
    rec = _record()
    rng = np.random.default_rng(2)
    prompts, t_row0 = _e5a_prompts(rec, 48.0, 5.0, rng)
    time_s = 1.0 + 1e-3 * np.arange(prompts.size)
    record = channel_record(11, time_s, prompts, np.ones(prompts.size, int))
    timing = channel_inav(record, GALILEO_E5AI)
    pages = [p for m in timing.messages for p in m.pages]
    assert [p.page_type for p in pages] == [2, 3, 4, 1] and timing.failures == []  # from GST 345610 s
    assert timing.ephemeris is not None and timing.ephemeris.elements["FNAV"][0] == 1.0
    for name in ("M0", "sqrtA", "SVclockBias", "TGD"):
        assert timing.ephemeris.elements[name][0] == pytest.approx(rec.elements[name][0], rel=1e-8, abs=1e-12)
    channel = inav_channel_timing(record, GALILEO_E5AI)
    assert channel is not None and channel.time_s.size == prompts.size
    assert np.max(np.abs(channel.transmit_s - (t_row0 + channel.time_s - 1.0))) < 1e-9
    assert channel.message.week_bits == 12 and channel.message.week == (982 + 1024) % 4096


def test_an_e5a_user_takes_the_fnav_clock_and_no_inav_one():
    """OS SIS ICD 5.1.5: the E5a single-frequency user's clock is the E1,E5a clock less
    (f_E1/f_E5a)^2 BGD(E1,E5a); an I/NAV record (clock for E1,E5b) gives no E5a clock (NaN),
    while an E1 user takes either record's own."""
    rec = _record()
    t = np.array([float(rec.elements["Toe"][0]) + 60.0])
    s = satellite_state(rec, t)
    gamma = (1575.42 / 1176.45) ** 2
    e5a = single_frequency_clock_s(rec, s, GALILEO_E5AI.carrier_freq_hz)
    assert e5a[0] == pytest.approx(s.clock_s[0] - gamma * rec.elements["TGD"][0], abs=1e-18)
    inav_rec = type(rec)(rec.sv, rec.toc_s, {**rec.elements, "FNAV": np.array([0.0])}, rec.health, rec.iode)
    assert np.isnan(single_frequency_clock_s(inav_rec, s, GALILEO_E5AI.carrier_freq_hz)[0])
    assert single_frequency_clock_s(inav_rec, s, GPS_L1CA.carrier_freq_hz)[0] == s.clock_l1_s[0]


def test_records_without_an_e5a_clock_are_left_out_and_a_set_of_none_refused(tmp_path):
    """`records_with_clock` keeps, on E5a, the Galileo records whose clock is for E1,E5a and
    every other system's; `receive` given none of them is refused in one line before any
    work (it ran into the solver's least squares with NaN clocks, deep in a traceback)."""
    from gnssframework import registry
    from gnssframework.navigation.ephemeris import Ephemerides, records_with_clock
    from gnssframework.receiver.frontend import open_recording
    from gnssframework.receiver.navigation.receive import receive
    from noisy_recording import write_noisy_recording

    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="E")
    kept = records_with_clock(nav, GALILEO_E5AI.carrier_freq_hz)
    assert kept is not None and kept.sv.size == int(np.sum(nav.elements["FNAV"] == 1.0)) < nav.sv.size
    assert records_with_clock(nav, GPS_L1CA.carrier_freq_hz).sv.size == nav.sv.size  # E1: both serve
    inav = nav.subset(np.flatnonzero(nav.elements["FNAV"] == 0.0))
    assert records_with_clock(inav, GALILEO_E5AI.carrier_freq_hz) is None
    assert isinstance(inav, Ephemerides)
    path = write_noisy_recording(tmp_path / "x.sigmf-data", [np.zeros(1000, complex)], 10.5e6, np.random.default_rng(0))
    with pytest.raises(ConfigError, match=r"^rinex: no record gives a galileo-e5ai user a clock") as err:
        receive(open_recording(path), registry.create("acquisition", "pcps"), None, rinex=inav, signal=GALILEO_E5AI)
    assert "\n" not in str(err.value)
