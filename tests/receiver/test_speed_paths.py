"""The harness loops evaluate the satellite orbits once for all epochs (issue 11).

Counting the orbit calls is what a per-epoch evaluation would break; results are
checked against an evaluation at each epoch's own time. Time is never asserted.
"""

from __future__ import annotations

import numpy as np

from test_deep_integration import _aided_setup, _OffsetNavigator


class _Counting:
    def __init__(self, fn):
        self.fn, self.times = fn, []

    def __call__(self, t):
        self.times.append(np.asarray(t, float).copy())
        return self.fn(t)


def test_deep_loop_evaluates_the_orbits_in_blocks_at_the_epoch_edges():
    from dataclasses import replace

    from gnssframework.receiver.deep.aided_tracking import run_aided_tracking
    from gnssframework.registry import create

    runs = 2
    truth, rx = _aided_setup(runs, 0.05)
    counted = _Counting(truth.sat_state)
    zero = np.zeros((runs, 3))

    def run(tr):
        nav = _OffsetNavigator(rx, zero, zero, np.zeros(runs), np.zeros(runs), (100.0, 0.0))
        channel = create("channel_filter", "iq-filter", adapter=None, estimator="ckf", output="equivalent")
        return run_aided_tracking(
            channel, nav, tr, np.random.default_rng(4), nco_interval_s=0.005, update_interval_s=0.01
        ), nav

    rec, nav = run(replace(truth, sat_state=counted))
    K = truth.epochs
    assert len(counted.times) == 1
    np.testing.assert_array_equal(counted.times[0], np.arange(K + 1) * truth.coherent_time_s)
    # The line of sight handed to the navigator at t_u is that of the orbit at t_u itself.
    for t_u, los in nav.updates:
        s = truth.sat_state(np.asarray(t_u))[0]
        e = (s - rx(t_u)[0][:, None]) / np.linalg.norm(s - rx(t_u)[0][:, None], axis=-1, keepdims=True)
        np.testing.assert_allclose(np.abs(np.einsum("rcj,rcj->rc", los, e)), 1.0, rtol=1e-12)
    assert rec.code_error_chips.shape == (K, runs, 6)


def test_vector_loop_evaluates_the_orbits_once_for_all_epochs():
    from dataclasses import replace

    from gnssframework.experiments import get_scenario
    from gnssframework.receiver.tracking.vector import run_vector_loop

    scen = get_scenario({"kind": "vector-tracking", "duration_s": 0.05, "channels": 4, "settle_s": 0.0})
    truth, x0, P0 = scen.truth(45.0, 2, np.random.default_rng(0))
    counted = _Counting(truth.sat_state)
    plugins = scen.build(
        {
            "channel_filter": {"name": "iq-filter", "params": {"estimator": "ckf"}},
            "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
        }
    )
    run_vector_loop(
        plugins["channel_filter"],
        plugins["nav_filter"],
        replace(truth, sat_state=counted),
        x0,
        P0,
        np.random.default_rng(1),
    )
    # Edges, mid-intervals, and the first NCO command: three calls whatever the epoch count.
    assert len(counted.times) == 3
    assert sorted(t.size for t in counted.times) == [1, truth.epochs, truth.epochs + 1]
