"""`receive` with SBAS messages from the recording's own GEO (`SbasOptions.from_signal`,
``receive --sbas-signal``): the project's LNAV recording of five satellites (50 dB-Hz) whose
codes carry known clock, ionospheric and tropospheric delays, and an SBAS L1 GEO (PRN 137,
45 dB-Hz, at a fixed range 0.125 s away) sending a stream that carries those errors
(`sbas_streams.compact_stream`: a whole set of corrections in its first ten messages).

Truth: the messages the generator sent and when each one's last symbol reached the antenna
(its send time, steered to GPS time, plus the GEO's 0.125 s), the receiver's record of a
message (as RTKLIB's logs date it). The fixes are checked against the same observables solved
with the sent messages at their true times (`SbasOptions` from a list, the file path): only
the dating of the messages may differ."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.cli import main
from gnssframework.navigation import sbas_message as sm
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.sbas_files import SbasRecord
from gnssframework.receiver.navigation.fixes import solve_epochs
from gnssframework.receiver.navigation.sbas_fixes import SbasOptions, day_of_year, merged_records, signal_records
from lnav_recordings import NAV, STATION, TOW0, WEEK, Geo, _strongest, write_lnav_recording
from sbas_streams import compact_stream, range_delays, receive_sbas

DURATION_S = 12.0
GEO_PRN = 137
GEO_DELAY_S = 0.125
#: The GEO's first message's send time: the whole second before the first sample's (its
#: symbols from there on, the first message cut by the recording's start).
T0 = float(np.floor(TOW0 - GEO_DELAY_S))
CLOCK_ERRORS_M = np.array([18.0, -24.0, 12.0, -15.0, 30.0])
#: The IGPs around the five satellites' pierce points (32.7-36.6 N, 135.3-145.4 E): one
#: message of delays per band.
BANDS = {7: (130, 135), 8: (140, 150)}
LATS = (30, 40)
SIGMA_M = 1.7 * 10 ** (-(50.0 - 45.0) / 20)  # test_sbas_receive's code noise at 50 dB-Hz


def _arrived_whole(k: int) -> float:
    """GPS time at which message ``k``'s last symbol reached the antenna."""
    return T0 + k + GEO_DELAY_S + 1.0


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    delay_m, prc_m = range_delays(sats, STATION, TOW0 + 5.0, day_of_year(WEEK, TOW0), CLOCK_ERRORS_M)
    sent = compact_stream(sats, prc_m, WEEK, T0, int(DURATION_S) + 2, GEO_PRN, BANDS, LATS)
    symbols = sm.encode_messages(np.array([r.bits for r in sent]))
    folder = tmp_path_factory.mktemp("sbas_signal")
    path = write_lnav_recording(
        folder / "geo.sigmf-data",
        sats,
        TOW0,
        DURATION_S,
        seed=41,
        iono_m=delay_m,
        cn0_dbhz=50.0,
        geo=Geo(GEO_PRN, symbols.astype(float), T0, GEO_DELAY_S, 45.0),
    )
    rinex = read_rinex_nav(NAV)
    result = receive_sbas(path, rinex, SbasOptions((), sigma_noise_m=SIGMA_M, from_signal=True))
    return result, sent, rinex, path, folder


def _read(result, sent):
    """The one SBAS channel, and the index in ``sent`` of each good message it read (by the
    time its first symbol arrived), checked to be that message."""
    (channel,) = result.sbas
    index = []
    for m, t_s in zip(channel.messages, channel.times_s):
        if m.crc_ok:
            k = int(round(TOW0 + t_s - GEO_DELAY_S - T0))
            np.testing.assert_array_equal(m.bits, sent[k].bits)
            index.append(k)
    return channel, index


@pytest.mark.slow
def test_the_geo_is_tracked_and_its_messages_read_and_dated(run):
    result, sent, _, _, _ = run
    assert result.sbas is not None and [c.prn for c in result.sbas] == [GEO_PRN] and result.sbas_notes == ()
    channel, index = _read(result, sent)
    assert not channel.failures
    # Each message read is one sent, whole in the recording; every one from the mask (the
    # third, arriving whole 2.7 s in: after the pull-in and the symbol edge) to the last.
    last_whole = max(k for k in range(len(sent)) if _arrived_whole(k) <= TOW0 + DURATION_S)
    assert index == list(range(index[0], last_whole + 1)) and index[0] <= 2
    # Dated by the GPS channels' epochs when each arrived whole: within the receiver
    # clock's bias (the observables' receive times less the truth) of the true time.
    obs = result.observables
    bias_s = float(np.max(np.abs(obs.rx_time_s - (TOW0 + obs.sample_time_s))))
    dated = signal_records(channel, obs.sample_time_s, obs.rx_time_s, WEEK)
    assert [r.prn for r in dated] == [GEO_PRN] * len(index) and all(r.week == WEEK for r in dated)
    assert [r.type for r in dated] == [sent[k].type for k in index]
    truth = np.array([_arrived_whole(k) for k in index])
    assert np.max(np.abs(np.array([r.tow_s for r in dated]) - truth)) <= bias_s + 1e-6
    assert bias_s < 0.01  # (the dating's margin: the epochs are 0.2 s apart)


@pytest.mark.slow
def test_the_fixes_are_corrected_once_the_set_has_arrived_as_with_the_sent_messages(run):
    result, sent, rinex, _, _ = run
    _, index = _read(result, sent)
    table = result.positions
    sats = table.columns["sbas_sats"]
    # The set is whole when the second band's delays (message 9) have arrived: broadcast
    # fixes before (sbas_sats 0, no protection levels), corrected ones from then on.
    whole = _arrived_whole(9)
    tow = table.columns["tow_s"]
    assert np.all(sats[tow < whole - 0.01] == 0) and np.all(np.isnan(table.columns["hpl_m"][sats == 0]))
    assert np.all(sats[tow > whole + 0.01] == 5) and np.count_nonzero(sats == 5) >= 8
    # The same observables corrected with the messages sent, at their true times (the file
    # path; in the week the receiver gave its fixes, its LNAV week's era): the same fixes,
    # protection levels and epochs corrected.
    week = int(table.columns["gps_week"][0])
    truth = tuple(SbasRecord(week, _arrived_whole(k), GEO_PRN, sent[k].type, sent[k].bits) for k in index)
    ref = solve_epochs(result.observables, rinex, sbas=SbasOptions(truth, sigma_noise_m=SIGMA_M))
    np.testing.assert_array_equal(ref.columns["sbas_sats"], sats)
    np.testing.assert_allclose(table.ecef_m, ref.ecef_m, atol=1e-3)
    np.testing.assert_allclose(table.columns["vpl_m"], ref.columns["vpl_m"], atol=1e-3, equal_nan=True)
    # The corrected fixes keep the code noise through the geometry (test_sbas_receive's
    # bound); the broadcast ones before them keep the injected 12-30 m clock errors.
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    bound = 4 * np.max(table.columns["hdop"] + table.columns["vdop"]) * SIGMA_M
    assert np.sqrt(np.mean(err[sats == 5] ** 2)) < bound < np.min(err[sats == 0])


@pytest.mark.slow
def test_no_message_leaves_the_broadcast_fixes_with_the_sbas_columns(run):
    result, _, rinex, _, _ = run
    plain = solve_epochs(result.observables, rinex)
    none = solve_epochs(result.observables, rinex, sbas=SbasOptions((), prn=GEO_PRN, from_signal=True))
    np.testing.assert_allclose(none.ecef_m, plain.ecef_m)
    assert np.all(none.columns["sbas_sats"] == 0) and np.all(np.isnan(none.columns["vpl_m"]))


def test_a_message_logged_and_decoded_is_kept_once():
    bits = [np.r_[np.ones(8), np.full(242, k % 2)].astype(np.uint8) for k in range(3)]
    logged = [SbasRecord(WEEK, 100.0 + k, GEO_PRN, 0, bits[k]) for k in range(3)]
    decoded = [SbasRecord(WEEK, 100.4 + k, GEO_PRN, 0, bits[k]) for k in (1, 2)]
    other = [SbasRecord(WEEK, 100.4, 129, 0, bits[0]), SbasRecord(WEEK, 103.0, GEO_PRN, 0, bits[0])]
    merged = merged_records(logged, decoded + other)
    # bits[0] again 3 s later and from GEO 129 are other messages; the decoded twins are not
    assert [(r.prn, r.tow_s) for r in merged] == [(137, 100.0), (129, 100.4), (137, 101.0), (137, 102.0), (137, 103.0)]


@pytest.mark.slow
def test_receive_sbas_signal_writes_the_messages_and_corrected_positions(run, tmp_path, capsys):
    result, _, _, path, _ = run
    out = tmp_path / "out"
    args = ["--sbas-signal", "--sbas-sigma-noise", f"{SIGMA_M}", "--ephemeris", str(NAV), "--rate", "5"]
    code = main(["receive", str(path), *args, "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0, printed
    channel = result.sbas[0]
    assert f"SBAS PRN {GEO_PRN}: {len(channel.good)} messages (types 2 1 2 25 25 18 18 26 26" in printed
    rows = (out / "sbas.csv").read_text().splitlines()
    assert len(rows) == 1 + len(channel.messages) and rows[2].split(",")[4] == "1"  # the mask, second read
    positions = (out / "positions.csv").read_text().splitlines()
    header = positions[0].split(",")
    last = dict(zip(header, positions[-1].split(",")))
    assert header[-3:] == ["hpl_m", "vpl_m", "sbas_sats"] and last["sbas_sats"] == "5"
    assert float(last["vpl_m"]) == pytest.approx(result.positions.columns["vpl_m"][-1], abs=0.01)
