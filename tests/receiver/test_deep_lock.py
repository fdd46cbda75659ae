"""Deep integration keeps lock where scalar loops lose it (reference 002's claim), on a short
jerk pulse of the deep-integration scenario: a regime chosen so the claim can be checked, and a
control where it must not show (docs/experiments/deep-integration.md, "Where scalar loops lose
lock")."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.random_streams import name_key, run_streams
from gnssframework.experiments.scenarios import get_scenario

DEEP = {
    "channel_filter": {"name": "iq-filter", "params": {"estimator": "ukf", "adaptive": False, "output": "equivalent"}},
    "nav_filter": {
        "name": "ins-ekf",
        "params": {
            "carrier_filter": {"name": "kf-carrier-loop", "params": {"states": 2, "q": [0.0, 0.001], "r": 0.05}}
        },
    },
}
LOOSE_NO_FLL = {
    "channel_filter": {"name": "scalar", "params": {"fll_bandwidth_hz": 0.0}},
    "nav_filter": {"name": "ins-ekf", "params": {}},
}


def _run(jerk_g_s: float, candidate: dict, runs: int = 2):
    # A 20 g vertical pulse from 0.5 s; at 50 g/s it rises in 0.75 s, holds 0.3 s and falls by 2.3 s.
    sc = get_scenario(
        {
            "kind": "deep-integration",
            "profile": "jerk-pulse",
            "duration_s": 2.3,
            "settle_s": 0.3,
            "pulse_accel_g": 20.0,
            "pulse_jerk_g_s": jerk_g_s,
            "pulse_start_s": 0.5,
            "pulse_hold_s": 0.3,
        }
    )
    plugins = sc.build(candidate)
    return sc.run_batch(
        {"name": "45dBHz", "cn0_dbhz": 45.0}, plugins, runs, run_streams(5, name_key("45dBHz"), range(runs))
    ).metrics


@pytest.mark.slow
@pytest.mark.parametrize("jerk_g_s, scalar_loses_lock", [(50.0, True), (5.0, False)])
def test_scalar_pll_loses_lock_under_50_g_per_s_where_deep_keeps_it(jerk_g_s, scalar_loses_lock):
    scalar = _run(jerk_g_s, LOOSE_NO_FLL)
    if scalar_loses_lock:
        # 3rd-order PLL (15 Hz, no FLL assist) under 50 g/s: code/frequency lock lost, cycles slipped, every run.
        assert np.all(scalar["loss_of_lock_fraction"] > 0.05), scalar["loss_of_lock_fraction"]
        assert np.all(scalar["cycle_slip_rate"] > 1.0), scalar["cycle_slip_rate"]
        deep = _run(jerk_g_s, DEEP)
        assert np.all(deep["loss_of_lock_fraction"] == 0.0)
        assert np.all(deep["phase_lock_loss_fraction"] == 0.0) and np.all(deep["cycle_slip_rate"] == 0.0)
    else:  # the control: the same loop keeps every kind of lock under 5 g/s
        assert np.all(scalar["loss_of_lock_fraction"] == 0.0)
        assert np.all(scalar["cycle_slip_rate"] == 0.0)
