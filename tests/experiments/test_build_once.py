"""A task builds each of its candidate's plugins once (issue 36).

A channel filter's parameters (a Kalman loop's process noise ``q``) are validated and
the plugin created once per task: `Scenario.build` is given the task's case and builds
the plugin with the parameters the case sets (`Scenario.case_parameters`: the
scintillation loops at the case's interval T), instead of building it at the
candidate's T and re-creating it in ``run_batch``. Results are the same either way.
"""

from __future__ import annotations

import types
from collections import Counter

import numpy as np
import pytest

import gnssframework as gf
from gnssframework import random_streams, registry
from gnssframework.experiments.config import ComparisonConfig
from gnssframework.experiments.run_plan import resolve
from gnssframework.experiments.runner import plan, run_task

BUILT = Counter()


@pytest.fixture()
def counting_loop(scratch_registry):
    """``counting-kf-loop``: the built-in Kalman carrier loop, counting its constructions."""
    base = registry.get("channel_filter", "kf-carrier-loop")

    class CountingKalmanLoop(base):
        name = "counting-kf-loop"

        def __init__(self, **params):
            BUILT[type(self).name] += 1
            super().__init__(**params)

    module = types.SimpleNamespace(register_channel_filter=gf.hookimpl(lambda register: register(CountingKalmanLoop)))
    registry.register_module(module, name="counting-kf-loop", distribution="test-build-once")
    BUILT.clear()
    yield "counting-kf-loop"


def _config(name: str) -> ComparisonConfig:
    loop = {"name": name, "params": {"q": [0.01, 0.1], "r": 10.0, "angle_unit": "deg", "dll_bandwidth_hz": 0.5}}
    return ComparisonConfig.model_validate(
        {
            "name": "build-once",
            "runs": 2,
            "batch_size": 1,
            "seed": 3,
            "scenario": {"kind": "scintillation", "duration_s": 3.0, "coherent_time_s": 0.01, "settle_s": 1.0},
            # the scenario's T (10 ms) and a case at another (1 ms): the loop runs at 1 ms there
            "cases": [{"name": "own-T", "s4": 0.5}, {"name": "1ms", "s4": 0.5, "coherent_time_s": 0.001}],
            "candidates": [{"name": "kf", "channel_filter": loop}],
        }
    )


@pytest.mark.slow
def test_a_task_creates_its_channel_filter_once(counting_loop):
    config = _config(counting_loop)
    resolved = resolve(config)
    BUILT.clear()  # validating the config created it (once per interval it is checked at)
    tasks = plan(config)
    for task in tasks:
        before = BUILT[counting_loop]
        run_task(resolved, task)
        assert BUILT[counting_loop] - before == 1, resolved.where(task)
    assert len(tasks) == 4 and BUILT[counting_loop] == 4


@pytest.mark.slow
def test_the_loop_built_for_the_case_runs_as_the_candidates_loop():
    # The loops take the harness's interval (no T of their own): the loop built for the
    # 1 ms case is the candidate's loop, and run_batch runs either at the case's T with the
    # same numbers.
    config = _config("kf-carrier-loop")
    resolved = resolve(config)
    scenario = resolved.scenario
    case = resolved.cases[1].as_case()
    built_for_case = resolved.build(0, 1)["channel_filter"]
    assert built_for_case.params == resolved.build(0)["channel_filter"].params

    def run(plugins):
        return scenario.run_batch(case, plugins, 2, random_streams.run_streams(3, (1,), [0, 1])).metrics

    direct, again = run(resolved.build(0, 1)), run(resolved.build(0))
    assert set(direct) == set(again)
    for name in direct:
        np.testing.assert_array_equal(direct[name], again[name], err_msg=name)
    # at 1 ms the same Q and R per interval make a loop about ten times wider than at 10 ms
    assert 7.0 < float(np.mean(direct["equivalent_bandwidth_hz"])) < 12.0


def test_a_loop_without_an_interval_of_its_own_gets_nothing_from_the_case():
    config = _config("kf-carrier-loop")
    resolved = resolve(config)
    spec = resolved.candidates[0].components["channel_filter"]
    for case in resolved.cases:
        assert resolved.scenario.case_parameters("channel_filter", spec, case.as_case()) == {}


# -- the same for an augmentation whose psi is the case's (multipath) --------------------------


@pytest.fixture()
def counting_ar1(scratch_registry):
    """``counting-ar1``: the built-in colored-ar1 augmentation, counting its constructions."""
    base = registry.get("augmentation", "colored-ar1")

    class CountingAr1(base):
        name = "counting-ar1"

        def __init__(self, **params):
            BUILT[type(self).name] += 1
            super().__init__(**params)

    module = types.SimpleNamespace(register_augmentation=gf.hookimpl(lambda register: register(CountingAr1)))
    registry.register_module(module, name="counting-ar1", distribution="test-build-once")
    BUILT.clear()
    yield "counting-ar1"


def _multipath(name: str, **params) -> ComparisonConfig:
    return ComparisonConfig.model_validate(
        {
            "name": "build-once-multipath",
            "runs": 2,
            "batch_size": 1,
            "seed": 5,
            "scenario": {"kind": "multipath", "epochs": 60, "psi": 0.95},
            "cases": [{"name": "psi-0.5", "psi": 0.5}, {"name": "psi-0.8", "psi": 0.8, "psi_training_epochs": 200}],
            "candidates": [
                {
                    "name": "ukf1",
                    "nav_filter": "position-ca",
                    "estimator": "ukf",
                    "augmentation": {"name": name, "params": {"cross_covariance": "paper", **params}},
                }
            ],
        }
    )


@pytest.mark.parametrize("estimator, per_task", [("truth", 1), ("lag1", 2)])
def test_a_task_creates_an_ar1_augmentation_with_the_case_s_psi_once(counting_ar1, estimator, per_task):
    # The true psi is the case's: built with it. An estimated psi needs the task's random
    # streams, which only run_batch has: that one is still re-created with its estimate.
    config = _multipath(counting_ar1, psi_estimator=estimator)
    resolved = resolve(config)
    BUILT.clear()
    for task in plan(config):
        before = BUILT[counting_ar1]
        run_task(resolved, task)
        assert BUILT[counting_ar1] - before == per_task, resolved.where(task)


def test_the_ar1_built_for_the_case_gives_the_numbers_of_the_re_created_one():
    resolved = resolve(_multipath("colored-ar1"))
    for i, case in enumerate(resolved.cases):
        built = resolved.build(0, i)
        assert built["augmentation"].params.psi == case.values["psi"]
        direct = resolved.scenario.run_batch(case.as_case(), built, 2, random_streams.run_streams(5, (1,), [0, 1]))
        again = resolved.scenario.run_batch(
            case.as_case(), resolved.build(0), 2, random_streams.run_streams(5, (1,), [0, 1])
        )
        for name in direct.metrics:
            np.testing.assert_array_equal(direct.metrics[name], again.metrics[name], err_msg=name)
