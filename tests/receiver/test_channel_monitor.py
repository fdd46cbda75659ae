"""The vector loop's channel fault monitor (`receiver.engine.channel_monitor`).

The test statistic against its chi-square law (Monte Carlo, binomial interval), the
consecutive-epoch logic against a hand-traced sequence, and a short vector-tracking run
with a 60 m code step on one channel: the monitor excludes that channel (only it) within
its ``consecutive`` intervals and the position stays at its fault-free error, while the
same loop without the monitor is pulled by tens of metres; the epoch of the exclusion
against the rule stated on the integrity page, for several ``consecutive`` and step times.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom

from gnssframework.errors import ConfigError
from gnssframework.experiments import get_scenario
from gnssframework import random_streams as draw
from gnssframework.receiver.engine.channel_monitor import ChannelMonitor


def _geometry(rng, runs, ch):
    e = rng.standard_normal((runs, ch, 3))
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    L = rng.standard_normal((runs, 8, 8)) * 0.5
    P = L @ np.swapaxes(L, -1, -2) + np.eye(8)
    return e, P


def test_a_healthy_channel_is_flagged_with_the_stated_probability():
    rng = np.random.default_rng(0)
    runs, ch, p_fa = 4000, 8, 1e-2
    e, P = _geometry(rng, runs, ch)
    R = rng.uniform(1.0, 25.0, (runs, ch))
    h = np.concatenate([-e, np.zeros((runs, ch, 3)), np.ones((runs, ch, 1)), np.zeros((runs, ch, 1))], axis=-1)
    s = R + np.einsum("rci,rij,rcj->rc", h, P, h)  # the innovation variance, written out
    nu = rng.standard_normal((runs, ch)) * np.sqrt(s)
    monitor = ChannelMonitor(false_alarm=p_fa, consecutive=1)
    monitor.reset((runs, ch))
    excluded = monitor.screen(nu, R, e, P)
    lo, hi = binom.interval(1 - 1e-4, runs * ch, p_fa)
    assert lo <= excluded.sum() <= hi


def test_consecutive_failures_exclude_and_consecutive_passes_readmit():
    monitor = ChannelMonitor(false_alarm=1e-3, consecutive=3, readmit=2)
    monitor.reset((1, 2))
    e, P = np.array([[1.0, 0, 0], [0, 1.0, 0]]), np.zeros((8, 8))
    big, small = 10.0, 0.1  # innovations in sigmas (R = 1, P = 0)
    sequence = [big, big, small, big, big, big, small, big, small, small]
    expected = [0, 0, 0, 0, 0, 1, 1, 1, 1, 0]  # out after 3 in a row, back after 2 clean ones
    got = [bool(monitor.screen(np.array([[x, 0.0]]), np.ones((1, 2)), e, P)[0, 0]) for x in sequence]
    assert got == [bool(v) for v in expected]
    assert not monitor.excluded[0, 1]
    with pytest.raises(ConfigError, match="false_alarm"):
        ChannelMonitor(false_alarm=1.0)
    with pytest.raises(ConfigError, match="consecutive"):
        ChannelMonitor(consecutive=0)


@pytest.fixture(scope="module")
def fault_runs():
    scen = get_scenario(
        {
            "kind": "vector-tracking",
            "duration_s": 3.0,
            "channels": 8,
            "settle_s": 0.5,
            "steady_state_s": 2.0,
            "pcrb": False,
        }
    )
    case = {"cn0_dbhz": 45.0, "fault_channel": 0, "fault_start_s": 1.0, "fault_step_m": 60.0}
    scen.check_case(case, "cases[0]")
    components = {
        "channel_filter": {"name": "discriminator", "params": {"code_discriminator": "eml-envelope"}},
        "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 1e-5}},
    }
    out = {}
    for name, options in (("none", None), ("monitor", {"channel_monitor": {"false_alarm": 1e-3, "consecutive": 3}})):
        plugins = scen.build(components, options)
        out[name] = scen.run_batch(case, plugins, 2, draw.run_streams(43, (0,), range(2)))
    return out


def test_the_monitor_cuts_off_a_faulty_channel_before_it_pulls_the_solution(fault_runs):
    none, monitor = fault_runs["none"], fault_runs["monitor"]
    # Excluded from the update at 1.015 s or 1.025 s (see the delay test below: the interval
    # ending at the step sees half of it, flagged or not) to 3 s, of the window from 0.5 s;
    # one epoch (0.01 s) of slack for the window's edge.
    lo, hi = (3.0 - 1.025 - 0.01) / 2.5, (3.0 - 1.015 + 0.01) / 2.5
    assert np.all((lo <= monitor.metrics["excluded_channels"]) & (monitor.metrics["excluded_channels"] <= hi))
    assert np.all(monitor.metrics["position_steady_error_rmse"] < 3.0)
    assert np.all(none.metrics["position_steady_error_rmse"] > 15.0)


@pytest.mark.parametrize("consecutive", [2, 3, 5])
@pytest.mark.parametrize("start_s", [1.0, 1.005])
def test_a_step_is_excluded_at_the_update_of_its_consecutive_th_flagged_interval(consecutive, start_s):
    """The detection delay of docs/estimators/integrity.md ("Vector tracking: a faulty channel").

    The truth's code range is sampled at the interval edges and the correlator model is linear
    between them, so a step from ``start_s`` shows as half the step in the interval ending at
    the first edge at or after it (index j = ceil(start_s / T) - 1), the whole step after. A
    150 m step (75 m at half) fails the test in every interval from j; the monitor leaves the
    channel out of the update of interval j + consecutive - 1 (the flagged one that completes
    the count), whose epoch is its mid-time (j + consecutive - 1/2) T: 1.5 T after a step on an
    edge with consecutive = 3, 2 T after one mid-interval.
    """
    T, runs = 0.01, 3
    scen = get_scenario(
        {
            "kind": "vector-tracking",
            "duration_s": 1.2,
            "channels": 8,
            "settle_s": 0.5,
            "steady_state_s": 0.6,
            "pcrb": False,
            "coherent_time_s": T,
        }
    )
    case = {"cn0_dbhz": 45.0, "fault_channel": 0, "fault_start_s": start_s, "fault_step_m": 150.0}
    components = {
        "channel_filter": {"name": "discriminator", "params": {"code_discriminator": "eml-envelope"}},
        "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 1e-5}},
    }
    plugins = scen.build(components, {"channel_monitor": {"false_alarm": 1e-3, "consecutive": consecutive}})
    _, rec = scen.vector_series(case, plugins, runs, draw.run_streams(44, (0,), range(runs)))
    excluded, t = rec.extra["excluded"], rec.time_s  # (epochs, runs, channels), mid-interval times
    j = int(np.ceil(start_s / T - 1e-9)) - 1
    out_from = (j + consecutive - 0.5) * T
    after = t > out_from - T / 2
    assert not excluded[~after].any()  # nothing before (no false alarm in 1 s at P_fa 1e-3 per 3 tests)
    assert excluded[after][..., 0].all()  # the faulty channel from that epoch to the end
    assert not excluded[after][..., 1:].any()  # and only it
    np.testing.assert_allclose(t[after][0], out_from, atol=1e-9)


def test_fault_settings_are_checked():
    scen = get_scenario({"kind": "vector-tracking", "duration_s": 3.0, "channels": 8, "pcrb": False})
    with pytest.raises(ConfigError, match=r"cases\[1\]\.fault_step_m"):
        scen.check_case({"cn0_dbhz": 45.0, "fault_step_m": 10.0}, "cases[1]")
    with pytest.raises(ConfigError, match=r"cases\[1\]\.fault_channel"):
        scen.check_case({"cn0_dbhz": 45.0, "fault_channel": 8, "fault_step_m": 10.0}, "cases[1]")
    with pytest.raises(ConfigError, match=r"fault_step_m"):
        scen.check_case({"cn0_dbhz": 45.0, "fault_channel": 2}, "cases[1]")
    with pytest.raises(ConfigError, match=r"scenario_options\.channel_monitor"):
        scen.candidate_options({"channel_monitor": {"consecutive": 0}}, "candidates[0]")
