"""The vector loop's channel fault monitor (`receiver.engine.channel_monitor`).

The test statistic against its chi-square law (Monte Carlo, binomial interval), the
consecutive-epoch logic against a hand-traced sequence, and a short vector-tracking run
with a 60 m code step on one channel: the monitor excludes that channel (only it) within
its ``consecutive`` intervals and the position stays at its fault-free error, while the
same loop without the monitor is pulled by tens of metres.
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
    scen = get_scenario({"kind": "vector-tracking", "duration_s": 3.0, "channels": 8, "settle_s": 0.5,
                         "steady_state_s": 2.0, "pcrb": False})
    case = {"cn0_dbhz": 45.0, "fault_channel": 0, "fault_start_s": 1.0, "fault_step_m": 60.0}
    scen.check_case(case, "cases[0]")
    components = {"channel_filter": {"name": "discriminator", "params": {"code_discriminator": "eml-envelope"}},
                  "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 1e-5}}}
    out = {}
    for name, options in (("none", None), ("monitor", {"channel_monitor": {"false_alarm": 1e-3,
                                                                           "consecutive": 3}})):
        plugins = scen.build(components, options)
        out[name] = scen.run_batch(case, plugins, 2, draw.run_streams(43, (0,), range(2)))
    return out


def test_the_monitor_cuts_off_a_faulty_channel_before_it_pulls_the_solution(fault_runs):
    none, monitor = fault_runs["none"], fault_runs["monitor"]
    # Excluded from 1.03 s to 3 s of the window from 0.5 s: (3 - 1.03) / 2.5 channels on average.
    np.testing.assert_allclose(monitor.metrics["excluded_channels"], (3.0 - 1.03) / 2.5, atol=0.01)
    assert np.all(monitor.metrics["position_steady_error_rmse"] < 3.0)
    assert np.all(none.metrics["position_steady_error_rmse"] > 15.0)


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
