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
