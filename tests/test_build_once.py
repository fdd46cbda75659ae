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
    loop = {"name": name, "params": {"coherent_time_s": 0.01, "q": [0.01, 0.1], "r": 10.0, "angle_unit": "deg",
                                     "dll_bandwidth_hz": 0.5}}
    return ComparisonConfig.model_validate({
        "name": "build-once", "runs": 2, "batch_size": 1, "seed": 3,
        "scenario": {"kind": "scintillation", "duration_s": 3.0, "coherent_time_s": 0.01, "settle_s": 1.0},
        # the candidate's own T (10 ms) and a case at another (1 ms): the loop runs at 1 ms there
        "cases": [{"name": "own-T", "s4": 0.5}, {"name": "1ms", "s4": 0.5, "coherent_time_s": 0.001}],
        "candidates": [{"name": "kf", "channel_filter": loop}],
    })


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


def test_the_loop_built_for_the_case_is_the_loop_run_batch_re_creates():
    # The same numbers whether run_batch gets the loop built for its case (the runner's
    # path) or one built at the candidate's T that it re-creates at the case's.
    config = _config("kf-carrier-loop")
    resolved = resolve(config)
    scenario = resolved.scenario
    case = resolved.cases[1].as_case()
    built_for_case = resolved.build(0, 1)["channel_filter"]
    re_created = scenario.at_interval(resolved.build(0)["channel_filter"], 0.001)
    assert built_for_case.params == re_created.params and built_for_case.params.coherent_time_s == 0.001

    def run(plugins):
        return scenario.run_batch(case, plugins, 2, random_streams.run_streams(3, (1,), [0, 1])).metrics

    direct, again = run(resolved.build(0, 1)), run(resolved.build(0))
    assert set(direct) == set(again)
    for name in direct:
        np.testing.assert_array_equal(direct[name], again[name], err_msg=name)


def test_a_case_at_the_candidates_own_interval_sets_nothing():
    config = _config("kf-carrier-loop")
    resolved = resolve(config)
    spec = resolved.candidates[0].components["channel_filter"]
    assert resolved.scenario.case_parameters("channel_filter", spec, resolved.cases[0].as_case()) == {}
    assert resolved.scenario.case_parameters("channel_filter", spec, resolved.cases[1].as_case()) == {
        "coherent_time_s": 0.001}
