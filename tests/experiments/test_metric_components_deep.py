"""The deep-integration scenario's metrics as components (metric_components' issue-12 section),
against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.experiments.metric_components import PostSettleMax, evaluate, units
from gnssframework.experiments.scenarios import deep_integration


class _Scen:
    kind = "hand"

    class params:  # noqa: N801 - stands in for a scenario's params
        settle_s = 1.0


T3 = np.array([0.0, 1.0, 2.0])


def test_post_settle_max_against_hand_values():
    e = np.array([[9.0, -1.0], [-4.0, 1.0], [0.0, -2.0]])
    assert PostSettleMax("m", "m", of="e").compute({"e": e}, None, None).value.tolist() == [9.0, 2.0]
    late = PostSettleMax("m", "m", of="e", settle="settle_s").compute({"e": e}, T3, _Scen)
    assert late.value.tolist() == [4.0, 2.0]  # the 9 at t = 0 is before settling
    assert late.series.tolist() == np.abs(e).tolist()
    v = np.zeros((3, 1, 2))
    v[1, 0] = [3.0, 4.0]  # a vector error: its norm, 5
    assert PostSettleMax("m", "m", of="v").compute({"v": v}, None, None).value.tolist() == [5.0]
    nan = np.array([[np.nan], [np.nan], [np.nan]])  # no estimate (vector tracking's attitude)
    assert np.isnan(PostSettleMax("m", "deg", of="a").compute({"a": nan}, None, None).value[0])


def test_deep_integration_metrics_are_declared_once_and_read_declared_series():
    comps = deep_integration.METRICS
    assert deep_integration.DeepIntegrationScenario.metrics == units(comps)
    assert len({c.name for c in comps}) == len(comps) == 17
    outputs = deep_integration.DeepIntegrationScenario.outputs
    assert all(c.of in outputs for c in comps)
    assert all(c.settle == "settle_s" for c in comps)


def test_deep_integration_metrics_from_hand_series():
    """Three updates at 0, 1, 2 s, two runs, settle at 1 s: every metric by hand."""
    runs = 2
    hp = np.array([[8.0, 1.0], [3.0, 2.0], [4.0, 2.0]])
    series = {e: hp * (i + 1) for i, e in enumerate(deep_integration.ERRORS)}
    series["attitude_error"] = np.full((3, runs), np.nan)  # vector tracking: no attitude
    series["code_tracking_error"] = np.array([[1.0, 0.0], [0.1, 0.3], [0.1, 0.4]])
    series["freq_tracking_error"] = np.array([[50.0, 0.0], [6.0, 1.0], [8.0, 1.0]])
    for name in ("phase_tracking_error", "phase_unlocked", "cycle_slips"):
        series[name] = np.full((3, runs), np.nan)  # no carrier loop
    series["loss_of_lock"] = np.array([[1.0, 0.0], [0.5, 0.0], [0.0, 0.25]])
    series["nees_pv"] = np.array([[100.0, 6.0], [5.0, 7.0], [7.0, 5.0]])
    out = evaluate(deep_integration.METRICS, series, T3, _Scen)
    m = out.metrics
    assert m["horizontal_position_error_rmse"] == pytest.approx([np.sqrt(12.5), 2.0])
    assert m["height_error_max"].tolist() == [8.0, 4.0]
    assert np.isnan(m["attitude_error_rmse"]).all() and np.isnan(m["attitude_error_max"]).all()
    assert m["code_tracking_error_rmse"] == pytest.approx([0.1, np.sqrt(0.125)])
    assert m["freq_tracking_error_rmse"] == pytest.approx([np.sqrt(50.0), 1.0])
    assert np.isnan(m["phase_tracking_error_rmse"]).all()
    assert m["loss_of_lock_fraction"].tolist() == [0.25, 0.125]
    assert m["nees"].tolist() == [6.0, 6.0]
    assert np.isnan(m["phase_lock_loss_fraction"]).all() and np.isnan(m["cycle_slip_rate"]).all()


def test_phase_lock_series_against_a_hand_built_slip():
    """One run, two channels, two updates of 4 epochs (update interval 0.004 s). Channel 0
    drifts by a whole half cycle through the second update (a slip); channel 1 sits at
    0.1 rad, then at pi - 0.1 (the other Costas lock point: no slip, error -0.1)."""
    ch0 = np.array([0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.6, 2.2])
    ch1 = np.array([0.1] * 4 + [np.pi - 0.1] * 4)
    phase = np.stack([ch0, ch1], -1)[:, None, :]  # (8, 1, 2)
    s = deep_integration.phase_lock_series(phase, 4, 0.004)
    # Update 1: all errors 0 or 0.1. Update 2, channel 0 modulo pi (into +-pi/2): 0.5, 1.0, 1.6 - pi, 2.2 - pi.
    e2 = np.array([0.5, 1.0, 1.6 - np.pi, 2.2 - np.pi, -0.1, -0.1, -0.1, -0.1])
    assert s["phase_tracking_error"][:, 0] == pytest.approx([np.sqrt(4 * 0.01 / 8), np.sqrt(np.mean(e2**2))])
    # Beyond pi/4 in update 2: 1.0, |1.6 - pi| = 1.54 and |2.2 - pi| = 0.94.
    assert s["phase_unlocked"][:, 0].tolist() == [0.0, 3 / 8]
    # One half-cycle slip (channel 0: its nearest multiple of pi goes from 0 to pi between 1.0 and 1.6 rad)
    # in update 2, over 2 channels and 0.004 s.
    assert s["cycle_slips"][:, 0].tolist() == [0.0, 1 / 2 / 0.004]
