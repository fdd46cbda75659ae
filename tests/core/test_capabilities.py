"""The capability interfaces: the core runs any nav filter that implements them, a
third-party one as the built-in, and picks none by name."""

from __future__ import annotations

import types

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.estimation import Gaussian, LinearModel
from gnssframework.experiments import get_scenario
from gnssframework.experiments.scenarios.deep_integration import _kind
from gnssframework.interfaces import BatchPositionFilter, ErrorStateNavFilter, IntegrationAiding
from gnssframework.plugin import PluginParams


class RandomWalkPosition(BatchPositionFilter):
    """A third-party position filter: a random walk per coordinate, position only."""

    name = "test-random-walk"
    description = "random-walk position filter (a test's third-party plugin)"
    Params = PluginParams
    requires = provides = ("position_m",)

    def model(self, dt_s=None) -> LinearModel:
        return LinearModel(np.eye(1), np.eye(1), np.array([[0.01]]), np.array([[1.0]]))

    def initial(self, first) -> Gaussian:
        return Gaussian(np.asarray(first, float)[..., None], np.eye(1) * 10.0)

    def reset(self, batch_shape, context) -> None:
        pass

    def step(self, inputs):
        return dict(inputs)


@pytest.fixture
def random_walk(scratch_registry):
    scratch_registry.register_module(
        types.SimpleNamespace(register_nav_filter=gf.hookimpl(lambda register: register(RandomWalkPosition))),
        name="test-capabilities",
        distribution="third-party",
    )
    return RandomWalkPosition


def _multipath(nav: str, options=None, runs: int = 3):
    scen = get_scenario({"kind": "multipath", "epochs": 100})
    plugins = scen.build(
        {"nav_filter": {"name": nav, "params": {}}, "estimator": {"name": "kf", "params": {}}}, options
    )
    return scen.run_batch({"psi": 0.8}, plugins, runs, np.random.default_rng(3)).metrics["horizontal_error_rmse"]


def test_a_third_party_batch_position_filter_runs_in_multipath_with_and_without_the_oracle(random_walk):
    plain = _multipath("test-random-walk")
    raw = (
        get_scenario({"kind": "multipath", "epochs": 100})
        .run_batch({"psi": 0.8}, {}, 3, np.random.default_rng(3))
        .metrics["horizontal_error_rmse"]
    )
    assert np.all(np.isfinite(plain)) and np.all(plain < raw)  # it filters: below the raw measurement
    tuned = _multipath(
        "test-random-walk", {"oracle": {"q_scales": [1e-4, 1.0], "r_scales": [1.0, 10.0], "training_runs": 2}}
    )
    assert np.mean(tuned) < np.mean(plain)  # the grid finds a better fixed Q/R than the given one


def test_the_built_in_position_filter_s_default_filter_is_its_model_from_its_prior():
    nav = gf.registry.create("nav_filter", "position-ca")
    zs = np.random.default_rng(0).normal(size=(30, 2, 2))
    est = gf.registry.create("estimator", "kf")
    res = nav.filter(zs, est)
    scaled = nav.filter(
        zs, est, model=LinearModel(nav.model().F, nav.model().H, nav.model().Q * 1.0, nav.model().R * 1.0)
    )
    np.testing.assert_array_equal(res.mean, scaled.mean)
    np.testing.assert_array_equal(nav.initial(zs[0]).mean[..., 0], zs[0])


def test_the_ins_filter_is_an_error_state_filter_that_states_its_aiding():
    ekf = gf.registry.create(
        "nav_filter", "ins-ekf", accel_aiding=False, clock_psd=(0.2, 0.3), carrier_filter="kf-carrier-loop"
    )
    assert isinstance(ekf, ErrorStateNavFilter) and ekf.error_states == 15
    aiding = ekf.aiding()
    assert aiding.accel_aiding is False and aiding.clock_psd == (0.2, 0.3)
    assert aiding.carrier_filter.name == "kf-carrier-loop"
    assert IntegrationAiding().accel_aiding is True  # the contract's default
    assert IntegrationAiding().coupling == "loose"
    # A third-party INS filter stating another coupling is refused where it states it.
    with pytest.raises(gf.ConfigError, match=r"^coupling: must be 'loose' or 'tight', got 'deep'$"):
        IntegrationAiding(coupling="deep")  # type: ignore[arg-type]


class _OtherIns(ErrorStateNavFilter):
    name = "test-other-ins"
    Params = PluginParams
    provides = ("error_state", "cov")
    cov = None

    def propagate(self, transition, process_noise) -> None:
        pass

    def reset(self, batch_shape, context) -> None:
        pass

    def step(self, inputs):
        return {}


@pytest.mark.parametrize("channel, kind", [("iq-filter", "deep"), ("scalar", "loose")])
def test_deep_integration_takes_any_error_state_filter_by_capability(channel, kind):
    ch = gf.registry.create("channel_filter", channel)
    assert _kind({"channel_filter": ch, "nav_filter": _OtherIns()}) == kind
    with pytest.raises(gf.ConfigError, match="error-state nav filter"):
        _kind({"channel_filter": ch, "nav_filter": gf.registry.create("nav_filter", "position-ca")})
