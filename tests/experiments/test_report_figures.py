"""The report's numbers and figures: significant figures matched to the SE, no spread or
significance from rounding, and figures a reader can trust (checked through matplotlib's
objects, not pixels): a grid, units on every axis, log scale where the range needs it,
one bound curve, one legend per figure, labels saying what is drawn."""

from __future__ import annotations

import pytest
import re
import types

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from pydantic import Field  # noqa: E402

import gnssframework as gf  # noqa: E402
from gnssframework.experiments import load_config, run_comparison  # noqa: E402
from gnssframework.experiments.figures import Curve, Panel, grid_shape, needs_log_scale, panel_grid  # noqa: E402
from gnssframework.experiments.metric_components import Mean, Rmse, evaluate, units  # noqa: E402
from gnssframework.experiments.number_format import at_rounding_level, format_estimate  # noqa: E402
from gnssframework.experiments.report import cdf_figure, series_figure  # noqa: E402
from gnssframework.experiments.scenarios import Scenario, ScenarioParams  # noqa: E402
from gnssframework.experiments.stats import paired_difference  # noqa: E402
from gnssframework.experiments.store import ResultStore  # noqa: E402

# -- numbers -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "kwargs", "text"),
    [
        # SE 3.86e-5: its 2nd significant figure is the 6th decimal; the spread goes there too.
        ((0.0006557, 3.86e-5), {"spread": 1.338e-4}, "0.000656 ± 0.000134"),
        # SE 0.39 -> one decimal; SE 12 -> units; SE 160 -> tens.
        ((4.4712, 0.39), {}, "4.47 ± 0.39"),
        ((104.4, 12.0), {}, "104 ± 12"),
        ((1844.4, 160.0), {}, "1840 ± 160"),
        # A negative difference keeps its sign, a positive one gets a +.
        ((-0.0424911, 0.000514), {"sign": True}, "-0.04249 ± 0.00051"),
        ((0.0122, 0.018), {"sign": True}, "+0.012 ± 0.018"),
        # Beyond 6 decimals or from 1e6 on, one shared power of ten.
        ((6.557e-7, 3.86e-8), {}, "(6.56 ± 0.39)e-07"),
        ((1.2e7, 3.0e5), {}, "(1.200 ± 0.030)e+07"),
        # No spread, or a spread at rounding level of the value: the value alone, 4 figures.
        ((0.22803560419104105, 2.8989753257218837e-17), {}, "0.228"),
        ((0.00010716586336069256, 0.0), {}, "0.0001072"),
        ((3.0, None), {}, "3"),
        ((None, 0.1), {}, "–"),
    ],
)
def test_format_estimate_against_hand_worked_cases(args, kwargs, text):
    assert format_estimate(*args, **kwargs) == text


def test_rounding_level_is_relative_to_the_numbers_compared():
    assert at_rounding_level(1e-17, 0.2) and at_rounding_level(0.0, 5.0) and at_rounding_level(None, 1.0)
    assert not at_rounding_level(1e-9, 0.2)
    # 1e-17 is data when the numbers themselves are that small.
    assert not at_rounding_level(1e-17, 1e-16)


def test_a_difference_with_only_rounding_spread_is_not_significant():
    bound = np.full(12, 0.22803560419104105)
    noisy = bound + np.array([0, 2.8e-17] * 6)  # the same bound, summed in another order
    pd = paired_difference(noisy, bound)
    assert pd.se == 0.0 and not pd.significant and pd.reason.endswith("up to floating-point rounding")
    # The same difference in every run, well above rounding: no spread, so no t-test either.
    shifted = paired_difference(bound + 0.25, bound)
    assert shifted.diff == pytest.approx(0.25) and not shifted.significant and "no spread" in shifted.reason
    same = paired_difference(bound, bound)
    assert not same.significant and same.reason == "identical values in every run"
    # A spread well above rounding is tested as before.
    assert paired_difference(bound + np.linspace(1e-3, 2e-3, 12), bound).significant


# -- figure helpers ------------------------------------------------------------------------


def test_log_scale_is_chosen_when_the_range_exceeds_the_decades():
    assert needs_log_scale(np.array([3.0, 3.0e2 * 1.01]))
    assert not needs_log_scale(np.array([3.0, 3.0e2 * 0.99]))
    assert needs_log_scale(np.array([0.0, 1.0, 1e3]))  # zeros cannot be drawn but do not veto
    assert not needs_log_scale(np.array([-1.0, 1.0, 1e3]))  # a log axis cannot show a negative value
    assert not needs_log_scale(np.array([np.nan, 5.0]))


def test_panel_grid_lays_out_labels_scales_and_one_legend():
    t = np.linspace(0, 10, 50)
    panels = [
        Panel(
            f"m{i}",
            "time (s)",
            f"m{i} (m)",
            [Curve("a", t, np.full(50, 1.0 + i)), Curve("b", t, np.full(50, 10.0 ** (i + 1)))],
        )
        for i in range(5)
    ]
    fig = panel_grid(panels, "title")
    try:
        assert grid_shape(5) == (2, 3) and len(fig.axes) == 5  # the sixth, empty cell is removed
        spans = [np.log10(10.0 ** (i + 1) / (1.0 + i)) for i in range(5)]
        assert [ax.get_yscale() for ax in fig.axes] == ["log" if s > 2 else "linear" for s in spans]
        assert len(fig.legends) == 1 and all(ax.get_legend() is None for ax in fig.axes)
        assert [t.get_text() for t in fig.legends[0].get_texts()] == ["a", "b"]
    finally:
        plt.close(fig)


# -- the report's figures on a comparison ---------------------------------------------------


class _Params(ScenarioParams):
    duration_s: float = Field(2.0, gt=0)


METRICS = (
    Rmse("error_rmse", "m", of="error_m"),
    Mean("nees", "-", of="nees_per_epoch"),
    Rmse("bound_rmse", "m", of="bound_m"),
)


class BoundScenario(Scenario):
    """A filter whose error shrinks as 1/sqrt(t) above a bound; an overconfident candidate
    ("literal") has a NEES 1000 times a consistent one's."""

    kind = "test-bound"
    Params = _Params
    CaseParams = _Params
    components = {"estimator": True}
    metrics = units(METRICS)
    bounds = {"error_rmse": "bound_rmse"}

    def run_batch(self, case, plugins, runs, rng):
        t = np.arange(1, 201) * 0.01
        scale = 1000.0 if plugins["estimator"].name == "ukf" else 1.0
        err = (1 + 0.3 * rng.standard_normal((runs, t.size)).T) / np.sqrt(t)[:, None]
        nees = scale * np.sum(rng.standard_normal((runs, t.size, 3)) ** 2, axis=-1).T  # chi-square, 3 dof
        bound = np.repeat((0.5 / np.sqrt(t))[:, None], runs, axis=1)
        return evaluate(METRICS, {"error_m": err, "nees_per_epoch": nees, "bound_m": bound}, t, self)


CONFIG = """
name = "bounds"
runs = 6
batch_size = 3
seed = 3
[executor]
workers = 1
[scenario]
kind = "test-bound"
[[cases]]
name = "only"
[[candidates]]
name = "consistent"
estimator = { name = "kf" }
[[candidates]]
name = "literal"
estimator = { name = "ukf" }
"""

UNIT = re.compile(r"\([^()]+\)$")


@pytest.fixture
def comparison(tmp_path, scratch_registry):
    module = types.SimpleNamespace(register_scenario=gf.hookimpl(lambda register: register(BoundScenario)))
    scratch_registry.register_module(module, "test-bound")
    path = tmp_path / "c.toml"
    path.write_text(CONFIG)
    config = load_config(path)
    run_comparison(config, tmp_path / "out", progress=False)
    return config, tmp_path / "out"


def _check_common(fig, panels: int):
    assert len(fig.axes) == panels and len(fig.legends) == 1
    assert all(ax.get_legend() is None for ax in fig.axes)
    for ax in fig.axes:  # units on every axis, a title on every panel
        assert UNIT.search(ax.get_xlabel()) and UNIT.search(ax.get_ylabel()) and ax.get_title()
    width, height = fig.get_size_inches()
    assert width / height < 4  # a grid, not a strip of panels


@pytest.mark.slow
def test_series_figure_is_labelled_with_what_it_draws(comparison):
    config, out = comparison
    fig = series_figure(config, out, "only")
    try:
        _check_common(fig, 2)  # the bound is not a panel of its own
        error, nees = fig.axes
        assert error.get_title() == "error_rmse" and error.get_ylabel() == "|error_m| (m)"
        assert error.get_xlabel() == "time (s)"
        # One bound curve (not one per candidate), dashed, beside the two candidates.
        labels = [line.get_label() for line in error.get_lines()]
        assert labels == ["consistent", "literal", "bound_rmse (bound)"]
        assert error.get_lines()[-1].get_linestyle() == "--"
        # NEES of 3 beside 3000: a log axis; the error (a factor ~3 between candidates): linear.
        assert nees.get_yscale() == "log" and error.get_yscale() == "linear"
        assert "median over 6 runs" in fig.get_suptitle()
        legend = [t.get_text() for t in fig.legends[0].get_texts()]
        assert legend == ["consistent", "literal", "bound_rmse (bound)"]
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_cdf_figure_has_units_and_one_bound_curve(comparison):
    config, out = comparison
    fig = cdf_figure(config, ResultStore(out / "results.sqlite"), "only")
    try:
        _check_common(fig, 2)
        error, nees = fig.axes
        assert error.get_xlabel() == "error_rmse (m)" and nees.get_xlabel() == "nees (-)"
        assert nees.get_xscale() == "log" and error.get_xscale() == "linear"
        assert [line.get_label() for line in error.get_lines()] == ["consistent", "literal", "bound_rmse (bound)"]
        # Each CDF climbs from 0 to 1 in steps of 1/runs.
        y = error.get_lines()[0].get_ydata()
        assert y[0] == 0 and y[-1] == 1 and np.allclose(np.diff(y), 1 / 6)
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_report_prints_a_bound_without_spread_or_significance(comparison):
    _, out = comparison
    report = (out / "report.md").read_text()
    row = next(line for line in report.splitlines() if line.startswith("| bound_rmse |") and "±" not in line)
    assert "**\\***" not in row
    paired = report.split("Paired differences to")[1].split("Ratios of means")[0]
    row = next(line for line in paired.splitlines() if line.startswith("| bound_rmse |"))
    assert "±" not in row and "**\\***" not in row


VECTOR = """
name = "vt-figures"
runs = 2
batch_size = 2
seed = 5
[executor]
workers = 1
[scenario]
kind = "vector-tracking"
duration_s = 0.3
channels = 4
settle_s = 0.05
steady_state_s = 0.1
[[cases]]
name = "c"
cn0_dbhz = 40.0
[[candidates]]
name = "discriminator"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv" }
[[candidates]]
name = "ckf"
channel_filter = { name = "iq-filter", params = { estimator = "ckf", adaptive = false } }
nav_filter = { name = "ekf-pv" }
"""


@pytest.mark.slow
def test_the_main_jobs_scenario_gets_a_grid_with_one_bound_curve_per_bounded_metric(tmp_path):
    path = tmp_path / "v.toml"
    path.write_text(VECTOR)
    config = load_config(path)
    run_comparison(config, tmp_path / "out", progress=False)
    store = ResultStore(tmp_path / "out" / "results.sqlite")
    for fig in (series_figure(config, tmp_path / "out", "c"), cdf_figure(config, store, "c")):
        try:
            # 12 metrics, the two PCRBs drawn inside the position and velocity panels.
            _check_common(fig, len(config.metric_names) - 2)
            titles = [ax.get_title() for ax in fig.axes]
            assert "pcrb_position" not in titles and "pcrb_velocity" not in titles
            for metric, bound in (("position_error_rmse", "pcrb_position"), ("velocity_error_rmse", "pcrb_velocity")):
                ax = fig.axes[titles.index(metric)]
                assert [line.get_label() for line in ax.get_lines()].count(f"{bound} (bound)") == 1
            # Each candidate keeps one colour across the panels.
            colours = {line.get_label(): line.get_color() for ax in fig.axes for line in ax.get_lines()}
            assert all(line.get_color() == colours[line.get_label()] for ax in fig.axes for line in ax.get_lines())
        finally:
            plt.close(fig)
    series = series_figure(config, tmp_path / "out", "c")
    try:
        labels = {ax.get_title(): ax.get_ylabel() for ax in series.axes}
        assert labels["position_error_rmse"] == "|position_error_m| (m)"  # what is drawn: |e_k|, not an RMSE
        assert labels["nees"] == "nav_nees (-)"
    finally:
        plt.close(series)
