"""A scenario's own metrics as components (experiments.metric_components), against hand values."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.experiments import get_scenario
from gnssframework.experiments.metric_components import ConvergenceEpoch, MeanAbs, Rmse, evaluate, units
from gnssframework.experiments.scenarios import multipath


def _hand_convergence(err: np.ndarray, window: int, factor: float) -> float:
    """The definition written out epoch by epoch (one run): the first epoch after which the
    RMS of the last `window` errors (zeros before the start) stays below factor x the RMS
    of the second half."""
    K = len(err)
    bound = factor * np.sqrt(np.mean(err[K // 2:] ** 2))
    last_above = -1
    for k in range(K):
        lo = max(0, k - window + 1)
        if np.sqrt(np.sum(err[lo:k + 1] ** 2) / window) > bound:
            last_above = k
    return float(last_above + 1)


def test_rmse_and_mean_abs_against_hand_values_scalar_vector_and_after_settling():
    e = np.array([[3.0, -1.0], [-4.0, 1.0], [0.0, 2.0]])
    assert Rmse("r", "m", of="e").compute({"e": e}, None, None).value == pytest.approx([np.sqrt(25 / 3), np.sqrt(2)])
    assert MeanAbs("a", "m", of="e").compute({"e": e}, None, None).value == pytest.approx([7 / 3, 4 / 3])
    v = np.zeros((2, 1, 2))
    v[0, 0] = [3.0, 4.0]  # |v| = 5, then 0
    r = Rmse("r", "m", of="v").compute({"v": v}, None, None)
    assert r.value == pytest.approx([np.sqrt(12.5)]) and r.series[:, 0].tolist() == [5.0, 0.0]

    class Scen:
        kind = "hand"

        class params:  # noqa: N801 - stands in for a scenario's params
            settle_s = 1.0

    t = np.array([0.0, 1.0, 2.0])
    late = Rmse("r", "m", of="e", settle="settle_s").compute({"e": e}, t, Scen)
    assert late.value == pytest.approx([np.sqrt(8.0), np.sqrt(2.5)])
    assert late.series.shape == (3, 2)  # the series keeps every epoch; only the value settles


def test_multipaths_convergence_component_on_a_hand_built_sequence():
    # err = 10 (k < 20), 3 (20 <= k < 40), 1 afterwards; window 10; second-half RMS 1, bound 2:
    # at k = 40 + j the window holds 9 - j threes and 1 + j ones, mean square (82 - 8j)/10 <= 4
    # first at j = 6, so the last epoch above is 45 and the run converges at 46. A 5x bound
    # would give 28. This goes through the component the scenario declares, so a change of
    # its factor or window is caught, not only one of the function's default.
    err = np.concatenate([np.full(20, 10.0), np.full(20, 3.0), np.ones(60)])[:, None]
    scen = get_scenario({"kind": "multipath", "epochs": 100, "convergence_window": 10})
    comp = next(m for m in multipath.METRICS if m.name == "convergence_epoch")
    out = comp.compute({"horizontal_error_m": err}, None, scen)
    assert out.value.tolist() == [46.0] == [_hand_convergence(err[:, 0], 10, 2.0)]
    assert out.series[:, 0].tolist() == [1.0] * 46 + [0.0] * 54


def test_convergence_epoch_equals_the_definition_written_out(rng):
    err = np.abs(rng.standard_normal((80, 6))) * np.linspace(6, 1, 80)[:, None]
    conv = ConvergenceEpoch("c", of="e", window=7, factor=1.5).compute({"e": err}, None, None).value
    assert conv.tolist() == [_hand_convergence(err[:, r], 7, 1.5) for r in range(6)]


def test_the_multipath_scenario_declares_each_metric_once_and_reports_the_hand_reductions():
    assert multipath.MultipathScenario.metrics == {m.name: m.unit for m in multipath.METRICS}
    scen = get_scenario({"kind": "multipath", "epochs": 60, "convergence_window": 5})
    zs = scen.simulate(3, np.random.default_rng(4), psi=0.9)
    res = scen.run_batch({"psi": 0.9}, {}, 3, np.random.default_rng(4))  # raw: the measurement itself
    lat, lon = zs[..., 0], zs[..., 1]
    h = np.hypot(lat, lon)
    hand = {"lat_error_mean": np.mean(np.abs(lat), 0), "lat_error_rmse": np.sqrt(np.mean(lat**2, 0)),
            "lon_error_mean": np.mean(np.abs(lon), 0), "lon_error_rmse": np.sqrt(np.mean(lon**2, 0)),
            "horizontal_error_rmse": np.sqrt(np.mean(h**2, 0)),
            "convergence_epoch": [_hand_convergence(h[:, r], 5, 2.0) for r in range(3)]}
    assert set(res.metrics) == set(hand)
    for name, value in hand.items():
        np.testing.assert_allclose(res.metrics[name], value, rtol=1e-12, err_msg=name)
    # The series: the raw signed errors (outputs) and each metric's own.
    np.testing.assert_array_equal(res.series["lat_error_m"], lat)
    np.testing.assert_array_equal(res.series["horizontal_error_rmse"], h)
    conv = res.metrics["convergence_epoch"]
    np.testing.assert_array_equal(res.series["convergence_epoch"], np.arange(60)[:, None] < conv[None, :])
    assert set(scen.outputs) <= set(res.series)


def test_names_are_unique_and_values_one_per_run():
    with pytest.raises(ValueError, match="two metric components are named 'x'"):
        units([Rmse("x", "m", of="a"), MeanAbs("x", "m", of="b")])

    class Bad(Rmse):
        def compute(self, series, time_s, scenario):
            return type(super().compute(series, time_s, scenario))(np.zeros(5))

    with pytest.raises(ValueError, match=r"metric 'bad' returned shape \(5,\), expected \(2,\)"):
        evaluate([Bad("bad", "m", of="e")], {"e": np.zeros((4, 2))}, None, None)
    with pytest.raises(ValueError, match="a raw series has the same name"):
        evaluate([Rmse("e", "m", of="e")], {"e": np.zeros((4, 2))}, None, None)
