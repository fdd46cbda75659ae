"""GPS CNAV from tracked L2C channels (`cnav_stream`), the tracker's L2 CM replica
(`correlator.replica_code_pair`) and the ``track`` command's ``cnav.csv``.

Truth: the messages `cnav.cnav_symbols` encoded into the generator's samples (their bits,
types and TOW) and the satellite time the generator put on the signal (symbol 0 starts
on a code epoch at a known SV time; the SV time then advances one chip per chip of code
phase); for the replica, the signal's own spreading table (CM chips, 0 in CL's slots).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from noisy_recording import write_noisy_recording

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation import cnav
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.receiver.channels.correlator import replica_code_pair, replica_codes
from gnssframework.receiver.navigation.cnav_stream import carries_cnav, channel_cnav, cnav_rows
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C, QZSS_L2C
from gnssframework.signal.if_samples import generate_if_samples

DATA = Path(__file__).parents[1] / "data"


def test_l2c_carries_cnav_and_other_signals_do_not():
    assert carries_cnav(GPS_L2C) and carries_cnav(QZSS_L2C)
    assert not carries_cnav(GPS_L1CA) and not carries_cnav(GALILEO_E1B_BOC11)


def test_channel_cnav_refuses_a_signal_without_cnav_in_one_line(channel_record):
    with pytest.raises(ConfigError, match=r"signal: PRN 7: gps-l1ca carries no CNAV") as err:
        channel_cnav(channel_record(7, [0.0], [1.0], [1]), GPS_L1CA)
    assert "\n" not in str(err.value)


def test_channel_cnav_decodes_each_run_and_dates_each_message(channel_record):
    # Two runs (a gap of one period after row 1000): each decodes on its own, in its own
    # pairing, and a message is dated by the row of its first symbol.
    rng = np.random.default_rng(5)
    rows = np.array([cnav.message_bits(9, t, 500 + k, rng.integers(0, 2, 238)) for k, t in enumerate((10, 11, 30, 0))])
    symbols = cnav.encode_cnav(rows).astype(float)[7:]  # starts mid-bit: pairing offset 1
    prompt = -40.0 * symbols + rng.standard_normal(symbols.size)  # 180 degrees off
    time_s = 3.0 + 0.02 * np.arange(symbols.size)
    time_s[1001:] += 0.02  # a lost period
    timing = channel_cnav(channel_record(9, time_s, prompt, np.ones(symbols.size, int)), GPS_L2C)
    got = [(m.msg_type, m.tow_count, m.crc_ok, m.inverted) for m in timing.messages]
    # Message k is rows 600 k - 7 to 600 k + 592. Run 1 (rows 0-1000) holds none whole
    # (message 0 started before row 0, message 1 runs past row 1000); run 2 (rows 1001-2392)
    # holds messages 2 and 3.
    assert got == [(30, 502, True, True), (0, 503, True, True)]
    starts = [1200 - 7, 1800 - 7]  # rows of their first symbols
    assert timing.time_s == pytest.approx([time_s[s] for s in starts])
    (r30, r0) = cnav_rows(timing)
    assert r30["bits_hex"] == cnav.message_from_bits(rows[2]).hex and r0["tow_s"] == f"{(503 * 6 - 12):.0f}"
    with pytest.raises(ConfigError, match=r"PRN 9's CM stream"):
        channel_cnav(
            channel_record(
                9, time_s, np.where(np.arange(symbols.size) == 5, np.nan, prompt), np.ones_like(prompt, int)
            ),
            GPS_L2C,
        )


def test_the_l2_cm_replica_is_the_mean_of_two_plus_minus_one_tables():
    prns = (1, 5, 32)
    a, b = replica_code_pair(GPS_L2C, prns)
    assert b is not None and np.all(np.abs(a) == 1) and np.all(np.abs(b) == 1)
    for k, prn in enumerate(prns):
        assert np.array_equal((a[k] + b[k]) / 2, GPS_L2C.spreading_table(prn))  # CM chips, 0 in CL's slots
    one, none = replica_code_pair(GPS_L1CA, prns)
    assert none is None and np.array_equal(one, replica_codes(GPS_L1CA, prns))


def test_the_compiled_mean_of_the_pair_is_the_reference_correlation_with_cms_table():
    # The tracker's L2C path (two compiled passes, their mean) against the float64 reference
    # correlating with the ternary table itself (`correlate_periods_numpy`), on noise plus
    # a CM signal, two code periods of two channels with E/P/L taps.
    from gnssframework.receiver.channels.correlator import correlate_periods, to_table_units
    from gnssframework.receiver.channels.correlator_reference import correlate_periods_numpy

    fs, prns = 2.5e6, (3, 11)
    rng = np.random.default_rng(8)
    x = generate_if_samples(3, 0.05, fs, 0.0, 50.0, rng, doppler_hz=300.0, complex_samples=True, signal=GPS_L2C)
    samples = x.samples.astype(np.complex128)
    phase = to_table_units(np.array([0.3, -0.2]), GPS_L2C)
    step = to_table_units(np.full(2, GPS_L2C.chip_rate_hz / fs), GPS_L2C)
    taps = to_table_units(np.array([-0.25, 0.0, 0.25]), GPS_L2C)
    common = (samples, np.array([0, 1000]), np.array([2, 2]), phase, step, np.zeros(2), np.full(2, 300.0 / fs))
    a, b = replica_code_pair(GPS_L2C, prns)
    sums_a, counts = correlate_periods(*common, a, taps, backend="numba")
    sums_b, counts_b = correlate_periods(*common, b, taps, backend="numba")
    table = np.stack([GPS_L2C.spreading_table(p) for p in prns])
    ref, ref_counts = correlate_periods_numpy(*common, table, taps)
    assert np.array_equal(counts, counts_b) and np.array_equal(counts, ref_counts)
    bound = 1e-4 * np.abs(ref).max()  # float32 sums of 50,000 samples
    assert np.max(np.abs(0.5 * (sums_a + sums_b) - ref)) < bound
    assert np.max(np.abs(sums_a - ref)) > 10 * bound  # one ±1 table alone is not CM's replica
    assert np.abs(ref[0, :, 1]).min() > 1000 * bound  # PRN 3's prompt holds the signal


def test_l2cs_tracking_settings_fit_a_20_ms_period_and_cms_half_chip_peak():
    """`signal_tracking_config` reads them from the description; track's CLI takes the same."""
    from argparse import Namespace

    from gnssframework.cli import _tracking_config_from_args
    from gnssframework.receiver.channels import WEAK_SIGNAL_SETTINGS, signal_tracking_config

    l2c = signal_tracking_config(GPS_L2C)
    # B_L T = 0.16 at T = 20 ms (the 18 Hz default, 0.36, is refused by the loop filter)
    assert l2c.pull_in_params == {"pll_bandwidth_hz": 8.0, "fll_bandwidth_hz": 4.0, "dll_bandwidth_hz": 1.0}
    assert l2c.channel_params == {"pll_bandwidth_hz": 8.0} and l2c.early_late_spacing_chips == 0.5
    assert l2c.coherent_ms == 1  # one CM period a symbol
    told = signal_tracking_config(GPS_L2C, early_late_spacing_chips=0.8, channel_params={"pll_bandwidth_hz": 5.0})
    assert told.early_late_spacing_chips == 0.8 and told.channel_params == {"pll_bandwidth_hz": 5.0}
    narrow = signal_tracking_config(GPS_L2C, pull_in_params={"pll_bandwidth_hz": 5.0})
    assert narrow.pull_in_params == {"pll_bandwidth_hz": 5.0}  # B_L T 0.1: kept
    weak = signal_tracking_config(GPS_L2C, **WEAK_SIGNAL_SETTINGS)  # its 15 Hz pull-in: B_L T 0.3
    assert weak.pull_in_params == l2c.pull_in_params and weak.bit_sync == "energy"
    assert weak.channel_params["pll_bandwidth_hz"] == 10.0  # the preset's own, B_L T 0.2
    l1 = signal_tracking_config(GPS_L1CA)
    assert l1.pull_in_params["pll_bandwidth_hz"] == 18.0 and l1.early_late_spacing_chips == 1.0
    assert l1.coherent_ms == 10  # half an LNAV bit
    args = Namespace(channel_filter="scalar", channel_params=None, duration=None)
    assert _tracking_config_from_args(args, GPS_L2C) == signal_tracking_config(GPS_L2C, channel_filter="scalar")


FS = 2.046e6
DOPPLER_HZ = 800.0


def _record_ephemeris():
    nav = read_rinex_nav(DATA / "07590920.05n")
    return nav.subset(np.flatnonzero(nav.elements["Toe"] % 300 == 0)[:1])  # toe on CNAV's 300 s grid


def _l2c_recording(path, prn: int, tow0: float, duration_s: float, rec) -> tuple:
    """``duration_s`` of generated L2C (45 dB-Hz, `DOPPLER_HZ`, complex int16 at `FS`) whose
    CM carries `cnav.cnav_symbols` (types 10, 11, 30 of ``rec``) from SV time ``tow0`` at
    t = 0, written chunk by chunk; the path, the SV time at symbol 0's start (the first code
    epoch, t = 0) and the SV seconds per receive second."""
    chunk_s = 0.5
    symbols, lead_s = cnav.cnav_symbols(prn, tow0, int(duration_s * 50) + 2, rec, wn=1316)
    code_rate = 1.0 + DOPPLER_HZ / GPS_L2C.carrier_freq_hz
    rng = np.random.default_rng(6)

    def chunks():
        for c in range(int(round(duration_s / chunk_s))):
            t0 = c * chunk_s
            yield generate_if_samples(
                prn,
                chunk_s,
                FS,
                0.0,
                45.0,
                rng,
                doppler_hz=DOPPLER_HZ,
                code_phase_chips=(GPS_L2C.chip_rate_hz * code_rate * t0) % GPS_L2C.code_length_chips,
                carrier_phase_rad=2 * np.pi * DOPPLER_HZ * t0,
                complex_samples=True,
                data_bits=symbols.astype(float),
                first_bit_edge_s=-t0,
                noise=False,
                signal=GPS_L2C,
            ).samples

    return write_noisy_recording(path, chunks(), FS, rng), tow0 - lead_s, code_rate


def _track(path, prn: int, out) -> list[dict]:
    args = ["track", str(path), "--signal", "gps-l2c", "--prns", str(prn), "--out", str(out), "--no-plots", "--quiet"]
    assert main(args) == 0
    with open(out / "cnav.csv", newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_track_gps_l2c_writes_the_cnav_messages_the_samples_carry(tmp_path, capsys):
    prn, rec = 5, _record_ephemeris()
    # The message of 86400 (type 10: 86400 / 12 is a multiple of 3) starts 0.31 s in.
    path, sym0, code_rate = _l2c_recording(tmp_path / "l2c.sigmf-data", prn, 86400.0 - 0.31, 13.0, rec)
    (row,) = _track(path, prn, tmp_path / "trk")
    text = capsys.readouterr().out
    assert f"PRN  {prn}: CNAV 1 messages (types 10), 0 CRC failures, TOW 86400 s" in text
    assert (row["prn"], row["prn_field"], row["msg_type"], row["tow_count"], row["tow_s"]) == (
        str(prn),
        str(prn),
        "10",
        str(86412 // 6),
        "86400",
    )
    assert (row["crc_ok"], row["alert"], row["inverted"] in ("0", "1")) == ("1", "0", True)
    payload10, _ = cnav.ephemeris_payloads(rec, 1316)
    assert row["bits_hex"] == cnav.message_from_bits(cnav.message_bits(prn, 10, 86412 // 6, payload10)).hex
    # The row starting the message's first symbol starts on the replica's code epoch where the
    # SV time is 86400: (86400 - sym0) SV seconds after t = 0, within a sample and the DLL's error.
    truth_s = (86400.0 - sym0) / code_rate
    assert abs(float(row["time_s"]) - truth_s) < 1.0 / FS + 0.1 / GPS_L2C.chip_rate_hz


@pytest.mark.slow
def test_samples_to_track_to_ephemeris_place_the_satellite_where_lnav_does(tmp_path):
    # 25 s: messages 10 (86400) and 11 (86412) whole; their ephemeris, decoded from the
    # tracked prompts, against the LNAV record the generator encoded (rounded to CNAV's
    # scale factors: within 5 cm, `test_cnav`).
    prn, rec = 7, _record_ephemeris()
    path, _, _ = _l2c_recording(tmp_path / "l2c.sigmf-data", prn, 86400.0 - 0.31, 25.0, rec)
    rows = _track(path, prn, tmp_path / "trk")
    assert [(r["msg_type"], r["tow_s"], r["crc_ok"]) for r in rows] == [("10", "86400", "1"), ("11", "86412", "1")]
    m10, m11 = (
        cnav.message_from_bits(np.array([int(c) for c in bin(int(r["bits_hex"], 16))[2:].zfill(300)], np.uint8))
        for r in rows
    )
    eph = cnav.parse_ephemeris(m10, m11)
    t = float(rec.elements["Toe"][0]) + np.linspace(-3600.0, 3600.0, 7)
    lnav = satellite_state(rec, t[:, None]).position_m[:, 0]
    assert np.max(np.linalg.norm(cnav.cnav_position(eph, t) - lnav, axis=-1)) < 0.05


@pytest.mark.slow
def test_every_row_of_an_l2c_channel_is_dated_from_its_cnav_tow(tmp_path):
    """`cnav_stream.cnav_channel_timing`: the rows after the pull-in, dated from the first
    checked message's TOW, each within a sample and a tenth of a CM chip of the SV time the
    generator sent at that instant; the week's low 10 bits from the type 10 message."""
    from l2c_recordings import l2c_tracking_config

    from gnssframework import registry
    from gnssframework.receiver.acquisition.report import acquire_recording
    from gnssframework.receiver.channels import SampleTracker
    from gnssframework.receiver.frontend import open_recording
    from gnssframework.receiver.navigation.cnav_stream import cnav_channel_timing

    prn, rec = 5, _record_ephemeris()
    path, sym0, code_rate = _l2c_recording(tmp_path / "l2c.sigmf-data", prn, 86400.0 - 0.31, 13.0, rec)
    recording = open_recording(path)
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(recording, acq, (prn,), signal=GPS_L2C) if r.detected]
    config = l2c_tracking_config()  # track --signal gps-l2c's settings
    record = SampleTracker(recording, config, acq, signal=GPS_L2C).run(found).channels[prn]
    timing = cnav_channel_timing(record, GPS_L2C)
    assert timing is not None and timing.time_s.size > 0.9 * (13.0 - 1.0) / 0.02
    err_s = timing.transmit_s - (sym0 + code_rate * timing.time_s)
    assert np.max(np.abs(err_s)) < 1.0 / FS + 0.1 / GPS_L2C.chip_rate_hz
    assert timing.message.week == 1316 and timing.message.week_bits == 13  # type 10 sends 13 bits
    assert timing.arc_start[0] and np.all(timing.half_cycle == timing.half_cycle[0])


def test_a_run_whose_checked_messages_disagree_is_not_dated():
    """Two CRC-checked messages 600 symbols apart must be 12 s apart in TOW: otherwise the
    run's time is ambiguous and it is left undated (`cnav_stream._run_epoch`)."""
    from gnssframework.receiver.navigation.cnav_stream import _run_epoch

    def message(start, tow_count, crc_ok=True):
        return cnav.CnavMessage(start, 5, 10, tow_count, False, crc_ok, False, np.zeros(300, int))

    assert _run_epoch([message(7, 100), message(607, 102)], 0.02) == (7, 100 * 6.0 - 12.0, False)
    assert _run_epoch([message(7, 100), message(607, 103)], 0.02) is None
    assert _run_epoch([message(7, 100, crc_ok=False), message(607, 103)], 0.02) == (607, 103 * 6.0 - 12.0, False)
    assert _run_epoch([message(7, 100, crc_ok=False)], 0.02) is None
