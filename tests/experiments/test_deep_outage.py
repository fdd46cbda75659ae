"""The deep-integration scenario's satellite outage (issue 42): its checks, its truth, and what loose and tight do with it."""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

from gnssframework import random_streams as draw
from gnssframework.errors import ConfigError
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.receiver.deep.loose import scalar_tracking, select_channels
from gnssframework.receiver.engine.sources import AnalyticSource
from gnssframework.registry import create
from gnssframework.signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0

BASE = {
    "kind": "deep-integration",
    "profile": "pull-up",
    "channels": 8,
    "clock": "ocxo",
    "loose_rate_window": "trailing",
    "loose_dll_correlation": "loop",
    "loose_gate_probability": 0.001,
}


def _scenario(**kw):
    return get_scenario({**BASE, **kw})


@pytest.mark.parametrize(
    "case, field, words",
    [
        ({"outage_channels": 8}, "outage_channels", "leave at least 1"),
        ({"outage_channels": 12}, "outage_channels", "leave at least 1"),
        ({"outage_channels": 5, "outage_start_s": 20.0}, "outage_start_s", "below duration_s"),
        ({"outage_channels": 5, "outage_start_s": 8.0, "outage_end_s": 8.0}, "outage_end_s", "after outage_start_s"),
        ({"outage_channels": 5, "outage_start_s": 8.0, "outage_end_s": 6.0}, "outage_end_s", "after outage_start_s"),
        ({"outage_channels": 5, "outage_start_s": 8.0, "outage_end_s": 21.0}, "outage_end_s", "at most duration_s"),
        ({"outage_start_s": 8.0}, "outage_start_s", "without an outage"),
        ({"outage_end_s": 9.0}, "outage_end_s", "without an outage"),
        ({"outage_channels": 0}, "outage_channels", ""),
    ],
)
def test_outage_fields_are_checked_with_their_name(case, field, words):
    sc = _scenario(duration_s=20.0)
    with pytest.raises(ConfigError) as exc:
        sc.check_case({"name": "x", "cn0_dbhz": 45.0, **case}, "cases[1]")
    assert exc.value.field == f"cases[1].{field}"
    assert words in str(exc.value)
    assert "\n" not in str(exc.value)


def test_a_valid_outage_passes_and_leaves_one_channel():
    sc = _scenario(duration_s=20.0)
    sc.check_case({"cn0_dbhz": 45.0, "outage_channels": 7, "outage_start_s": 12.0, "outage_end_s": 20.0}, "cases[0]")
    sc.check_case({"cn0_dbhz": 45.0, "outage_channels": 5, "outage_start_s": 12.0}, "cases[0]")  # to the end


def _elevations_deg(sc):
    """Each channel's elevation at the start, from pymap3d (not the scenario's own function)."""
    p = sc.params
    s, _, _ = sc.satellites().state(np.asarray(p.start_time_s))
    _, el, _ = pymap3d.ecef2aer(s[:, 0], s[:, 1], s[:, 2], p.lat_deg, p.lon_deg, p.height_m)
    return np.asarray(el)


def test_the_lowest_channels_lose_their_signal_in_the_window_only():
    sc = _scenario(duration_s=0.6, settle_s=0.1)
    runs, T = 2, sc.params.coherent_time_s
    truth = sc._truth(sc.flight(), 45.0, runs, draw.run_streams(5, (), range(runs)), (3, 0.2, 0.45))
    g = truth.signal_gain
    assert g.shape == (600, runs, 8)
    low3 = np.argsort(_elevations_deg(sc))[:3]
    blocked = np.zeros(8, bool)
    blocked[low3] = True
    t_mid = (np.arange(600) + 0.5) * T
    inside = (t_mid >= 0.2) & (t_mid < 0.45)
    expected = np.where(inside[:, None, None] & blocked[None, None, :], 0.0, 1.0)
    np.testing.assert_array_equal(g, np.broadcast_to(expected, g.shape))
    # The correlators the harnesses draw from that truth: in the outage a blocked channel's prompt holds
    # noise only (unit-variance I and Q: E|P|^2 = 2); the others keep A^2 = 2 c T = 63 at 45 dB-Hz.
    source = AnalyticSource(
        CorrelatorSimulator(T, 1.0),
        np.broadcast_to(amplitude_from_cn0(45.0, T), (runs, 8)),
        np.random.default_rng(1),
        signal_gain=g,
    )

    class _Zero:  # the replica exactly on the truth
        code_chips = phase_rad = freq_hz = np.zeros((runs, 8))

    ks = np.nonzero(inside)[0]
    power = np.stack([np.abs(source.correlate(None, k, _Zero).prompt) ** 2 for k in ks])  # (k, runs, ch)
    n = power[..., blocked].size  # 250 x 2 x 3 = 1500 draws; |P|^2 of pure noise is exponential, sd 2
    assert abs(power[..., blocked].mean() - 2.0) < 5 * 2.0 / np.sqrt(n)
    assert power[..., ~blocked].mean() > 50.0


def test_outage_leaves_the_other_channels_random_numbers_alone():
    # Scalar loops with and without the outage, the same streams: an unblocked channel's errors are the
    # same to the last bit (its loop never sees the others), and a blocked one's until the outage.
    K, runs, T = 800, 2, 0.001
    t = np.arange(K + 1)[:, None, None] * T
    rho = 2.2e7 + np.arange(8) * 1e5 + (-300.0 + 40.0 * np.arange(8)) * t + np.zeros((1, runs, 1))
    blocked = np.zeros((runs, 8), bool)
    blocked[:, [1, 4, 6]] = True
    t_mid = (np.arange(K) + 0.5) * T
    gain = np.where(((t_mid >= 0.3) & (t_mid < 0.6))[:, None, None] & blocked, 0.0, 1.0)
    loop = create("channel_filter", "scalar", pll_bandwidth_hz=20.7, dll_bandwidth_hz=0.21)
    a = scalar_tracking(loop, rho, 45.0, T, np.random.default_rng(9))
    b = scalar_tracking(loop, rho, 45.0, T, np.random.default_rng(9), amplitude_scale=gain)
    np.testing.assert_array_equal(a.code_error_chips[:, ~blocked], b.code_error_chips[:, ~blocked])
    np.testing.assert_array_equal(a.freq_error_hz[:, ~blocked], b.freq_error_hz[:, ~blocked])
    before = t_mid < 0.3
    np.testing.assert_array_equal(a.freq_error_hz[before][:, blocked], b.freq_error_hz[before][:, blocked])
    # and the blocked loops do see it: noise only drives their frequency away
    assert np.all(np.any(a.freq_error_hz[~before][:, blocked] != b.freq_error_hz[~before][:, blocked], axis=0))


def test_select_channels_keeps_each_runs_usable_channels_in_order():
    usable = np.array([[True, False, True, True], [False, True, True, True]])
    x = np.arange(8.0).reshape(2, 4)
    s = np.arange(24.0).reshape(2, 4, 3)
    xs, ss = select_channels(usable, x, s)
    np.testing.assert_array_equal(xs, [[0.0, 2.0, 3.0], [5.0, 6.0, 7.0]])
    np.testing.assert_array_equal(ss[1], s[1, 1:])
    np.testing.assert_array_equal(ss[0], s[0, [0, 2, 3]])
    with pytest.raises(ConfigError, match="same number of channels"):
        select_channels(np.array([[True, True], [True, False]]), x[:, :2])


@pytest.mark.slow
def test_loose_stops_updating_below_four_channels_and_tight_goes_on_with_three(monkeypatch):
    # 2 s of the level flight, updates at 0.1, ..., 2.0 s (the first is pull-in); 5 of 8 channels blocked
    # from 1.0 s. Trailing rate windows end at the update; its code reading reaches one interval (1 ms)
    # past it, so the update at 1.0 s already sees the outage: loose may fix at 0.2-0.9 s (8 updates)
    # and never after, tight updates at 0.2-2.0 s (19), on 3 channels from 1.0 s (11).
    from gnssframework.experiments.scenarios import deep_integration_runs as runs_mod

    calls = {"loose": [], "tight": []}
    loose_update, tight_update = runs_mod.loose_update, runs_mod.tight_update

    def spy_loose(ins, ekf, fp, fv, fcov, gate, **geometry):
        calls["loose"].append(fp.shape)
        return loose_update(ins, ekf, fp, fv, fcov, gate, **geometry)

    def spy_tight(ins, ekf, m_rho, *rest):
        calls["tight"].append(m_rho.shape)
        dx = tight_update(ins, ekf, m_rho, *rest)
        calls.setdefault("tight_dx", []).append(np.linalg.norm(dx[:, 6:9], axis=-1))
        return dx

    monkeypatch.setattr(runs_mod, "loose_update", spy_loose)
    monkeypatch.setattr(runs_mod, "tight_update", spy_tight)
    sc = _scenario(duration_s=2.0, settle_s=0.5)
    case = {"name": "outage", "cn0_dbhz": 45.0, "outage_channels": 5, "outage_start_s": 1.0}
    sc.check_case(case, "cases[0]")
    for coupling in ("loose", "tight"):
        plugins = {
            "channel_filter": create("channel_filter", "scalar", pll_bandwidth_hz=20.7, dll_bandwidth_hz=0.21),
            "nav_filter": create("nav_filter", "ins-ekf", coupling=coupling),
        }
        res = sc.run_batch(case, plugins, 2, np.random.default_rng(2222))
        assert np.all(np.isfinite(np.asarray(res.metrics["horizontal_position_error_rmse"])))
    assert calls["loose"] == [(2, 3)] * 8  # fixes (runs, 3) before the outage only
    assert calls["tight"] == [(2, 8)] * 8 + [(2, 3)] * 11
    # tight's 3-channel updates do move the position (not a no-op on an empty measurement)
    assert np.all(np.stack(calls["tight_dx"][8:]) > 0)


def test_pv_fix_refuses_three_channels_whatever_the_rounding():
    # With 3 channels the 4x4 normal matrix (position and clock) is singular, but LAPACK's solve only
    # notices an exactly zero pivot: on random geometries it returned corrections of ~1e15 m in about
    # 80 % of them. The fix refuses by the count instead.
    from gnssframework.errors import NumericalError
    from gnssframework.receiver.deep.loose import pv_fix

    rng = np.random.default_rng(0)
    r = np.array(pymap3d.geodetic2ecef(34.23, 108.3576, 590.6))
    for _ in range(20):
        u = rng.normal(size=(3, 3))
        u[:, 2] = np.abs(u[:, 2])  # above the horizon, roughly
        s = r + 2.2e7 * u / np.linalg.norm(u, axis=1)[:, None]
        rho = np.linalg.norm(s - r, axis=1)[None] + rng.normal(size=(1, 3))
        with pytest.raises(NumericalError, match="fewer than 4 channels"):
            pv_fix(
                rho, np.zeros((1, 3)), np.ones((1, 3)), np.ones((1, 3)), s, np.zeros((3, 3)), r[None], np.zeros((1, 3))
            )


# --- deep and vector drop the blocked channels too ----------------------------------------


def test_exclude_channels_leaves_a_differenced_update_blind_to_them():
    # Whatever a left-out channel's residuals say, the Kalman correction of the differenced
    # update (measurements.integration_measurement, gain P H^T S^-1) is the same to 1e-9 of
    # its size; the reference of the differences is the highest C/N0 among the used channels.
    from gnssframework.receiver.deep.ins_navigator import REJECTED_FIX_VAR, exclude_channels
    from gnssframework.receiver.deep.measurements import integration_measurement, reference_channel

    rng = np.random.default_rng(3)
    runs, ch = 4, 6
    usable = np.ones((runs, ch), bool)
    usable[:, [0, 2]] = False  # channel 0, the highest C/N0, is left out
    cn0 = np.array([48.0, 45.0, 47.0, 40.0, 44.0, 46.0])
    los = rng.normal(size=(runs, ch, 3))
    los /= np.linalg.norm(los, axis=-1, keepdims=True)
    cov = np.broadcast_to(np.diag([4.0, 0.01]), (runs, ch, 2, 2)).copy()
    A = rng.normal(size=(runs, 15, 15))
    P = A @ np.swapaxes(A, -1, -2) + 15 * np.eye(15)

    def correction(residual):
        z_res, c, n0 = exclude_channels(usable, residual, cov, cn0)
        ref = reference_channel(n0)
        z, H, R = integration_measurement(z_res, c, los, ref)
        S = H @ P @ np.swapaxes(H, -1, -2) + R
        return P @ np.swapaxes(H, -1, -2) @ np.linalg.solve(S, z[..., None]), ref

    residual = rng.normal(size=(runs, ch, 2))
    garbage = residual.copy()
    garbage[:, [0, 2]] = rng.normal(scale=1e3, size=(runs, 2, 2))
    dx, ref = correction(residual)
    dx_g, _ = correction(garbage)
    assert np.all(ref == 5)  # 46 dB-Hz: the highest among the used channels
    np.testing.assert_allclose(dx_g, dx, rtol=0, atol=1e-9 * np.abs(dx).max())
    _, c, n0 = exclude_channels(usable, residual, cov, cn0)
    assert np.all(np.isneginf(n0[:, [0, 2]])) and np.all(c[:, 0, 0, 0] == 4.0 + REJECTED_FIX_VAR)
    # A run that keeps no channel (a lock detector lost them all): its correction is nil, to
    # 1e-9 of a used update's, while the other runs' are as before.
    usable[1] = False
    dx_none, _ = correction(residual)
    assert np.abs(dx_none[1]).max() < 1e-9 * np.abs(dx).max()
    np.testing.assert_allclose(np.delete(dx_none, 1, 0), np.delete(dx, 1, 0), rtol=0, atol=1e-9 * np.abs(dx).max())


def test_left_out_takes_a_refused_run_as_all_its_channels():
    # tight_update's gate refuses whole runs ((runs, 1)), exclude_channels single channels
    # ((runs, ch)): one rule, the same numbers; what is not left out is untouched.
    from gnssframework.receiver.deep.ins_navigator import REJECTED_FIX_VAR, left_out

    rng = np.random.default_rng(5)
    z = rng.normal(size=(3, 4, 2))
    cov = np.broadcast_to(np.diag([4.0, 0.01]), (3, 4, 2, 2))
    refused = np.array([False, True, False])
    z_run, cov_run = left_out(z, cov, refused[:, None])
    z_ch, cov_ch = left_out(z, cov, np.repeat(refused[:, None], 4, axis=1))
    np.testing.assert_array_equal(z_run, z_ch)
    np.testing.assert_array_equal(cov_run, cov_ch)
    assert np.all(z_run[1] == 0) and np.array_equal(z_run[[0, 2]], z[[0, 2]])
    np.testing.assert_array_equal(cov_run[1], cov[1] + REJECTED_FIX_VAR * np.eye(2))
    np.testing.assert_array_equal(cov_run[[0, 2]], cov[[0, 2]])


def test_scheduled_exclusion_counts_the_intervals_from_its_reset():
    from gnssframework.receiver.engine.channel_monitor import ScheduledExclusion

    blocked = np.array([[True, False, False], [False, False, True]])
    monitor = ScheduledExclusion(lambda k: ~(blocked & (k >= 2)))
    monitor.reset((2, 3))
    seen = [monitor.screen(np.zeros((2, 3)), None, None, None).copy() for _ in range(4)]
    assert not seen[0].any() and not seen[1].any()
    np.testing.assert_array_equal(seen[2], blocked)
    np.testing.assert_array_equal(monitor.excluded, blocked)
    monitor.reset((2, 3))
    assert monitor.interval == 0 and not monitor.excluded.any()


def _candidate(name: str) -> dict:
    import pathlib
    import tomllib

    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "deep_integration_ci.toml"
    spec = {c["name"]: c for c in tomllib.loads(example.read_text())["candidates"]}[name]
    return {k: create(k, spec[k]["name"], **spec[k].get("params", {})) for k in ("channel_filter", "nav_filter")}


def test_deep_leaves_the_blocked_channels_out_from_the_first_update_in_the_outage(monkeypatch):
    # 2 s of the level flight, 5 of 8 channels blocked from 1.0 s, updates every 0.1 s: the
    # update at 1.0 s holds the prefilters' outputs of 0.9-1.0 s, still before the outage; from
    # the update at 1.1 s on, the blocked channels go into the filter with residual 0 and
    # variance raised by REJECTED_FIX_VAR, never as the differences' reference.
    from gnssframework.receiver.deep import ins_navigator

    seen = []
    exclude = ins_navigator.exclude_channels

    def spy(usable, residual, cov, cn0):
        out = exclude(usable, residual, cov, cn0)
        seen.append((usable.copy(), out))
        return out

    monkeypatch.setattr(ins_navigator, "exclude_channels", spy)
    sc = _scenario(duration_s=2.0, settle_s=0.5)
    case = {"name": "outage", "cn0_dbhz": 45.0, "outage_channels": 5, "outage_start_s": 1.0}
    sc.check_case(case, "cases[0]")
    res = sc.run_batch(case, _candidate("deep"), 2, np.random.default_rng(2222))
    assert np.all(np.isfinite(np.asarray(res.metrics["horizontal_velocity_error_rmse"])))
    truth = sc._truth(sc.flight(), 45.0, 2, draw.as_run_streams(np.random.default_rng(2222), 2), (5, 1.0, None))
    blocked = np.any(truth.signal_gain == 0, axis=0)
    assert blocked.sum(axis=-1).tolist() == [5, 5]
    used = [u for u, _ in seen]
    before = [u for u in used if u.all()]
    after = used[len(before) :]
    assert len(after) == 10 and all(np.array_equal(u, ~blocked) for u in after)  # updates at 1.1-2.0 s
    for _, (residual, cov, cn0) in seen[len(before) :]:
        assert (
            np.all(residual[blocked] == 0)
            and np.all(cov[blocked][:, 0, 0] > 1e11)
            and np.all(np.isneginf(cn0[blocked]))
        )


@pytest.mark.slow
def test_vector_loops_that_drop_the_blocked_channels_do_not_follow_their_noise(monkeypatch):
    # The tuned vector loop of deep_integration_ci on 3 s of the level flight, 5 of 8 channels
    # blocked from 1.5 s: with the blocked channels left out of its navigation update it keeps
    # its horizontal velocity error at a few tenths of a m/s; with them in (their screen made a
    # no-op), it follows their noise (measured 0.66-0.82 against 1.7-17.8 m/s on 3 runs).
    from gnssframework.receiver.engine.channel_monitor import ScheduledExclusion

    sc = _scenario(duration_s=3.0, settle_s=1.5)
    case = {"name": "outage", "cn0_dbhz": 45.0, "outage_channels": 5, "outage_start_s": 1.5}
    sc.check_case(case, "cases[0]")
    errors = {}
    for dropped in (True, False):
        if not dropped:

            def keep_all(self, innovation_m, *rest):
                self.interval += 1
                self.excluded = np.zeros(np.shape(innovation_m), bool)
                return self.excluded

            monkeypatch.setattr(ScheduledExclusion, "screen", keep_all)
        res = sc.run_batch(case, _candidate("vector"), 3, np.random.default_rng(7))
        errors[dropped] = np.asarray(res.metrics["horizontal_velocity_error_rmse"])
    assert np.all(errors[True] < 1.0)
    assert np.mean(errors[True]) < 0.5 * np.mean(errors[False])
