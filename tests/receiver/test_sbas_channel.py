"""SBAS L1 messages from tracked ``sbas-l1`` channels (`sbas_stream`), and the ``track``
command's ``sbas.csv``.

Truth: the messages the generator sent (24 real MSAS messages of RTKLIB's GW-10 test log,
`tests/data/README.md`, encoded by `sbas_message.encode_messages`) and the time the
generator put each message's first symbol on the signal.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation import sbas_message as sm
from gnssframework.receiver.channels import ChannelRecord
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples, write_recording
from gnssframework.receiver.navigation.inav_stream import coherent_periods
from gnssframework.receiver.navigation.sbas_stream import SBAS_COLUMNS, carries_sbas, channel_sbas, sbas_rows
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.sbas_l1 import SBAS_L1

DATA = Path(__file__).parents[1] / "data" / "sbas_msas_gw10_20110121.txt"


def _messages(prn: int) -> np.ndarray:
    texts = [line.split()[2] for line in DATA.read_text().splitlines() if line and not line.startswith("#")]
    prns = [int(line.split()[1]) for line in DATA.read_text().splitlines() if line and not line.startswith("#")]
    return sm.messages_from_hex([t for t, p in zip(texts, prns) if p == prn])


def test_sbas_l1_is_recognised_and_tracked_a_symbol_a_row():
    assert carries_sbas(SBAS_L1)
    assert not carries_sbas(GPS_L1CA) and not carries_sbas(GALILEO_E1B_BOC11)
    assert coherent_periods(SBAS_L1, None) == 2  # one row one 2 ms symbol


def test_channel_sbas_reads_each_run_and_dates_each_message_by_its_first_row(channel_record):
    """Pull-in rows of one code period, then two runs of one-symbol rows with a gap: the
    whole messages of each run are read, inverted, each dated by the row of its first
    symbol; a corrupted one is reported, not counted good."""
    msgs = _messages(129)
    sym = -sm.encode_messages(msgs).astype(float)  # a Costas loop's 180 degrees
    rng = np.random.default_rng(3)
    prompt = 5.0 * sym + rng.standard_normal(sym.size)
    prompt[8 * 500 + 300 : 8 * 500 + 360] *= -1  # message 8 corrupted
    pull_in = 40  # 1 ms rows before the bit edge is known
    keep = np.r_[np.arange(250, 4 * 500 + 100), np.arange(5 * 500 + 10, sym.size)]  # a 0.82 s gap
    t0 = 0.7
    t = np.r_[np.arange(pull_in) * 0.001 + t0 - 0.04, t0 + keep * 0.002]
    p = np.r_[rng.standard_normal(pull_in), prompt[keep]]
    k = np.r_[np.ones(pull_in, int), np.full(keep.size, 2)]
    ch = channel_sbas(channel_record(129, t, p, k), SBAS_L1)
    assert ch.symbols == keep.size
    # run 1 holds messages 1-3 whole, run 2 messages 6-11
    starts = [1, 2, 3, 6, 7, 8, 9, 10, 11]
    assert [m.crc_ok for m in ch.messages] == [j != 8 for j in starts]
    assert len(ch.failures) == 1 and "PRN 129" in ch.failures[0] and "CRC-24Q" in ch.failures[0]
    for m, j in zip(ch.messages, starts):
        assert m.inverted
        if m.crc_ok:
            np.testing.assert_array_equal(m.bits, msgs[j])
    np.testing.assert_allclose(ch.times_s, t0 + 500 * 0.002 * np.array(starts), atol=1e-9)
    rows = sbas_rows(ch)
    assert rows[0]["preamble"] == "0x53" and rows[0]["message_type"] == 2 and rows[0]["inverted"] == 1
    assert rows[0]["message_hex"] == DATA.read_text().splitlines()[5 + 2].split()[2]


def test_too_few_symbols_are_refused_in_one_line_naming_the_prn(channel_record):
    t = np.arange(400) * 0.002
    with pytest.raises(ConfigError) as exc:
        channel_sbas(channel_record(137, t, np.ones(400), np.full(400, 2)), SBAS_L1)
    text = str(exc.value)
    assert "PRN 137" in text and "400" in text and "500" in text and len(text.splitlines()) == 1
    with pytest.raises(ConfigError, match="PRN 133.*0 "):  # 1 ms rows only: no symbol rows
        channel_sbas(channel_record(133, np.arange(900) * 0.001, np.ones(900), np.ones(900, int)), SBAS_L1)
    with pytest.raises(ConfigError, match="no SBAS"):
        channel_sbas(ChannelRecord(3), GPS_L1CA)


# --- the track command on a generated SBAS recording carrying real messages ----------

FS = 4e6
DURATION_S = 4.5
SKIP = 377  # the recording starts 377 symbols into the first message
SAT = SatelliteSignal(129, 45.0, -420.0, 811.7, 1.1, first_bit_code_period=0, signal=SBAS_L1)


@pytest.mark.slow
def test_track_sbas_l1_writes_the_messages_it_was_sent(tmp_path, capsys):
    msgs = _messages(129)
    symbols = sm.sbas_symbols(msgs, SKIP, int(DURATION_S * sm.SYMBOL_RATE_HZ) + 2)
    sat = SatelliteSignal(
        **{
            k: getattr(SAT, k)
            for k in ("prn", "cn0_dbhz", "doppler_hz", "code_phase_chips", "carrier_phase_rad", "signal")
        },
        first_bit_code_period=0,
        symbols=symbols,
    )
    x = synthesize_samples([sat], DURATION_S, FS, 0.0, np.random.default_rng(43))
    path = write_recording(tmp_path / "sbas.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0)
    out = tmp_path / "trk"
    args = ["track", str(path), "--signal", "sbas-l1", "--prns", "129", "--out", str(out), "--no-plots", "--quiet"]
    assert main(args) == 0
    text = capsys.readouterr().out
    with open(out / "sbas.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    # Messages 1-4 start 0.246, 1.246, 2.246, 3.246 s of symbols in: after the pull-in, the
    # whole ones up to 4.5 s are 1-3 (the 4th ends at 4.246 s of symbols; the tracker's
    # last rows may stop short of it, so it is not required).
    assert len(rows) >= 3 and all(r["crc_ok"] == "1" for r in rows)
    code_rate = SBAS_L1.code_freq_hz(SAT.doppler_hz) / SBAS_L1.chip_rate_hz
    tolerance_s = 1.0 / FS + 0.1 / SBAS_L1.chip_rate_hz
    for j, r in enumerate(rows, start=1):
        np.testing.assert_array_equal(sm.messages_from_hex([r["message_hex"]])[0], msgs[j])
        # the log starts on 0xC6: message j's preamble part is (2 + j) mod 3
        assert r["preamble"] == f"0x{sm.PREAMBLES[(2 + j) % 3]:02X}"
        assert int(r["message_type"]) == sm.parse_message(msgs[j])[1]
        truth_s = SAT.first_bit_edge_s() + (500 * j - SKIP) * 0.002 / code_rate
        assert abs(float(r["time_s"]) - truth_s) < tolerance_s
    # The contents column: PRN 129's messages 1-3 are fast corrections 2 and 3 (under the
    # log's mask, IODP 3) and a null message.
    assert [r["content"][:16] for r in rows[:3]] == ["fast corrections", "fast corrections", ""]
    assert rows[0]["content"].endswith("IODP 3: mask numbers 1-13") and rows[1]["content"].endswith("14-26")
    types = " ".join(r["message_type"] for r in rows)
    assert f"PRN 129: SBAS {len(rows)} messages (types {types}), 0 CRC failures" in text
    assert "sbas.csv" in text


@pytest.mark.slow
def test_track_on_a_recording_shorter_than_a_message_says_so_in_one_line(tmp_path, capsys):
    """0.8 s of SBAS (like the 0.5 s real recordings): tracked, an empty ``sbas.csv``, and
    one note naming the PRN and its symbols."""
    symbols = sm.sbas_symbols(_messages(129), 0, 402)
    sat = SatelliteSignal(129, 45.0, -420.0, 811.7, 1.1, first_bit_code_period=0, signal=SBAS_L1, symbols=symbols)
    x = synthesize_samples([sat], 0.8, FS, 0.0, np.random.default_rng(44))
    path = write_recording(tmp_path / "short.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0)
    out = tmp_path / "trk"
    args = ["track", str(path), "--signal", "sbas-l1", "--prns", "129", "--out", str(out), "--no-plots", "--quiet"]
    assert main(args) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if line.startswith("note: SBAS PRN 129")]
    assert len(notes) == 1 and "a message needs 500" in notes[0]
    assert (out / "sbas.csv").read_text().splitlines() == [",".join(SBAS_COLUMNS)]
