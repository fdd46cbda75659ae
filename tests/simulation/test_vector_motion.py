"""The vector-tracking scenario's moving receiver: a vehicle on a figure-eight."""

import numpy as np
import pymap3d
import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments import get_scenario
from gnssframework.experiments.config import ComparisonConfig
from gnssframework.simulation.trajectory import FigureEight

SCEN = {"kind": "vector-tracking", "duration_s": 3.0, "channels": 8, "settle_s": 0.5, "steady_state_s": 1.5}


def test_figure_eight_derivatives_are_the_numerical_ones_and_its_extremes_the_closed_forms():
    eight = FigureEight(half_length_m=25.0, lap_s=20.0)
    a, w = 25.0, 2 * np.pi / 20.0
    t = np.linspace(0.0, 40.0, 4001)
    h = 1e-3  # central differences: error h^2/6 times the next derivative (a w^3 ~ 1 m/s^3)
    pos, vel, acc = eight.enu(t)
    p_plus, v_plus, _ = eight.enu(t + h)
    p_minus, v_minus, _ = eight.enu(t - h)
    np.testing.assert_allclose(vel, (p_plus - p_minus) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(acc, (v_plus - v_minus) / (2 * h), atol=1e-6)
    # Speed A w (cos^2 + cos^2 2)^(1/2) of the phase: from sqrt(7)/4 A w (where cos^2 = 3/8)
    # to sqrt(2) A w (the crossing); acceleration
    # A w^2 (sin^2 + 4 sin^2 2)^(1/2) of the phase, largest 17/8 A w^2 where sin^2 = 17/32,
    # its north part 2 A w^2; flat; closed after a lap.
    speed = np.linalg.norm(vel, axis=-1)
    assert speed.min() == pytest.approx(np.sqrt(7) / 4 * a * w, rel=1e-5)
    assert speed.max() == pytest.approx(np.sqrt(2) * a * w, rel=1e-6)
    assert np.linalg.norm(acc, axis=-1).max() == pytest.approx(17 / 8 * a * w**2, rel=1e-4)
    assert np.abs(acc[:, 1]).max() == pytest.approx(2 * a * w**2, rel=1e-6)
    # Turning right (clockwise: the vertical part of v x a negative) round the east lobe in
    # the first half lap, left round the west one in the second: by hand from the closed
    # form, (v x a)_up = -A^2 w^3 sin(wt) (3 - 2 sin^2 wt).
    turn = vel[:, 0] * acc[:, 1] - vel[:, 1] * acc[:, 0]
    np.testing.assert_allclose(turn, -(a**2) * w**3 * np.sin(w * t) * (3 - 2 * np.sin(w * t) ** 2), atol=1e-9)
    first, second = (t % 20.0 > 0.1) & (t % 20.0 < 9.9), (t % 20.0 > 10.1) & (t % 20.0 < 19.9)
    assert np.all(turn[first] < 0) and np.all(turn[second] > 0)
    assert np.all(pos[first, 0] > 0) and np.all(pos[second, 0] < 0)
    assert np.all(pos[:, 2] == 0)
    np.testing.assert_allclose(eight.enu(20.0)[0], [0.0, 0.0, 0.0], atol=1e-12)
    assert pos[:, 0].max() == pytest.approx(a, rel=1e-6) and pos[:, 1].max() == pytest.approx(a / 2, rel=1e-6)


def test_scenario_truth_follows_the_figure_eight_and_its_range_rate_is_the_ranges_derivative():
    scen = get_scenario({**SCEN, "duration_s": 20.0})
    truth, x0, _ = scen.truth(45.0, 2, np.random.default_rng(0), "figure-eight")
    p = scen.params
    t = np.linspace(0.0, 20.0, 201)
    r, v = truth.receiver_state(t)
    assert r.shape == v.shape == (201, 2, 3)
    # The receiver in the local frame of the start (pymap3d, independent of the scenario's
    # rotation): the closed form, up to the Earth's curvature below a flat track (A^2/2R ~ 0.05 mm).
    e, n, u = pymap3d.ecef2enu(*np.moveaxis(r[:, 0], -1, 0), p.lat_deg, p.lon_deg, p.height_m)
    w = 2 * np.pi / p.figure_eight_lap_s
    np.testing.assert_allclose(e, p.figure_eight_half_length_m * np.sin(w * t), atol=1e-6)
    np.testing.assert_allclose(n, p.figure_eight_half_length_m / 2 * np.sin(2 * w * t), atol=1e-6)
    np.testing.assert_allclose(u, 0.0, atol=1e-6)
    # The range rate the truth implies (line-of-sight projection of the relative velocity)
    # against the central difference of the geometric ranges: the satellites' and the
    # vehicle's motion together. Error h^2/6 times the range's third derivative (< 1 m/s^3).
    h = 1e-3

    def ranges(tt):
        s, _ = truth.sat_state(np.asarray(tt))
        rr, _ = truth.receiver_state(np.asarray(tt))
        return np.linalg.norm(s[..., None, :, :] - rr[..., :, None, :], axis=-1)

    s, sv = truth.sat_state(t)
    los = s[:, None] - r[:, :, None]
    unit = los / np.linalg.norm(los, axis=-1, keepdims=True)
    rate = np.sum((sv[:, None] - v[:, :, None]) * unit, axis=-1)
    np.testing.assert_allclose(rate, (ranges(t + h) - ranges(t - h)) / (2 * h), atol=1e-5)
    # The vehicle's share of the range rate is not small: up to its speed (~11 m/s).
    static_rate = np.sum(sv[:, None] * unit, axis=-1)
    assert np.abs(rate - static_rate).max() > 5.0
    # The nav filter's initial estimate is drawn around the moving truth (speed ~11 m/s).
    assert np.linalg.norm(x0[:, 3:6], axis=-1) == pytest.approx(np.sqrt(2) * p.figure_eight_half_length_m * w, abs=3.0)


def test_a_case_motion_overrides_the_scenarios_and_the_loop_tracks_the_vehicle():
    scen = get_scenario({**SCEN, "duration_s": 4.0})

    def plugins():
        return scen.build(
            {
                "channel_filter": {"name": "discriminator", "params": {}},
                "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 1.0}},
            }
        )

    moving = scen.run_batch({"cn0_dbhz": 45.0, "motion": "figure-eight"}, plugins(), 3, np.random.default_rng(5))
    static = scen.run_batch({"cn0_dbhz": 45.0}, plugins(), 3, np.random.default_rng(5))
    # Tracking holds (code error a small fraction of a chip, frequency error well inside
    # the FLL's pull-in of 1/(2T) = 50 Hz) and the vehicle's acceleration shows as a larger
    # velocity error than on the static receiver with the same seeds and filter.
    assert np.all(moving.metrics["code_phase_error_rmse"] < 0.01)
    assert np.all(moving.metrics["carrier_freq_error_rmse"] < 2.0)
    assert np.all(moving.metrics["velocity_error_rmse"] > static.metrics["velocity_error_rmse"])
    # No bound for the moving case (it assumes constant velocity); the static case has one.
    assert "pcrb_velocity" in static.metrics and "pcrb_velocity" not in moving.metrics


@pytest.mark.parametrize(
    "extra, case, field",
    [
        ({"motion": "figure-eight", "velocity_enu_m_s": [1.0, 0.0, 0.0]}, None, "scenario.motion"),
        ({"motion": "figure-eight", "pcrb": True}, None, "scenario.pcrb"),
        ({"velocity_enu_m_s": [0.0, 2.0, 0.0]}, {"cn0_dbhz": 45.0, "motion": "figure-eight"}, "cases[0].motion"),
        ({"pcrb": True}, {"cn0_dbhz": 45.0, "motion": "figure-eight"}, "scenario.pcrb"),
    ],
)
def test_a_figure_eight_beside_another_motion_or_the_bound_is_refused_naming_the_field(extra, case, field):
    with pytest.raises(ConfigError) as info:
        scen = get_scenario({**SCEN, **extra})
        scen.check_case(case, "cases[0]")
    assert info.value.field == field


def test_a_trajectory_file_and_a_figure_eight_are_refused_together(tmp_path):
    path = tmp_path / "track.csv"
    path.write_text("t_s,lat_deg,lon_deg,height_m\n0,34.23,108.3576,590.6\n10,34.23,108.3577,590.6\n")
    with pytest.raises(ConfigError) as info:
        get_scenario({**SCEN, "trajectory_file": str(path), "pcrb": False, "motion": "figure-eight"})
    assert info.value.field == "scenario.motion" and "trajectory_file" in info.value.detail


def test_an_unknown_motion_is_a_one_line_config_error():
    cfg = {
        "name": "m",
        "runs": 1,
        "scenario": SCEN,
        "cases": [{"name": "a", "cn0_dbhz": 45.0, "motion": "circle"}],
        "candidates": [{"name": "d", "channel_filter": {"name": "discriminator"}, "nav_filter": {"name": "ekf-pv"}}],
    }
    with pytest.raises(ConfigError) as info:
        ComparisonConfig.model_validate(cfg)
    assert "motion" in str(info.value) and "\n" not in str(info.value)


@pytest.mark.slow
def test_a_comparison_with_moving_and_static_cases_reports_the_bound_where_it_exists(tmp_path):
    """The bound is declared for the whole config but exists only for the static case: the
    moving case's runs carry it as undefined (NaN, with the scenario's reason), not a failure."""
    import json

    from gnssframework.experiments.results import compare

    cfg = {
        "name": "bound-where-defined",
        "runs": 2,
        "seed": 3,
        "executor": {"kind": "local", "workers": 1},
        "scenario": {**SCEN, "duration_s": 2.0},
        "metrics": ["velocity_error_rmse", "pcrb_velocity"],
        "cases": [{"name": "static", "cn0_dbhz": 45.0}, {"name": "moving", "cn0_dbhz": 45.0, "motion": "figure-eight"}],
        "candidates": [
            {
                "name": "d",
                "channel_filter": {"name": "discriminator"},
                "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 1.0}},
            }
        ],
    }
    compare(cfg, tmp_path)
    rows = {(r["case"], r["metric"]): r for r in json.loads((tmp_path / "summary.json").read_text())["rows"]}
    static, moving = rows[("static", "pcrb_velocity")], rows[("moving", "pcrb_velocity")]
    assert np.isfinite(static["mean"]) and static["mean"] > 0
    assert moving["mean"] is None or not np.isfinite(moving["mean"])
    assert np.isfinite(rows[("moving", "velocity_error_rmse")]["mean"])
