"""Galileo I/NAV from tracked E1-B channels (`inav_stream`), and the ``track`` command's
report of it.

Truth: the pages `inav.encode_inav` / `inav.inav_symbols` wrote (their word types, the
record's IODnav, the GST of each page) and, for the transmit times, the satellite time the
generator put on the signal: symbol 0 starts on a code epoch at a known GST, and the
satellite time then advances one chip per chip of code phase.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation import inav
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.channels import ChannelRecord
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples, write_recording
from gnssframework.receiver.navigation.inav_stream import (
    carries_inav,
    carries_lnav,
    channel_inav,
    coherent_periods,
    require_lnav,
    symbol_runs,
)
from gnssframework.receiver.navigation.receive import receive
from gnssframework.signal.galileo_e1 import GALILEO_E1B, GALILEO_E1B_BOC11, GALILEO_E1C_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.qzss_l1ca import QZSS_L1CA

NAV = Path(__file__).parents[1] / "data" / "galileo_inav_20feb2022_05h.rnx"
WN = 1174


def test_signals_by_message_and_the_coherent_default():
    assert carries_inav(GALILEO_E1B) and carries_inav(GALILEO_E1B_BOC11)
    assert not carries_inav(GALILEO_E1C_BOC11) and not carries_inav(GPS_L1CA)
    assert carries_lnav(GPS_L1CA) and carries_lnav(QZSS_L1CA) and not carries_lnav(GALILEO_E1B_BOC11)
    assert coherent_periods(GPS_L1CA, None) == 10 and coherent_periods(GALILEO_E1B_BOC11, None) == 1
    assert coherent_periods(GPS_L1CA, 20) == 20
    assert coherent_periods(GALILEO_E1C_BOC11, None) == 1  # its E1-B symbol (and overlay chip): one period
    with pytest.raises(ConfigError, match="tracking.coherent_ms.*span galileo-e1b-boc11"):
        coherent_periods(GALILEO_E1B_BOC11, 10)
    # the library names its parameter; the track command names it as its option
    from gnssframework.cli import option_field

    assert option_field("tracking.coherent_ms") == "--coherent-ms-track"


def test_receive_refuses_a_signal_it_would_date_as_lnav_in_one_line():
    with pytest.raises(ConfigError) as exc:
        require_lnav(GALILEO_E1B_BOC11)
    assert "LNAV" in str(exc.value) and "track --signal galileo-e1b-boc11" in str(exc.value)
    assert len(str(exc.value).splitlines()) == 1
    with pytest.raises(ConfigError, match="galileo-e1c-boc11"):
        receive(None, None, None, signal=GALILEO_E1C_BOC11)  # refused before anything is read


def test_symbol_runs_split_at_gaps_and_longer_integrations():
    t = np.r_[np.arange(10) * 0.004, 0.1 + np.arange(5) * 0.004, 0.12 + np.arange(3) * 0.008]
    k = np.r_[np.ones(15, int), np.full(3, 2)]
    runs = symbol_runs(t, k, 0.004)
    assert [r.tolist() for r in runs] == [list(range(10)), list(range(10, 15))]
    assert [r.size for r in symbol_runs(t, k, 0.004, min_symbols=6)] == [10]


def test_channel_inav_decodes_each_run_dates_its_rows_and_reports_a_bad_page(channel_record):
    """Two runs of one channel (a gap between them), both inverted; a page of the second
    with a corrupted CRC is reported, not used; every dated row's transmit time is the GST
    of its page start plus 4 ms a row plus its code phase."""
    rec = read_rinex_nav(NAV, systems="E").subset(np.array([0]))
    first = 18019  # a page start (odd second); pages of word types 22, 1, 3, 5, 0, 16, 2, 4, 6
    sym = -inav.encode_inav(rec, WN, first, 9).astype(float)  # a Costas loop's 180 degrees
    n1, skip = 3 * inav.PAGE_SYMBOLS + 100, 300  # run 1: pages at 18019-18023; run 2 after 1.2 s lost
    rng = np.random.default_rng(39)
    prompt = sym * 5.0 + rng.normal(0.0, 1.0, sym.size)  # Es/N0 = 11 dB: no symbol errors to speak of
    bad = 5 * inav.PAGE_SYMBOLS + 120  # inside the page at 18029 s: flip 40 coded symbols
    prompt[bad : bad + 40] *= -1
    keep = np.r_[np.arange(n1), np.arange(n1 + skip, sym.size)]
    t = 2.5 + keep * 0.004  # recording time of each row (a code epoch)
    code = rng.uniform(0.0, 0.5, keep.size)  # replica code phase past that epoch (chips)
    timing = channel_inav(channel_record(11, t, prompt[keep], np.ones(keep.size, int), code), GALILEO_E1B_BOC11)
    assert len(timing.messages) == 2
    # encode_inav sends word types beyond 0-5 as type 0 with the GST
    assert [p.word_type for p in timing.messages[0].pages] == [0, 1, 3]  # 18019, 18021, 18023
    assert [p.word_type for p in timing.messages[1].pages] == [0, 2, 4, 0]  # 18027, (18029 bad), 18031-18035
    assert all(p.inverted for m in timing.messages for p in m.pages)
    assert len(timing.failures) == 1 and "CRC-24Q" in timing.failures[0]
    # The GST: the last page's (18035 s), dating its first symbol.
    gst_time, wn, tow = timing.gst
    assert (wn, tow) == (WN, 18035.0)
    assert gst_time == pytest.approx(2.5 + (18035 - first) * inav.SYMBOL_RATE_HZ * 0.004, abs=1e-9)
    # Dated rows: all of both runs, transmit time from the symbol index in the stream.
    assert timing.rows.size == keep.size
    truth = first + keep * 0.004 + code / GALILEO_E1B_BOC11.chip_rate_hz
    np.testing.assert_allclose(timing.transmit_s, truth, rtol=0, atol=1e-9)
    assert timing.ephemeris is None  # words 1-5 are not all in one run


def test_channel_inav_refuses_a_signal_without_inav():
    with pytest.raises(ConfigError, match="no I/NAV"):
        channel_inav(ChannelRecord(3), GPS_L1CA)


# --- the track command on a generated E1-B recording carrying I/NAV -------------------

FS = 4e6
TOW0 = 18020.6  # GST at the first symbol edge: the pages of words 1, 3, 5 start 0.4, 2.4, 4.4 s later
DURATION_S = 6.5
SAT = SatelliteSignal(19, 45.0, 730.0, 1200.3, 0.4, first_bit_code_period=0, signal=GALILEO_E1B_BOC11)


@pytest.mark.slow
def test_track_galileo_e1b_reports_the_inav_pages_iodnav_and_gst(tmp_path, capsys, channel_record):
    rec = read_rinex_nav(NAV, systems="E").subset(np.array([0]))
    symbols, lead_s = inav.inav_symbols(rec, WN, TOW0, int(DURATION_S * inav.SYMBOL_RATE_HZ) + 2)
    sym0 = TOW0 - lead_s  # GST at symbol 0's start (18020.6 s in binary falls just short of that edge)
    assert lead_s in (pytest.approx(0.0, abs=1e-9), pytest.approx(0.004, abs=1e-9))
    sat = SatelliteSignal(
        **{
            k: getattr(SAT, k)
            for k in (
                "prn",
                "cn0_dbhz",
                "doppler_hz",
                "code_phase_chips",
                "carrier_phase_rad",
                "first_bit_code_period",
                "signal",
            )
        },
        symbols=symbols,
    )
    x = synthesize_samples([sat], DURATION_S, FS, 0.0, np.random.default_rng(41))
    path = write_recording(tmp_path / "e1b.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0)
    out = tmp_path / "trk"
    assert (
        main(
            [
                "track",
                str(path),
                "--signal",
                "galileo-e1b-boc11",
                "--prns",
                "19",
                "--out",
                str(out),
                "--no-plots",
                "--quiet",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    with open(out / "inav.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert row["prn"] == "19" and row["word_types"] == "1 3 5" and row["crc_failures"] == "0"
    assert row["iodnav"] == str(int(rec.iode[0]))
    assert (row["gst_wn"], row["gst_tow_s"]) == (str(WN), "18025")
    # The GST dates the first symbol of word 5's page: it left the satellite 18025 - sym0 s
    # after symbol 0, whose edge is the first code epoch; the row starting there starts on
    # the sample of the replica's code epoch (within a sample, plus the DLL's error: 0.1 chip).
    edge_s = SAT.first_bit_edge_s()
    code_rate = GALILEO_E1B_BOC11.code_freq_hz(SAT.doppler_hz) / GALILEO_E1B_BOC11.chip_rate_hz
    tolerance_s = 1.0 / FS + 0.1 / GALILEO_E1B_BOC11.chip_rate_hz
    assert abs(float(row["gst_time_s"]) - (edge_s + (18025 - sym0) / code_rate)) < tolerance_s
    assert "I/NAV 3 pages (word types 1 3 5), 0 CRC failures" in text and "GST week 1174 TOW 18025 s" in text
    # The summary counts 4 ms code periods, not milliseconds: the whole recording tracked.
    with open(out / "summary.csv", newline="") as f:
        (summary,) = list(csv.DictReader(f))
    assert abs(float(summary["tracked_s"]) - DURATION_S) < 0.01 and float(summary["locked_fraction"]) > 0.9
    # The transmit time of every dated row (tracking.csv read back as the channel's record)
    # against the generator's satellite time: within the DLL's error (0.06 chip at 45 dB-Hz
    # with a 2 Hz pull-in DLL, `test_boc_sample_tracker`), nowhere near a code period (4 ms).
    with open(out / "tracking.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    time_s, prompt_i, code = ([float(r[c]) for r in rows] for c in ("time_s", "prompt_i", "code_phase_chips"))
    record = channel_record(19, time_s, prompt_i, [int(r["coherent_ms"]) for r in rows], code)
    timing = channel_inav(record, GALILEO_E1B_BOC11)
    t = record.column("time_s")[timing.rows]
    truth = sym0 + (t - edge_s) * code_rate  # satellite seconds per receive second: the code rate
    late = t > 1.0  # after pull-in
    err_chips = (timing.transmit_s - truth)[late] * GALILEO_E1B_BOC11.chip_rate_hz
    assert late.sum() > 1000 and np.all(np.abs(err_chips) < 0.1), np.abs(err_chips).max()


def test_an_ephemeris_is_ready_once_the_page_completing_words_1_to_5_has_arrived(channel_record):
    """One run of nine pages from GST 18019 s (word types 22, 1, 3, 5, 0, 16, 2, 4, 6): the
    record is complete with word 4's page (18033 s), i.e. at the row after that page's last
    symbol, 16 s of pages after the run's first symbol; its fields are the record's."""
    rec = read_rinex_nav(NAV, systems="E").subset(np.array([0]))
    sym = inav.encode_inav(rec, WN, 18019, 9).astype(float) * 4.0
    t = 1.0 + np.arange(sym.size) * 0.004
    timing = channel_inav(channel_record(11, t, sym, np.ones(sym.size, int)), GALILEO_E1B_BOC11)
    ((ready_s, eph),) = timing.ephemerides
    assert ready_s == pytest.approx(1.0 + (18035 - 18019) * 1.0, abs=1e-9)
    assert int(eph.iode[0]) == int(rec.iode[0]) and eph.sv[0] == rec.sv[0]
    assert eph.elements["sqrtA"][0] == pytest.approx(rec.elements["sqrtA"][0], rel=1e-12)


def test_a_galileo_run_without_position_reports_its_inav_not_lnav(tmp_path, channel_record):
    """A receive run on E1-B whose channels decoded no I/NAV page: the reason and the
    report speak of I/NAV pages and the GST (what dates E1-B), not of LNAV subframes."""
    from gnssframework.receiver.acquisition.search import AcquisitionResult
    from gnssframework.receiver.channels.records import TrackingResult
    from gnssframework.receiver.navigation.receive import ReceiveResult
    from gnssframework.receiver.navigation.report import no_position_reason, write_no_position_report

    rng = np.random.default_rng(3)
    n = 600  # 2.4 s of 4 ms symbols, random signs: no sync pattern, no page
    channels = {
        prn: channel_record(prn, 0.004 * np.arange(n), rng.choice([-1.0, 1.0], n), np.ones(n, int))
        for prn in (4, 11, 19, 27)
    }
    acq = [AcquisitionResult(p, True, 1000.0, 10, 100.0, 40.0, 30.0, 20.0) for p in channels]
    result = ReceiveResult(TrackingResult(channels, acq, 2.4, "scalar"), None, None)
    reason = no_position_reason(result, signal=GALILEO_E1B_BOC11)
    assert "no I/NAV page with a GST decoded (4 of 4 satellites found locked" in reason
    assert "LNAV" not in reason and "LNAV" in no_position_reason(result)  # GPS still speaks LNAV
    write_no_position_report(tmp_path, result, reason, signal=GALILEO_E1B_BOC11)
    report = (tmp_path / "report.md").read_text()
    assert "| I/NAV pages | GST TOW (s) |" in report and "LNAV" not in report
    rows = [line for line in report.splitlines() if line.startswith("| 4 |")]
    assert len(rows) == 1 and "| 0 | - |" in rows[0] and "no I/NAV page with a GST decoded" in rows[0]
