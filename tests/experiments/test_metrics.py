"""Metric helpers against hand-computed values; the metric plugin kind end to end."""

from __future__ import annotations

import json
import types

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import gnssframework as gf
from gnssframework.errors import ConfigError, PluginError
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments.metrics import Metric, MetricValue, fraction, max_after_settle, nees_mean, rmse, settled


def test_rmse_by_hand():
    err = np.array([[3.0, 1.0], [4.0, -1.0], [0.0, 2.0]])  # (K=3, runs=2)
    # run 0: sqrt((9 + 16 + 0) / 3) = sqrt(25/3); run 1: sqrt((1 + 1 + 4) / 3) = sqrt(2)
    assert rmse(err) == pytest.approx([np.sqrt(25 / 3), np.sqrt(2)])
    mask = np.array([False, True, True])
    assert rmse(err, mask) == pytest.approx([np.sqrt(8.0), np.sqrt(2.5)])


def test_rmse_of_a_vector_error_uses_its_norm():
    err = np.zeros((2, 1, 3))
    err[0, 0] = [1.0, 2.0, 2.0]  # |e| = 3
    err[1, 0] = [0.0, 0.0, 1.0]  # |e| = 1
    assert rmse(err) == pytest.approx([np.sqrt(5.0)])


def test_max_after_settle_by_hand():
    t = np.array([0.0, 0.5, 1.0, 1.5])
    err = np.array([[9.0, -9.0], [1.0, -3.0], [-2.0, 0.5], [1.5, 1.0]])
    assert max_after_settle(err, t, 1.0) == pytest.approx([2.0, 1.0])
    assert max_after_settle(err, t, 0.5) == pytest.approx([2.0, 3.0])
    with pytest.raises(ValueError, match="no epoch selected"):
        max_after_settle(err, t, 2.0)


def test_nees_mean_by_hand():
    # e = [1, 2], P = diag(1, 4): e^T P^-1 e = 1 + 1 = 2; e = [2, 0], P = diag(2, 1): 2.
    err = np.array([[[1.0, 2.0]], [[2.0, 0.0]]])
    cov = np.array([[np.diag([1.0, 4.0])], [np.diag([2.0, 1.0])]])
    assert nees_mean(err, cov) == pytest.approx([2.0])
    # A correlated P: P = [[2, 1], [1, 2]], P^-1 = [[2, -1], [-1, 2]] / 3, e = [1, 1] -> 2/3.
    assert nees_mean(np.ones((1, 1, 2)), np.array([[[[2.0, 1.0], [1.0, 2.0]]]])) == pytest.approx([2 / 3])
    assert nees_mean(np.array([[1.0], [3.0]]), mask=np.array([False, True])) == pytest.approx([3.0])


def test_fraction_and_settled_by_hand():
    flags = np.array([[1, 0], [1, 0], [0, 1], [1, 0]])
    assert fraction(flags) == pytest.approx([0.75, 0.25])
    mask = settled(np.array([0.0, 1.0, 2.0, 3.0]), 2.0, 4)
    assert mask.tolist() == [False, False, True, True]
    assert fraction(flags, mask) == pytest.approx([0.5, 0.5])
    assert settled(None, 5.0, 3).all()


class PeakCode(Metric):
    name = "code_phase_error_peak"
    unit = "chips"
    description = "largest per-epoch code error after the settle time"
    requires = ("code_phase_error_rmse",)

    def compute(self, series, time_s, scenario):
        err = series["code_phase_error_rmse"]
        return MetricValue(max_after_settle(err, time_s, scenario.params.settle_s), err)


class NeedsOther(Metric):
    name = "needs_other"
    requires = ("lat_error_rmse",)

    def compute(self, series, time_s, scenario):
        return MetricValue(rmse(series["lat_error_rmse"]))


class Incomplete(Metric):
    name = "incomplete"


def _register(registry, *classes):
    module = types.SimpleNamespace(register_metric=gf.hookimpl(lambda register: [register(c) for c in classes]))
    registry.register_module(module, "third-party-metrics", distribution="third-party")


CONFIG = """
runs = 2
batch_size = 2
metrics = [{metrics}]
[executor]
workers = 1
[scenario]
kind = "vector-tracking"
duration_s = 0.3
channels = 4
settle_s = 0.1
[[cases]]
name = "c"
cn0_dbhz = 40.0
[[candidates]]
name = "disc"
channel_filter = {{ name = "discriminator" }}
nav_filter = {{ name = "ekf-pv" }}
"""


def _load(tmp_path, metrics):
    path = tmp_path / "m.toml"
    path.write_text(CONFIG.format(metrics=metrics))
    return load_config(path)


@pytest.mark.slow
def test_a_third_party_metric_is_named_in_a_config_and_reported(tmp_path, scratch_registry):
    _register(scratch_registry, PeakCode, NeedsOther)
    assert "code_phase_error_peak" in scratch_registry.names("metric")
    config = _load(tmp_path, '"code_phase_error_rmse", "code_phase_error_peak"')
    summary = json.loads(run_comparison(config, tmp_path / "out", progress=False).read_text())
    rows = {r["metric"]: r for r in summary["rows"]}
    peak, rms = rows["code_phase_error_peak"], rows["code_phase_error_rmse"]
    assert peak["unit"] == "chips" and peak["runs"] == 2
    assert peak["mean"] > rms["mean"] > 0  # a maximum exceeds the RMS over the same epochs
    # By hand from the stored raw series (the scenario's per-epoch code error, RMS over channels).
    raw = np.load(tmp_path / "out" / "raw" / "c" / "disc" / "run000000-000001.npz")
    late = raw["code_error_chips"][raw["time_s"] >= 0.1]
    assert peak["mean"] == pytest.approx(np.mean(late.max(axis=0)), rel=1e-12)
    assert rms["mean"] == pytest.approx(np.mean(np.sqrt(np.mean(late**2, axis=0))), rel=1e-12)
    assert "| code_phase_error_peak | chips |" in (tmp_path / "out" / "report.md").read_text()


def test_a_metric_the_scenario_cannot_feed_is_refused_at_load_time(tmp_path, scratch_registry):
    _register(scratch_registry, PeakCode, NeedsOther)
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, '"needs_other"')
    assert err.value.field == "metrics[0]" and "lat_error_rmse" in str(err.value)
    assert "code_phase_error_peak" in str(err.value)  # the allowed list includes applicable components
    with pytest.raises(ConfigError, match=r"metrics\[1\]: unknown 'nope'"):
        _load(tmp_path, '"nees", "nope"')


def test_a_metric_with_compute_left_abstract_is_refused(scratch_registry):
    _register(scratch_registry, Incomplete)
    assert "incomplete" not in scratch_registry.names("metric")
    failure = scratch_registry.failures()[-1]
    assert "compute" in failure.error and "abstract" in failure.error
    with pytest.raises(PluginError):  # and directly
        scratch_registry._REGISTRY._add("metric", Incomplete, "x", "")


@settings(max_examples=60, deadline=None)
@given(
    arrays(float, st.tuples(st.integers(1, 12), st.integers(1, 4)), elements=st.floats(-1e3, 1e3)), st.floats(-10, 10)
)
def test_helper_inequalities_and_scaling(err, c):
    r = rmse(err)
    assert np.all(r >= np.abs(np.mean(err, axis=0)) - 1e-9)  # RMS >= |mean|
    assert np.allclose(rmse(c * err), abs(c) * r, rtol=1e-9, atol=1e-9)  # homogeneous of degree 1
    assert np.all(max_after_settle(err, None, 0.0) >= r - 1e-9)  # max >= RMS over the same epochs
    f = fraction(err > 0)
    assert np.all((f >= 0) & (f <= 1))


def test_one_lookup_finds_a_scenario_s_own_component_and_a_registered_metric(scratch_registry):
    from gnssframework.experiments import get_scenario
    from gnssframework.experiments.metric_components import Rmse, series_label
    from gnssframework.experiments.metrics import available_metrics, metric_component

    _register(scratch_registry, PeakCode, NeedsOther)
    scen = get_scenario({"kind": "vector-tracking"})
    own = metric_component("code_phase_error_rmse", scen)
    assert own is scen.metrics.components["code_phase_error_rmse"] and isinstance(own, Rmse)
    assert isinstance(metric_component("code_phase_error_peak", scen), PeakCode)
    assert metric_component("no_such_metric", scen) is None
    names = available_metrics(scen)
    assert names[: len(scen.metrics)] == list(scen.metrics)
    assert "code_phase_error_peak" in names and "needs_other" not in names  # it needs a series vector-tracking lacks
    assert series_label(scen, "code_phase_error_rmse") == own.series_label


class WrongShape(Metric):
    name = "wrong_shape"
    requires = ("code_phase_error_rmse",)

    def compute(self, series, time_s, scenario):
        return MetricValue(np.zeros(7))


@pytest.mark.slow
def test_a_registered_metric_is_computed_like_a_scenario_s_own_and_a_wrong_shape_names_the_task(
    tmp_path, scratch_registry
):
    from gnssframework.errors import RunFailure

    _register(scratch_registry, WrongShape)
    with pytest.raises(RunFailure) as err:
        run_comparison(_load(tmp_path, '"wrong_shape"'), tmp_path / "out", progress=False)
    assert "candidate 'disc', case 'c', runs 0-1" in str(err.value)
    assert "metric 'wrong_shape' returned shape (7,), expected (2,), one value per run" in str(err.value)
