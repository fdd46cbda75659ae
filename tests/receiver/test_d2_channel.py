"""BeiDou D2 from a tracked GEO B1I channel (`inav_stream.channel_inav` with
`beidou-b1i-geo`): 500 bit/s, each bit a row of two 1 ms code periods after bit
synchronisation (as SBAS L1's symbols), subframe 1's ten pages to a record.

Truth: the frames `d2nav.encode_d2` makes of the real GEO record C05 (the VILL file), and
the BDT the test gives each row (the first whole bit starts at a known BDT; a row starts
every 2 ms after it), taken to GPS time (+14 s) as the receiver dates rows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.navigation import d2nav
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.navigation.decoded import navigation_message, require_positioning
from gnssframework.receiver.navigation.inav_stream import carries_d1, carries_d2, channel_inav, inav_channel_timing
from gnssframework.signal.beidou_b1i import BEIDOU_B1I, BEIDOU_B1I_GEO
from gnssframework.signal.sbas_l1 import SBAS_L1

DATA = Path(__file__).parents[1] / "data"
BDT_WEEK = 650  # 2018-06-19
SKIP_BITS = 113  # bits dropped before the record's first: it starts mid-subframe


def _geo():
    nav = read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", systems="C")
    return nav.subset(np.flatnonzero(nav.sv == "C05")[:1])


def test_geo_b1i_carries_d2_and_the_receiver_positions_from_it():
    assert carries_d2(BEIDOU_B1I_GEO) and not carries_d1(BEIDOU_B1I_GEO)
    assert not carries_d2(BEIDOU_B1I) and not carries_d2(SBAS_L1)  # 2 ms symbols too, system S
    assert navigation_message(BEIDOU_B1I_GEO).name == "D2"
    require_positioning(BEIDOU_B1I_GEO)  # no refusal


def test_a_channels_pages_are_decoded_and_every_row_dated(channel_record):
    """36 s of 2 ms rows at a bit SNR of 8 dB, from 113 bits into a frame: every whole
    subframe kept (inverted: the Costas loop 180 degrees off), the ten pages' record equal to
    the one sent within half an LSB, and every row dated to its GPS time within 1 ns; the
    channel's week is GPS's (BDT + 1356), of 13 bits."""
    rec = _geo()
    sow0 = int(rec.toc_s[0]) - 3  # page 10 of the previous cycle, then a whole cycle
    bits = d2nav.encode_d2(rec, BDT_WEEK, sow0, 13).astype(float)[SKIP_BITS:]
    rng = np.random.default_rng(4)
    prompts = -(3.5 * bits + rng.standard_normal(bits.size))
    time_s = 2.0 + 2e-3 * np.arange(bits.size)
    record = channel_record(5, time_s, prompts, np.full(bits.size, 2, int))
    timing = channel_inav(record, BEIDOU_B1I_GEO)
    subframes = [s for m in timing.messages for s in m.pages]
    assert len(subframes) == 13 * 5 - 1 and timing.failures == []
    assert all(s.inverted for s in subframes)
    eph = timing.ephemeris
    assert eph is not None and eph.sv.tolist() == ["C05"]
    for name, lsb in (("sqrtA", 2.0**-19), ("Eccentricity", 2.0**-33), ("SVclockBias", 2.0**-33), ("TGD", 1e-10)):
        assert abs(eph.elements[name][0] - rec.elements[name][0]) <= 0.5001 * lsb, name
    channel = inav_channel_timing(record, BEIDOU_B1I_GEO)
    assert channel is not None and channel.time_s.size == bits.size
    t_row0 = sow0 + SKIP_BITS * 2e-3 + 14.0  # GPS time of the first row's start
    code_s = record.column("code_phase_chips")[0] / BEIDOU_B1I_GEO.chip_rate_hz
    assert np.max(np.abs(channel.transmit_s - (t_row0 + channel.time_s - 2.0 + code_s))) < 1e-9
    assert channel.message.week_bits == 13 and channel.message.week == BDT_WEEK + 1356


def test_rows_not_a_whole_bit_are_not_read(channel_record):
    """The pull-in's one-period rows (before bit synchronisation) carry half a bit: a channel
    of such rows alone decodes nothing and dates nothing."""
    rec = _geo()
    bits = d2nav.encode_d2(rec, BDT_WEEK, int(rec.toc_s[0]), 2).astype(float)
    halves = np.repeat(bits, 2)
    record = channel_record(5, 2.0 + 1e-3 * np.arange(halves.size), 3.0 * halves, np.ones(halves.size, int))
    timing = channel_inav(record, BEIDOU_B1I_GEO)
    assert timing.messages == [] and timing.rows.size == 0 and timing.gst is None
    assert inav_channel_timing(record, BEIDOU_B1I_GEO) is None


@pytest.mark.slow
def test_the_track_command_reads_a_generated_geo_satellites_d2(tmp_path):
    """What a user types, on 4 s of generated B1I from the GEO record C05 seen from VILL
    (4.2 MHz complex int8, 45 dB-Hz, D2 from `d2nav.encode_d2`): the channel synchronises to
    the 2 ms bits and ``d2.csv`` holds the subframes it read whole, consecutive IDs, the last
    one's start in GPS time (its frame's SOW + 0.6 s a subframe + 14 s), to the millisecond
    in the file's column."""
    import csv

    from gnssframework.cli import main
    from inav_recordings import B1I_FS, satellite_time
    from noisy_recording import signal_chunks, write_noisy_recording

    rec = _geo()
    tow0 = float(rec.toc_s[0]) + 14.0 + 0.35  # GPS time: the C05 record's toc (BDT) and 0.35 s
    t_sv0 = satellite_time(rec, np.array(tow0))
    first_sow = int(np.floor((float(t_sv0[0]) - 14.0 - 0.1) / 3.0)) * 3
    bits = d2nav.encode_d2(rec, BDT_WEEK, first_sow, 3).astype(float)
    streams = [(bits, first_sow + 14.0)]
    rng = np.random.default_rng(21)
    chunks = signal_chunks(rec, tow0, 4.0, BEIDOU_B1I_GEO, B1I_FS, satellite_time, streams, 45.0, rng)
    path = write_noisy_recording(tmp_path / "geo.sigmf-data", chunks, B1I_FS, rng, fmt="ci8")
    out = tmp_path / "trk"
    assert main(["track", str(path), "--signal", "beidou-b1i-geo", "--prns", "5", "--out", str(out), "--quiet"]) == 0
    with open(out / "d2.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 and rows[0]["prn"] == "5"
    ids = [int(x) for x in rows[0]["word_types"].split()]
    assert len(ids) >= 4 and all((b - a) % 5 == 1 for a, b in zip(ids, ids[1:]))
    # The last subframe read: its start in GPS time is its frame's SOW + 14 s + 0.6 s a
    # subframe before it. No week: page 1 (the week's) began before the recording.
    t_last = float(rows[0]["gst_tow_s"]) - 14.0 - first_sow
    assert rows[0]["gst_wn"] == "" and rows[0]["crc_failures"] == "0"
    assert 0.0 < t_last < 9.0 and abs(t_last / 0.6 - round(t_last / 0.6)) < 1e-6
    assert round(t_last / 0.6) % 5 == ids[-1] - 1
