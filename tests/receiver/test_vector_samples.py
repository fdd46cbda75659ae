"""Vector tracking on samples (`receiver.navigation.vector_tracking`) on the project's own
generator: the five satellites of `test_receiver_fix` (real broadcast orbits seen from a
known station, LNAV, light time and Earth rotation), at 45 dB-Hz for the pull-in, the LNAV
TOW and a first fix, then faded to a C/N0 at which the scalar receiver's channels lose
lock. The scalar receiver's failure is asserted on the same file; vector tracking keeps
a position to the end, and every vector channel's Doppler matches the generator's."""

from __future__ import annotations

import numpy as np
import pytest

import test_receiver_fix as fix
from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.navigation.vector_tracking import vector_config
from lnav_recordings import WEEK, C, true_dopplers, write_lnav_recording

DURATION_S = 13.0
FADE_S = 10.5  # the first fix comes with TOW, 8.6 s in (see test_receiver_fix)
STRONG_DBHZ, WEAK_DBHZ = 45.0, 24.0


def _cn0(t_s: float) -> float:
    return STRONG_DBHZ if t_s < FADE_S else WEAK_DBHZ


@pytest.fixture(scope="module")
def faded(tmp_path_factory):
    """``fix.recording``'s signals with the C/N0 profile `_cn0`; the true Doppler per chunk."""
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    path = write_lnav_recording(
        tmp_path_factory.mktemp("vector") / "faded.sigmf-data", sats, fix.TOW0, DURATION_S, seed=7, cn0_dbhz=_cn0
    )
    prns = [int(s[1:]) for s in sats.sv]
    return path, prns, true_dopplers(sats, fix.TOW0, DURATION_S)


def _receive(path, **kw):
    return receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        tracking_config(),
        rate_hz=5.0,
        rinex=read_rinex_nav(fix.NAV),
        **kw,
    )


@pytest.mark.slow
def test_scalar_receiver_loses_every_channel_after_the_fade(faded):
    path, prns, _ = faded
    result = _receive(path)
    for prn in prns:
        events = result.tracking.channels[prn].events
        assert any(t > FADE_S and "lost" in text for t, text in events), events
    # No fix more than a second after the fade (lock detection and loss take 0.6 s).
    assert result.positions is not None and result.positions.sample_time_s.max() < FADE_S + 1.0


#: The vector channels: the discriminators, and reference 000's I/Q filter (a CKF on the six
#: correlators) handing the navigation filter the frequency measurement equivalent to each
#: interval's new information (`plugins.channel_filters.IqFilter`, output "equivalent"),
#: the code error from the code discriminator (the new information's code error is shrunk
#: towards 0, the IqFilter text says: its channels' code errors exceed four of the filter's
#: predicted standard deviations here).
CHANNELS = {"discriminator": {}, "iq-filter": {"output": "equivalent", "equivalent_code": "discriminator"}}


@pytest.fixture(scope="module", params=list(CHANNELS))
def vector_result(faded, request):
    return _receive(
        faded[0],
        vector=vector_config(
            solution_rate_hz=5.0, channel_filter=request.param, channel_params=CHANNELS[request.param]
        ),
    )


@pytest.mark.slow
def test_vector_tracking_keeps_a_fix_through_the_fade(faded, vector_result):
    _, prns, _ = faded
    solution = vector_result.vector
    assert set(solution.prns) == set(prns) and solution.handover_s < FADE_S
    table = vector_result.positions
    after = table.sample_time_s > FADE_S + 1.0
    # A row every 1/5 s to the end of the file, all five satellites in each.
    assert table.sample_time_s[after].size >= (DURATION_S - FADE_S - 1.0) * 5 - 2
    assert np.all(table.columns["n_sats"][after] == 5)
    err = np.linalg.norm(table.ecef_m[after] - fix.STATION, axis=1)
    # As well as the scalar receiver at 45 dB-Hz (test_receiver_fix's bound: about 1.7 m of
    # code noise per satellite for a 2 Hz DLL, DOP-scaled), at 24 dB-Hz.
    dops = table.columns["hdop"][after] + table.columns["vdop"][after]
    assert np.all(np.isfinite(dops))
    assert np.sqrt(np.mean(err**2)) < 4 * dops.max() * 1.7, (err, dops)
    speed = np.linalg.norm(np.stack([table.columns[k] for k in ("vel_e_mps", "vel_n_mps", "vel_u_mps")], 1), axis=1)
    assert np.all(speed[after] < 1.0)


@pytest.mark.slow
def test_vector_channels_follow_the_true_code_and_doppler_at_the_weak_signal(faded, vector_result):
    """No dynamics but the satellites': at 24 dB-Hz every vector channel's code phase and
    Doppler are the generator's within four standard deviations of the pseudorange and rate
    the navigation filter predicts for it (its covariance projected on the line of sight:
    the thermal noise of five discriminators through the filter), plus what the record's
    sampling adds (the generator's Doppler is constant over each 0.5 s chunk)."""
    _, prns, dopplers = faded
    solution = vector_result.vector
    nav = read_rinex_nav(fix.NAV)
    sats = fix._strongest(nav, fix.TOW0, 5)
    t_sol = np.asarray(solution.sample_time_s)
    x = np.asarray(solution.state)
    for k, prn in enumerate(prns):
        ch = vector_result.tracking.channels[prn]
        t, dop, stage = ch.column("time_s"), ch.column("doppler_hz"), ch.column("stage")
        chips = ch.column("code_phase_chips")
        weak = (t > FADE_S + 1.0) & (stage == 4)
        assert weak.sum() > 100
        # The filter's epoch just before each row, and its line-of-sight standard deviations.
        j = np.clip(np.searchsorted(t_sol, t[weak]) - 1, 0, t_sol.size - 1)
        los = sats_los(sats, k, x[j, :3])
        h_range = np.concatenate([-los, np.ones((los.shape[0], 1))], axis=1)
        cov = np.asarray(solution.cov)[j]
        sigma_range = np.sqrt(np.einsum("ki,kij,kj->k", h_range, cov[:, np.r_[0:3, 6]][:, :, np.r_[0:3, 6]], h_range))
        sigma_rate = np.sqrt(np.einsum("ki,kij,kj->k", h_range, cov[:, np.r_[3:6, 7]][:, :, np.r_[3:6, 7]], h_range))
        truth_dop = dopplers[np.minimum((t[weak] / fix.CHUNK_S).astype(int), len(dopplers) - 1), k]
        dop_err = dop[weak] - truth_dop
        assert np.sqrt(np.mean(dop_err**2)) < 4 * np.sqrt(np.mean(sigma_rate**2)) / 0.1903
        # Code: the chips the signal had sent at each row's first sample (receiver clock = GPS time).
        t_sv = np.array([fix._satellite_time(sats, np.array(fix.TOW0 + ti))[k] for ti in t[weak]])
        true_chips = (t_sv * 1e3 % 1.0) * 1023
        code_err_m = ((chips[weak] - true_chips + 511.5) % 1023 - 511.5) * 293.05
        assert np.sqrt(np.mean(code_err_m**2)) < 4 * np.sqrt(np.mean(sigma_range**2)), (
            np.sqrt(np.mean(code_err_m**2)),
            np.sqrt(np.mean(sigma_range**2)),
        )


@pytest.mark.slow
def test_every_vector_channel_is_in_the_observables_and_rinex_after_the_hand_over(faded, vector_result, tmp_path):
    """The observables (and so ``observations.rnx``) keep every vector-tracked satellite to
    the end: its rows go on bit by bit from the decoded TOW through the hand-over. Each
    transmit time is the generator's (receiver clock = GPS time) within half a chip, the
    early-late discriminator's reach (a miscounted millisecond or bit would be 300 km or
    more off); no carrier phase after the hand-over (no PLL closes it)."""
    from gnssframework.receiver.navigation.rinex_obs import write_rinex_obs

    _, prns, _ = faded
    obs, handover_s = vector_result.observables, vector_result.vector.handover_s
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    after = obs.sample_time_s > handover_s
    assert obs.sample_time_s[after].size >= (DURATION_S - handover_s) * 5 - 2
    cols = [list(obs.prn).index(p) for p in prns]
    assert np.isfinite(obs.pseudorange_m[np.ix_(after, cols)]).all()
    t_sv = np.array([fix._satellite_time(sats, np.array(fix.TOW0 + t)) for t in obs.sample_time_s[after]])
    err_m = (obs.transmit_s[np.ix_(after, cols)] - t_sv) * C
    assert np.abs(err_m).max() < 0.5 * 293.05, np.abs(err_m).max(axis=0)
    assert np.isnan(obs.carrier_cycles[np.ix_(after, cols)]).all()
    # The RINEX file: every epoch after the hand-over lists all five satellites.
    text = write_rinex_obs(tmp_path / "observations.rnx", obs, WEEK).read_text()
    epochs = [line for line in text.splitlines() if line.startswith("> ")]
    assert len(epochs) == obs.sample_time_s.size
    counts = np.array([int(line.split()[-1]) for line in epochs])
    assert np.all(counts[after] == 5), counts


def sats_los(sats, k: int, receiver_m: np.ndarray) -> np.ndarray:
    """Unit vectors ``(n, 3)`` from receivers ``receiver_m`` ``(n, 3)`` to satellite ``k`` (75 ms before)."""
    from gnssframework.navigation.ephemeris import satellite_state

    pos = satellite_state(sats.subset(np.array([k])), fix.TOW0 + 10.0).position_m[0]
    d = pos - receiver_m
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_a_bad_vector_setting_names_the_field():
    with pytest.raises(ConfigError, match="min_cn0_dbhz"):
        vector_config(min_cn0_dbhz="low")


@pytest.mark.slow
def test_position_command_tracks_vector(faded, tmp_path, capsys):
    from gnssframework.cli import main

    path, _, _ = faded
    code = main(
        [
            "position",
            str(path),
            "--out",
            str(tmp_path / "pos"),
            "--ephemeris",
            str(fix.NAV),
            "--rate",
            "5",
            "--tracking",
            "vector",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    assert "vector tracking from" in out
    rows = (tmp_path / "pos" / "positions.csv").read_text().splitlines()[1:]
    # Rows to the end of the file, through the fade.
    assert len(rows) >= 5 * (DURATION_S - 9.0) - 2


@pytest.mark.slow
def test_position_command_closes_the_loop_with_the_iq_filter(faded, tmp_path, capsys):
    from gnssframework.cli import main

    path, _, _ = faded
    code = main(
        [
            "position",
            str(path),
            "--out",
            str(tmp_path / "pos"),
            "--ephemeris",
            str(fix.NAV),
            "--rate",
            "5",
            "--tracking",
            "vector",
            "--vector-channel-filter",
            "iq-filter",
            "--vector-channel-params",
            '{"output": "equivalent", "equivalent_code": "discriminator"}',
            "--duration",
            "10.5",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    assert "vector tracking from" in out and "(channel filter iq-filter)" in out


@pytest.mark.parametrize(
    "extra",
    [
        ["--tracking", "vector", "--vector-channel-filter", "scalar"],
        [
            "--tracking",
            "vector",
            "--vector-channel-filter",
            "iq-filter",
            "--vector-channel-params",
            '{"output": "sideways"}',
        ],
        ["--tracking", "vector", "--vector-channel-params", "[1]"],
        ["--vector-channel-filter", "iq-filter"],
    ],
)
def test_bad_vector_channel_options_exit_2(faded, tmp_path, extra):
    from gnssframework.cli import main

    assert main(["position", str(faded[0]), "--out", str(tmp_path), "--ephemeris", str(fix.NAV), *extra]) == 2


def test_an_unknown_tracking_mode_exits_2(faded, tmp_path, capsys):
    from gnssframework.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["position", str(faded[0]), "--out", str(tmp_path), "--tracking", "deep"])
    assert exc.value.code == 2


#: The first satellite absent from 10.5 s to 13 s of a 16 s, 45 dB-Hz file (hand-over at 9 s).
BLANK = (0, 10.5, 13.0)


@pytest.fixture(scope="module")
def blanked(tmp_path_factory):
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    path = write_lnav_recording(
        tmp_path_factory.mktemp("vblank") / "blanked.sigmf-data", sats, fix.TOW0, 16.0, seed=11, blank=BLANK
    )
    return int(sats.sv[0][1:]), _receive(path, vector=vector_config(solution_rate_hz=5.0))


def assert_dropped_and_rejoined(result, gone: int, blank_start_s: float, blank_end_s: float, settled_s: float) -> None:
    """Vector channel ``gone``, blanked over ``[blank_start_s, blank_end_s)``: dropped by the
    loss-of-lock rule within the time the rule states, unused from then (and from the moment
    its C/N0 window holds noise only) until it is back, re-acquired by the aided search at
    the first round after the signal returns, used again after; the position error from
    ``settled_s`` on, in each phase, within four standard deviations of the filter's
    covariance (RMS over the phase)."""
    v, cfg = vector_config(), tracking_config()
    events = result.tracking.channels[gone].events
    lost = [t for t, text in events if text.startswith("lost: C/N0 estimate below")]
    found = [t for t, text in events if "re-acquired in the window predicted by the navigation solution" in text]
    # The estimate over cn0_window_ms is all noise cn0_window_ms after the blank starts, and is
    # evaluated every 20 ms (one bit: the tracker's detect_periods); the rule then needs loss_ms of it. Before loss_ms of
    # blank it cannot fire.
    assert len(lost) == 1, events
    assert blank_start_s + v.loss_ms * 1e-3 <= lost[0] <= blank_start_s + (cfg.cn0_window_ms + v.loss_ms + 30) * 1e-3
    # The aided search runs every reacquire_every_ms: the first one after the return finds it.
    assert len(found) == 1 and blank_end_s <= found[0] <= blank_end_s + cfg.reacquire_every_ms * 1e-3 + 0.05
    sol = result.vector
    t, used = np.asarray(sol.sample_time_s), np.asarray(sol.used)[:, gone - 1]
    assert not used[(t > min(lost[0], blank_start_s + cfg.cn0_window_ms * 1e-3)) & (t < found[0])].any()
    # Back in the update once its own C/N0 estimate (a window's worth) is over min_cn0_dbhz.
    assert used[t > found[0] + cfg.cn0_window_ms * 1e-3].all()
    err = np.linalg.norm(np.asarray(sol.state)[:, :3] - fix.STATION, axis=1)
    sigma_3d = np.sqrt(np.trace(np.asarray(sol.cov)[:, :3, :3], axis1=1, axis2=2))
    for lo, hi in ((settled_s, blank_start_s), (blank_start_s, found[0]), (found[0], t[-1] + 1)):
        m = (t >= lo) & (t < hi)
        assert m.sum() > 20
        assert np.sqrt(np.mean(err[m] ** 2)) < 4 * np.sqrt(np.mean(sigma_3d[m] ** 2)), (lo, hi)


@pytest.mark.slow
def test_a_blanked_vector_channel_is_dropped_and_reacquired_after_the_lnav_hand_over(blanked):
    gone, result = blanked
    assert result.vector.handover_s < BLANK[1] and gone in result.vector.prns
    assert_dropped_and_rejoined(result, gone, BLANK[1], BLANK[2], settled_s=result.vector.handover_s + 1.0)
    table = result.positions
    while_gone = (table.sample_time_s > BLANK[1] + 1.0) & (table.sample_time_s < BLANK[2])
    assert while_gone.sum() >= 5 and np.all(table.columns["n_sats"][while_gone] == 4)


@pytest.mark.slow
def test_a_rejoined_vector_channel_is_back_in_the_observables(blanked):
    """The blanked channel, re-acquired and closed again at a boundary that may be mid-bit,
    is dated from its replica's transmit time: in every epoch from a second after it is
    found to the end, its transmit time the generator's within half a chip; in none while
    it is gone."""
    gone, result = blanked
    events = result.tracking.channels[gone].events
    found = [t for t, text in events if "re-acquired in the window predicted by the navigation solution" in text]
    obs = result.observables
    j = list(obs.prn).index(gone)
    back = obs.sample_time_s > found[0] + 1.0
    assert back.sum() >= 5 * (16.0 - found[0] - 1.0) - 2
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    k = [int(s[1:]) for s in sats.sv].index(gone)
    t_sv = np.array([fix._satellite_time(sats, np.array(fix.TOW0 + t))[k] for t in obs.sample_time_s[back]])
    assert np.abs((obs.transmit_s[back, j] - t_sv) * C).max() < 0.5 * 293.05
    away = (obs.sample_time_s > BLANK[1] + 1.0) & (obs.sample_time_s < BLANK[2])
    assert away.any() and not np.isfinite(obs.pseudorange_m[away, j]).any()


@pytest.mark.slow
def test_the_lnav_hand_over_takes_the_navigation_files_klobuchar(faded, monkeypatch):
    """No page 18 in the file: given the navigation file's Klobuchar coefficients (as
    ``receive --ephemeris`` passes them), the hand-over fix and the loop's predicted ranges
    carry the ionospheric delay (1.5 m or more: the model's night-time 5 ns at the zenith)."""
    from gnssframework.navigation.rinex_nav_header import read_nav_file_info
    from gnssframework.receiver.navigation import vector_tracking

    trackers = []
    run = vector_tracking.VectorSampleTracker.run

    def keep(self, *args, **kwargs):
        trackers.append(self)
        return run(self, *args, **kwargs)

    monkeypatch.setattr(vector_tracking.VectorSampleTracker, "run", keep)
    iono = read_nav_file_info(fix.NAV).iono
    result = _receive(faded[0], vector=vector_config(solution_rate_hz=5.0), duration_s=FADE_S, iono_fallback=iono)
    assert result.vector.handover_s is not None and result.observables.iono_utc is None  # none decoded
    nav = trackers[0].closer.nav  # the vector navigator the hand-over started
    assert nav.iono == iono
    assert np.all(nav.iono_m >= 1.5) and np.all(nav.iono_m < 50.0)
