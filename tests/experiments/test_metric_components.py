"""A scenario's own metrics as components (experiments.metric_components), against hand values."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from gnssframework.experiments import get_scenario
from gnssframework.experiments.metric_components import (
    ConvergenceEpoch,
    LockLossFraction,
    Mean,
    MeanAbs,
    Rmse,
    SlipRecovery,
    Std,
    evaluate,
    slip_recovery,
    units,
)
from gnssframework.experiments.scenarios import carrier_smoothing, multipath, scintillation, vector_tracking
from gnssframework.random_streams import as_run_streams


def _hand_convergence(err: np.ndarray, window: int, factor: float) -> float:
    """The definition written out epoch by epoch (one run): the first epoch after which the
    RMS of the last `window` errors (zeros before the start) stays below factor x the RMS
    of the second half."""
    K = len(err)
    bound = factor * np.sqrt(np.mean(err[K // 2 :] ** 2))
    last_above = -1
    for k in range(K):
        lo = max(0, k - window + 1)
        if np.sqrt(np.sum(err[lo : k + 1] ** 2) / window) > bound:
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
    zs = scen.simulate(3, as_run_streams(np.random.default_rng(4), 3), psi=0.9)  # run_batch's streams
    res = scen.run_batch({"psi": 0.9}, {}, 3, np.random.default_rng(4))  # raw: the measurement itself
    lat, lon = zs[..., 0], zs[..., 1]
    h = np.hypot(lat, lon)
    hand = {
        "lat_error_mean": np.mean(np.abs(lat), 0),
        "lat_error_rmse": np.sqrt(np.mean(lat**2, 0)),
        "lon_error_mean": np.mean(np.abs(lon), 0),
        "lon_error_rmse": np.sqrt(np.mean(lon**2, 0)),
        "horizontal_error_rmse": np.sqrt(np.mean(h**2, 0)),
        "convergence_epoch": [_hand_convergence(h[:, r], 5, 2.0) for r in range(3)],
    }
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


# --- The components of carrier-smoothing, scintillation and vector-tracking ----------------


class _Scen:
    """A stand-in scenario: only the parameters the components read."""

    kind = "hand"

    def __init__(self, **params):
        self.params = type("Params", (), params)()


def test_mean_and_std_against_hand_values_after_settle_time_or_leading_epochs():
    x = np.array([[1.0, 2.0], [3.0, -2.0], [5.0, 4.0]])
    t = np.array([0.0, 1.0, 2.0])
    scen = _Scen(settle_s=1.0, settle_epochs=2)
    mean = Mean("m", "-", of="x", settle="settle_s").compute({"x": x}, t, scen)
    assert mean.value.tolist() == [4.0, 1.0]  # (3 + 5) / 2, (-2 + 4) / 2
    np.testing.assert_array_equal(mean.series, x)  # signed: a NEES series is itself
    std = Std("s", "-", of="x", settle="settle_s").compute({"x": x}, t, scen)
    assert std.value.tolist() == [1.0, 3.0]  # {3, 5} and {-2, 4} about their means
    np.testing.assert_array_equal(std.series, np.abs(x))
    assert Mean("m", "-", of="x", skip_epochs="settle_epochs").compute({"x": x}, None, scen).value.tolist() == [5, 4]
    assert Rmse("r", "-", of="x", skip_epochs=1).compute({"x": x}, None, scen).value == pytest.approx(
        [np.sqrt(17.0), np.sqrt(10.0)]
    )
    # A derived settle time (a function of the scenario), as vector-tracking's steady state.
    late = Mean("m", "-", of="x", settle=lambda s: 2 * s.params.settle_s).compute({"x": x}, t, scen)
    assert late.value.tolist() == [5.0, 4.0]
    with pytest.raises(ValueError, match="no epoch selected"):
        Mean("m", "-", of="x", settle=3.0).compute({"x": x}, t, scen)


def test_lock_loss_fraction_against_hand_blocks():
    # T = 0.1 s, epochs at 0.05 ... 0.55 s; settle 0.1 s leaves epochs 1-5; blocks of 0.2 s =
    # 2 epochs: (1, 2) and (3, 4), epoch 5 is a partial block and left out, as is epoch 0.
    h = np.pi / 2  # cos(2 h) = -1
    err = np.array([[h, h], [0, 0], [0, 0], [h, np.pi / 4], [h, 0], [h, h]])
    t = (np.arange(6) + 0.5) * 0.1
    comp = LockLossFraction("lol", of="e", window="lock_window_s", threshold="lock_threshold", settle="settle_s")
    out = comp.compute({"e": err}, t, _Scen(lock_window_s=0.2, lock_threshold=0.5, settle_s=0.1))
    # run 0: block means 1 and -1 -> one of two out of lock; run 1: 1 and (0 + 1) / 2 = 0.5,
    # not below the threshold -> none.
    assert out.value.tolist() == [0.5, 0.0]
    assert out.series[:, 0].tolist() == [1, 0, 0, 1, 1, 1] and out.series[:, 1].tolist() == [1, 0, 0, 1, 0, 1]
    # Blocks of one epoch (0.1 s): of the 5 settled epochs, run 0 has 3 out of lock
    # (cos(2 h) = -1) and run 1 two (cos(pi / 2) = 0 and -1).
    one = comp.compute({"e": err}, t, _Scen(lock_window_s=0.1, lock_threshold=0.5, settle_s=0.1))
    assert one.value.tolist() == [0.6, 0.4]


def test_lock_loss_fraction_refuses_a_window_longer_than_the_settled_epochs():
    # 5 settled epochs of 0.1 s hold no block of 0.6 s: a named error, not a NumPy warning and a NaN.
    err = np.zeros((6, 2))
    t = (np.arange(6) + 0.5) * 0.1
    comp = LockLossFraction("lol", of="e", window="lock_window_s", threshold="lock_threshold", settle="settle_s")
    with pytest.raises(ValueError, match=r"^lol: the 5 settled epochs hold no whole block of 6 epochs"):
        comp.compute({"e": err}, t, _Scen(lock_window_s=0.6, lock_threshold=0.5, settle_s=0.1))


def _slip_runs():
    """Three hand-built runs of 60 epochs, errors +-1 (reference sigma exactly 1) except:
    run 0: a slip at 40 leaving 10, 10, 5 -> running RMS over 5 epochs 6.7, 5.06, 2.41, 1:
    recovered (2 sigma) after 3 epochs (after 2 with a 4-sigma band);
    run 1: a slip at 40 leaving 10 to the end -> censored;
    run 2: slips at 35 and 40 -> 40 is not isolated (5 <= 10 epochs), 35 recovers at once."""
    err = np.where(np.arange(60) % 2, 1.0, -1.0)[:, None].repeat(3, axis=1)
    err[40:43, 0] = [10.0, 10.0, 5.0]
    err[40:, 1] = 10.0
    slips = np.zeros((60, 3), bool)
    slips[40, 0] = slips[40, 1] = slips[35, 2] = slips[40, 2] = True
    return err, slips


def test_slip_recovery_components_against_hand_values_through_the_scenarios_declaration():
    err, slips = _slip_runs()
    scen = _Scen(recovery_isolation_epochs=10, settle_epochs=5)
    comps = {m.name: m for m in carrier_smoothing.METRICS}
    series = {"range_error_m": err, "slip": slips}
    rec = comps["slip_recovery_epochs"].compute(series, None, scen)
    np.testing.assert_array_equal(rec.value, [3.0, np.nan, 0.0])
    np.testing.assert_array_equal(rec.series, slips.astype(float))
    assert comps["censored_slips"].compute(series, None, scen).value.tolist() == [0.0, 1.0, 0.0]
    # Only the mean can be undefined (NaN); the scenario's table of reasons comes from the components.
    assert carrier_smoothing.CarrierSmoothingScenario.undefined_reasons == {"slip_recovery_epochs": "no isolated slips"}
    wide = SlipRecovery("r", of="range_error_m", slips="slip", band=4.0, isolation=10, start=5)
    assert wide.compute(series, None, scen).value[0] == 2.0
    # The reference window must start at or after settle_epochs: with 11 the slip at 40
    # (reference from 10) is not measured, nor 35.
    late = comps["slip_recovery_epochs"].compute(series, None, _Scen(recovery_isolation_epochs=10, settle_epochs=11))
    np.testing.assert_array_equal(late.value, [np.nan, np.nan, np.nan])


def test_false_resets_component_against_hand_values():
    # run 0: a detection before any slip (false), then a slip caught two epochs late (true);
    # run 1: a slip caught at once, then a second detection with no new slip (false).
    detected = np.array([[1, 0], [0, 1], [0, 1], [1, 0]], bool)
    slips = np.array([[0, 0], [1, 1], [0, 0], [0, 0]], bool)
    comp = next(m for m in carrier_smoothing.METRICS if m.name == "false_reset_rate")
    out = comp.compute({"slip_detected": detected, "slip": slips}, None, None)
    assert out.value.tolist() == [1.0, 1.0]
    assert out.series.tolist() == [[1, 0], [0, 0], [0, 1], [1, 0]]


def test_an_optional_component_is_left_out_without_its_series_and_a_required_one_is_not():
    comps = [Rmse("a", "m", of="x"), Rmse("b", "m", of="y", optional=True)]
    res = evaluate(comps, {"x": np.ones((3, 2))}, None, None)
    assert set(res.metrics) == {"a"}
    with pytest.raises(KeyError):
        evaluate([Rmse("b", "m", of="y")], {"x": np.ones((3, 2))}, None, None)


@pytest.mark.parametrize("module", [multipath, carrier_smoothing, scintillation, vector_tracking])
def test_each_scenario_derives_its_metric_table_from_its_components(module):
    cls = next(
        c
        for c in vars(module).values()
        if isinstance(c, type)
        and getattr(c, "METRICS", None) is None
        and hasattr(c, "run_batch")
        and c.__module__ == module.__name__
    )
    assert cls.metrics == {m.name: m.unit for m in module.METRICS}
    # Every series a component reads is a declared output: a third-party metric may read it too.
    assert {r for m in module.METRICS for r in m.requires} <= set(cls.outputs)


def test_carrier_smoothing_reports_the_hand_reductions():
    scen = get_scenario(
        {
            "kind": "carrier-smoothing",
            "epochs": 300,
            "settle_epochs": 20,
            "slip_probability": 0.02,
            "recovery_isolation_epochs": 40,
        }
    )
    truth, code, _, slips = scen.simulate(3, as_run_streams(np.random.default_rng(5), 3))  # run_batch's streams
    res = scen.run_batch({}, {}, 3, np.random.default_rng(5))  # raw: the pseudorange itself
    err = code - truth
    np.testing.assert_allclose(res.metrics["error_rmse"], np.sqrt(np.mean(err[20:] ** 2, axis=0)), rtol=1e-12)
    assert res.metrics["false_reset_rate"].tolist() == [0.0, 0.0, 0.0]  # raw never detects
    np.testing.assert_array_equal(res.series["range_error_m"], err)
    np.testing.assert_array_equal(res.series["slip"], slips)
    rec, cens = slip_recovery(err, slips, isolation=40, start=20)  # the scenario's parameters reach it
    np.testing.assert_array_equal(res.metrics["slip_recovery_epochs"], rec)
    np.testing.assert_array_equal(res.metrics["censored_slips"], cens)
    assert slips.sum() > 3  # the draw has slips to measure


def test_scintillation_reports_the_hand_reductions():
    scen = get_scenario({"kind": "scintillation", "duration_s": 1.0, "settle_s": 0.3, "lock_window_s": 0.1})
    ch = scen.build({"channel_filter": {"name": "scalar", "params": {"pll_bandwidth_hz": 10.0}}})
    res = scen.run_batch({"s4": 0.6, "cn0_dbhz": 30.0}, ch, 2, np.random.default_rng(3))
    err, disc, t = res.series["phase_error_rad"], res.series["phase_disc_rad"], res.time_s
    assert np.all(np.abs(err) <= np.pi / 2) and t[0] == pytest.approx(0.005)
    s = t >= 0.3  # 70 epochs: 7 blocks of 10
    hand_lol = [
        np.mean([np.mean(np.cos(2 * err[s][10 * b : 10 * b + 10, r])) < 0.5 for b in range(7)]) for r in range(2)
    ]
    hand = {
        "phase_error_rmse": np.sqrt(np.mean(err[s] ** 2, axis=0)),
        "discriminator_std": np.std(disc[s], axis=0),
        "loss_of_lock_fraction": hand_lol,
        "equivalent_bandwidth_hz": res.series["loop_noise_bandwidth_hz"][0],
    }
    assert set(res.metrics) == set(hand)
    for name, value in hand.items():
        np.testing.assert_allclose(res.metrics[name], value, rtol=1e-12, err_msg=name)
    assert np.all(res.series["loop_noise_bandwidth_hz"] == res.series["loop_noise_bandwidth_hz"][0, 0])


def test_vector_tracking_reports_the_hand_reductions():
    scen = get_scenario(
        {
            "kind": "vector-tracking",
            "duration_s": 0.3,
            "channels": 4,
            "settle_s": 0.1,
            "steady_state_s": 0.2,
            "innovation_false_alarm": 1e-3,
        }
    )
    plugins = scen.build({"channel_filter": {"name": "discriminator"}, "nav_filter": {"name": "ekf-pv"}})
    res = scen.run_batch({"cn0_dbhz": 40.0}, plugins, 2, np.random.default_rng(8))
    t, sr = res.time_s, res.series
    s, steady = t >= 0.1, t >= 0.2
    assert s.sum() == 20 and steady.sum() == 10

    def rms(x, m):
        return np.sqrt(np.mean(x[m] ** 2, axis=0))

    hand = {
        "code_phase_error_rmse": rms(sr["code_error_chips"], s),
        "carrier_freq_error_rmse": rms(sr["freq_error_hz"], s),
        "position_error_rmse": rms(sr["position_error_m"], s),
        "velocity_error_rmse": rms(sr["velocity_error_m_s"], s),
        "position_steady_error_rmse": rms(sr["position_error_m"], steady),
        "nees": np.mean(sr["nav_nees"][s], axis=0),
        "nees_position": np.mean(sr["nav_nees_position"][s], axis=0),
        "nees_velocity": np.mean(sr["nav_nees_velocity"][s], axis=0),
        "code_output_rmse": rms(sr["code_output_error_chips"], s),
        "freq_output_rmse": rms(sr["freq_output_error_hz"], s),
        "pcrb_position": rms(sr["pcrb_position_m"], s),
        "pcrb_velocity": rms(sr["pcrb_velocity_m_s"], s),
        "pcrb_position_code": rms(sr["pcrb_position_code_m"], s),
        "pcrb_velocity_code": rms(sr["pcrb_velocity_code_m_s"], s),
        "excluded_channels": np.zeros(2),  # no channel monitor: no channel excluded
        # The nav filter's NIS over its 2 x 4 rows (ranges and rates of 4 channels), and its test at 1e-3.
        "nis_per_dof": np.mean(sr["nav_nis_per_dof"][s], axis=0),
        "innovation_alarm_fraction": np.mean((sr["nav_nis_per_dof"] * 8 > chi2.isf(1e-3, 8))[s], axis=0),
    }
    # Integrity: the default alert limits 40 m (horizontal) and 35 m (vertical).
    for axis, limit in (("horizontal", 40.0), ("vertical", 35.0)):
        err, pl = sr[f"{axis}_error_m"], sr[f"{axis[0]}pl_m"]
        hand[f"{axis[0]}pl_mean"] = np.mean(pl[s], axis=0)
        hand[f"{axis}_misleading_fraction"] = np.mean((err > pl)[s], axis=0)
        hand[f"{axis}_hazardous_fraction"] = np.mean(((pl < limit) & (err > limit))[s], axis=0)
        hand[f"{axis}_available_fraction"] = np.mean((pl < limit)[s], axis=0)
    # The scenario's optional metrics whose series this configuration does not record (read
    # from its definitions: the smoothed ones here, smoothed = false); each says why.
    skipped = {c.name for c in vector_tracking.METRICS if c.optional and not set(c.requires) <= set(sr)}
    assert skipped and all(scen.undefined_reasons.get(name) for name in skipped)
    assert set(res.metrics) == set(hand) == set(scen.metrics) - skipped
    for name, value in hand.items():
        np.testing.assert_allclose(res.metrics[name], value, rtol=1e-12, err_msg=name)
    assert sr["code_error_chips"].shape == (30, 2) and np.all(sr["nav_nees"] > 0)
    np.testing.assert_array_equal(sr["pcrb_position"], sr["pcrb_position_m"])  # the bound drawn beside the error
