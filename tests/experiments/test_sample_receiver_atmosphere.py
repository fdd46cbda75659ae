"""The ``sample-receiver`` scenario's atmosphere: the generator delays each signal by the
ionosphere and troposphere it states, and the receiver's models remove what they model.

Independent truth: a least-squares fix (`navigation.pvt.solve_position`, the receiver's
solver) on the pseudoranges the generator's timing implies lands on the generator's
position when the truth is exactly the receiver's models, and is moved by the weighted
least-squares mapping of the models' residual (written out here) when it is not.

Tolerance: the times of week are float64 seconds near 3.5e5, whose spacing (5.8e-11 s)
is 1.7 cm of range, so a pseudorange ``c (t_rx - t_sv)`` carries up to that rounding and a
fix from six of them a few centimetres (measured: 0.4 cm without the ionosphere, 2.2 cm
with it); the tests allow 5 cm against decimetre-to-metre effects."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework.experiments  # noqa: F401 - registers the scenario kinds
from gnssframework import random_streams, registry
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.experiments.scenarios.sample_receiver_signals import transmit_times
from gnssframework.navigation.ephemeris import satellite_state
from gnssframework.navigation.pvt import solve_position

C_MPS = 299_792_458.0
#: A fix's error from the rounding of float64 times of week (module docstring), m.
ROUNDING_M = 0.05
CASE = {"name": "45", "cn0_dbhz": 45.0}


def _plan(**atmosphere):
    scenario = get_scenario({"kind": "sample-receiver", "satellites": 6, "duration_s": 8.0, **atmosphere})
    return scenario.plan(CASE)


def _fix(plan, *, models: bool, t_after_s: float = 3.0):
    """The fix at ``t_after_s`` into the recording from the generator's code timing (the
    receiver's clock exact), with or without the receiver's models."""
    rx = np.array(plan.receiver_ecef_m)
    t_rx = plan.start_tow_s + t_after_s
    eph = plan.ephemerides
    sat = satellite_state(eph, np.full(eph.sv.size, t_rx - 0.075)).position_m
    code_m = plan.atmosphere.delays_m(sat, plan.receiver_lat_lon_h, t_rx)[0] if plan.atmosphere else None
    t_sv = transmit_times(eph, rx, t_rx, code_m)
    fix = solve_position(
        C_MPS * (t_rx - t_sv),
        t_sv,
        eph,
        iono=plan.atmosphere.iono_utc() if models else None,
        troposphere=models,
        elevation_mask_deg=0.0,
    )
    assert fix is not None
    return np.asarray(fix.position_ecef_m) - rx, sat, t_rx


def _wls_mapping(plan, sat, el_deg, residual_m):
    """The position change (m, ECEF) a weighted least-squares fix makes of range errors
    ``residual_m``: (G^T W G)^-1 G^T W with W = sin^2(E), the solver's weighting."""
    rx = np.array(plan.receiver_ecef_m)
    u = (sat - rx) / np.linalg.norm(sat - rx, axis=1, keepdims=True)
    G = np.hstack([-u, np.ones((u.shape[0], 1))])
    W = np.diag(np.sin(np.radians(el_deg)) ** 2)
    return np.linalg.solve(G.T @ W @ G, G.T @ W @ residual_m)[:3]


def test_the_receivers_models_remove_an_atmosphere_that_is_exactly_theirs():
    plan = _plan(iono_scale=1.0, tropo_zenith_residual_m=0.0)
    error, _, _ = _fix(plan, models=True)
    assert np.linalg.norm(error) < ROUNDING_M, error
    # the delays are there: without the models the same pseudoranges are metres off
    raw, _, _ = _fix(plan, models=False)
    assert np.linalg.norm(raw) > 2.0, raw
    # and the clean control has none: its fix without models is as exact
    clean, _, _ = _fix(_plan(atmosphere=False), models=False)
    assert np.linalg.norm(clean) < ROUNDING_M, clean


def test_what_the_models_leave_moves_the_fix_by_its_least_squares_mapping():
    """The default atmosphere (the ionosphere 1.5 times the broadcast model's, the zenith
    troposphere 5 cm beyond the model's): the fix moves by (G^T W G)^-1 G^T W of the residual
    ranges, W = sin^2(E) (the solver's elevation weighting), within the rounding."""
    import pymap3d

    plan = _plan()
    atm = plan.atmosphere
    assert atm.iono_scale == 1.5 and atm.tropo_zenith_residual_m == 0.05
    error, sat, t_rx = _fix(plan, models=True)
    lat, lon, h = plan.receiver_lat_lon_h
    code_m, carrier_m = atm.delays_m(sat, plan.receiver_lat_lon_h, t_rx)
    iono_m = (code_m - carrier_m) / 2
    az, el, _ = pymap3d.ecef2aer(sat[:, 0], sat[:, 1], sat[:, 2], lat, lon, h)
    residual = iono_m * (1 - 1 / atm.iono_scale) + atm.tropo_zenith_residual_m / np.sin(np.radians(el))
    predicted = _wls_mapping(plan, sat, el, residual)
    np.testing.assert_allclose(error, predicted, atol=ROUNDING_M)
    assert np.linalg.norm(predicted) > 0.3  # a residual worth testing: decimetres


def test_the_ionosphere_delays_the_code_and_advances_the_carrier():
    plan = _plan()
    rx_t = plan.start_tow_s
    sat = satellite_state(plan.ephemerides, np.full(plan.ephemerides.sv.size, rx_t)).position_m
    code_m, carrier_m = plan.atmosphere.delays_m(sat, plan.receiver_lat_lon_h, rx_t)
    no_iono = _plan(iono_scale=0.0).atmosphere.delays_m(sat, plan.receiver_lat_lon_h, rx_t)
    np.testing.assert_allclose(no_iono[0], no_iono[1])  # the troposphere delays both alike
    iono = code_m - no_iono[0]
    assert np.all(iono > 0.5)  # metres of ionosphere at L1
    np.testing.assert_allclose(carrier_m, no_iono[1] - iono)  # advanced by as much


@pytest.mark.slow
def test_the_scenario_hands_the_receiver_its_models_and_coefficients(monkeypatch):
    """The batch's receiver call: the models on with the plan's coefficients where the
    recording has an atmosphere, off in the clean control."""
    from gnssframework.experiments.scenarios import sample_receiver as module

    seen = []

    def probe(*args, **kwargs):
        seen.append((kwargs["ionosphere"], kwargs["troposphere"], kwargs.get("iono_fallback")))
        raise RuntimeError("stop")

    monkeypatch.setattr(module.receive_module, "receive", probe)
    for atmosphere in (True, False):
        scenario = get_scenario(
            {"kind": "sample-receiver", "satellites": 4, "duration_s": 2.0, "atmosphere": atmosphere}
        )
        streams = random_streams.run_streams(5, (1,), [0])
        with pytest.raises(RuntimeError, match="stop"):
            scenario.run_batch(CASE, {"channel_filter": registry.create("channel_filter", "scalar")}, 1, streams)
    (ion_on, trop_on, coeffs), (ion_off, trop_off, none) = seen
    assert ion_on and trop_on and coeffs.alpha == (1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08)
    assert not ion_off and not trop_off and none is None


def test_a_case_can_be_the_clean_control():
    scenario = get_scenario({"kind": "sample-receiver", "satellites": 4})
    assert scenario.plan({"name": "sky", "cn0_dbhz": 45.0}).atmosphere is not None
    assert scenario.plan({"name": "clean", "cn0_dbhz": 45.0, "atmosphere": False}).atmosphere is None


def test_orbit_and_clock_errors_move_the_fix_by_their_least_squares_mapping():
    """A signal later than the broadcast ephemeris says by ``orbit_clock_m`` per satellite
    (the models otherwise exact): the fix moves by the weighted least-squares mapping of
    those ranges, (G^T W G)^-1 G^T W, within the rounding."""
    from dataclasses import replace

    import pymap3d

    from gnssframework.experiments.scenarios.sample_receiver_signals import with_atmosphere

    exact = _plan(iono_scale=1.0, tropo_zenith_residual_m=0.0)
    bias = np.array([1.5, -0.8, 0.3, 2.0, -1.2, 0.6])
    plan = with_atmosphere(exact, replace(exact.atmosphere, orbit_clock_m=tuple(bias)))
    assert plan.key != exact.key  # its own samples
    error, sat, _ = _fix(plan, models=True)
    lat, lon, h = plan.receiver_lat_lon_h
    _, el, _ = pymap3d.ecef2aer(sat[:, 0], sat[:, 1], sat[:, 2], lat, lon, h)
    predicted = _wls_mapping(plan, sat, el, bias)
    np.testing.assert_allclose(error, predicted, atol=ROUNDING_M)
    assert np.linalg.norm(predicted) > 0.5


def test_each_run_draws_its_own_errors_from_its_own_stream():
    """Every run its own atmosphere and orbit and clock errors, from the run's ``errors``
    stream: the same run gets the same draws whatever its batch; the spreads over many
    runs are the stated ones; a clean case, or spreads of 0, keep the case's plan."""
    scenario = get_scenario({"kind": "sample-receiver", "satellites": 6, "duration_s": 8.0})
    plan = scenario.plan(CASE)

    def drawn(first, runs):
        streams = random_streams.as_run_streams(
            random_streams.run_streams(5, (1,), list(range(first, first + runs))), runs
        )
        return [scenario.run_plan(plan, g).atmosphere for g in streams.child("errors").generators]

    batch = drawn(0, 4)
    assert drawn(2, 1)[0] == batch[2] and batch[0] != batch[1]
    many = drawn(0, 2000)
    scale = np.array([a.iono_scale for a in many])
    tropo = np.array([a.tropo_zenith_residual_m for a in many])
    orbit = np.array([a.orbit_clock_m for a in many])
    p = scenario.params
    for values, mean, std in ((scale, p.iono_scale, p.iono_scale_std), (tropo, 0.05, 0.03), (orbit, 0.0, 0.6)):
        se = std / np.sqrt(values.size)  # of the mean; the spread's own SE is std / sqrt(2 n)
        assert abs(values.mean() - mean) < 4 * se, (values.mean(), mean)
        assert abs(values.std() - std) < 4 * std / np.sqrt(2 * values.size), (values.std(), std)
    assert orbit.shape == (2000, 6)
    assert abs(np.corrcoef(orbit[:, 0], orbit[:, 1])[0, 1]) < 4 / np.sqrt(2000)  # independent satellites
    clean = scenario.plan({"name": "clean", "cn0_dbhz": 45.0, "atmosphere": False})
    assert scenario.run_plan(clean, np.random.default_rng(0)) is clean
    still = get_scenario(
        {"kind": "sample-receiver", "satellites": 6, "iono_scale_std": 0, "tropo_zenith_residual_std_m": 0}
        | {"orbit_clock_residual_std_m": 0}
    )
    fixed = still.plan(CASE)
    assert still.run_plan(fixed, np.random.default_rng(0)) is fixed


@pytest.mark.parametrize(
    "field, value",
    [("iono_scale_std", -0.1), ("iono_scale_std", 3.0), ("tropo_zenith_residual_std_m", 0.6)]
    + [("orbit_clock_residual_std_m", -1.0), ("orbit_clock_residual_std_m", 25.0)],
)
def test_a_spread_outside_its_bounds_is_refused_naming_the_field(tmp_path, field, value):
    from gnssframework.errors import ConfigError
    from gnssframework.experiments import load_config

    (tmp_path / "c.toml").write_text(
        f"""name = "t"
runs = 1
[scenario]
kind = "sample-receiver"
{field} = {value}
[[cases]]
name = "45"
cn0_dbhz = 45.0
[[candidates]]
name = "a"
channel_filter = "scalar"
"""
    )
    with pytest.raises(ConfigError, match=f"scenario.{field}"):
        load_config(tmp_path / "c.toml")
