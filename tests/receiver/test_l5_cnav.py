"""GPS CNAV on L5 I5 (`cnav_stream` with `gps-l5i`): 100 symbols/s, each ten 1 ms code
periods under the NH10 overlay, 6 s messages (IS-GPS-705 20.3.3).

Truth: the messages `cnav.cnav_symbols` encoded at L5's rate (their types and TOW counts),
the overlay the test puts on each 1 ms prompt, and the SV time it gives each row (the
first symbol starts at a known SV time; a row starts every millisecond after it)."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation import cnav
from gnssframework.receiver.channels import signal_tracking_config
from gnssframework.receiver.channels.signal_settings import coherent_periods
from gnssframework.receiver.navigation.overlay_symbols import overlay_symbols_of_run
from gnssframework.receiver.navigation.cnav_stream import (
    carries_cnav,
    channel_cnav,
    cnav_channel_timing,
    message_s,
)
from gnssframework.signal.galileo_e5a import GALILEO_E5AI
from gnssframework.signal.gps_l2c import GPS_L2C
from gnssframework.signal.gps_l5 import GPS_L5I, GPS_L5Q
from gnssframework.signal.gps_l5_codes import L5I_NEUMAN_HOFFMAN

PRN = 24
#: SV time (s of week) of the stream's start, 2.37 s into a 6 s message.
TOW0 = 345_602.37
#: Rows of the record dropped before its first (the overlay's chip 3 of a symbol).
SKIP_ROWS = 3


def _l5_prompts(seconds: float, amplitude: float, rng: np.random.Generator):
    """1 ms in-phase prompts of I5 (the Costas loop's sign, inverted here), from row
    ``SKIP_ROWS`` of the symbol in force at ``TOW0``, and the SV time of that row's start."""
    n_symbols = int(seconds / 0.01) + 2
    symbols, into = cnav.cnav_symbols(PRN, TOW0, n_symbols, message_s=cnav.L5_MESSAGE_S)
    chips = np.repeat(symbols.astype(float), 10) * np.tile(L5I_NEUMAN_HOFFMAN, n_symbols)
    prompts = -amplitude * chips + rng.standard_normal(chips.size)
    rows = int(seconds / 1e-3)
    return prompts[SKIP_ROWS : SKIP_ROWS + rows], TOW0 - into + SKIP_ROWS * 1e-3


def test_l5_i5_carries_cnav_and_its_pilot_and_e5a_do_not():
    assert carries_cnav(GPS_L5I) and carries_cnav(GPS_L2C)
    assert not carries_cnav(GPS_L5Q) and not carries_cnav(GALILEO_E5AI)
    assert message_s(GPS_L5I) == cnav.L5_MESSAGE_S == 6.0 and message_s(GPS_L2C) == cnav.MESSAGE_S


def test_the_overlay_is_found_and_ten_rows_make_a_symbol():
    """The run starts on the overlay's chip 3: the first whole symbol starts on row 7, and the
    symbols are the encoded ones (negated: the prompts are), each 10 times a row's."""
    rng = np.random.default_rng(3)
    prompts, _ = _l5_prompts(1.0, 5.0, rng)
    symbols, starts = overlay_symbols_of_run(prompts, np.zeros_like(prompts), GPS_L5I, PRN)
    sent, _ = cnav.cnav_symbols(PRN, TOW0, 200, message_s=cnav.L5_MESSAGE_S)
    assert starts[0] == 10 - SKIP_ROWS and np.all(np.diff(starts) == 10)
    np.testing.assert_array_equal(np.sign(symbols), -sent[1 : 1 + symbols.size])
    assert np.mean(np.abs(symbols)) == pytest.approx(50.0, rel=0.05)
    # Too short to synchronise (three overlay periods): no symbols.
    assert overlay_symbols_of_run(prompts[:29], np.zeros(29), GPS_L5I, PRN)[0].size == 0


def test_a_channels_l5_messages_are_decoded_and_every_row_dated(channel_record):
    """16 s of rows at about 41 dB-Hz (5 sigma a 1 ms prompt): every message that lies whole
    in the run is decoded with its CRC, dated by the row of its first symbol, and 6 s apart
    in TOW; every row after the first message's start is dated to its SV time within 1 ns
    (the code phase is 0: a row's start is its transmit time)."""
    rng = np.random.default_rng(8)
    prompts, t_sv_row0 = _l5_prompts(16.0, 5.0, rng)
    time_s = 0.5 + 1e-3 * np.arange(prompts.size)
    record = channel_record(PRN, time_s, prompts, np.ones(prompts.size, int))
    timing = channel_cnav(record, GPS_L5I)
    assert len(timing.messages) == 2 and all(m.crc_ok and m.inverted for m in timing.messages)
    tows = [m.tow_s for m in timing.messages]
    # Messages start on multiples of 6 s of SV time: the first after TOW0.
    first = np.ceil(TOW0 / 6.0) * 6.0
    assert tows == pytest.approx([first, first + 6.0])
    assert timing.time_s == pytest.approx(0.5 + (np.array(tows) - t_sv_row0))
    channel = cnav_channel_timing(record, GPS_L5I)
    assert channel is not None and channel.time_s.size == prompts.size
    sv_time = t_sv_row0 + (channel.time_s - 0.5)
    assert np.max(np.abs(channel.transmit_s - sv_time)) < 1e-9


def test_the_tracking_keeps_one_code_period_under_an_overlay():
    """The tracker does not wipe an overlay off: on L5 I5 (10 code periods a symbol) the
    coherent interval stays one period, and more is refused in one line."""
    assert coherent_periods(GPS_L5I, None) == 1 and signal_tracking_config(GPS_L5I).coherent_ms == 1
    with pytest.raises(ConfigError, match="tracking.coherent_ms: 10 code periods span gps-l5i's overlay"):
        coherent_periods(GPS_L5I, 10)
