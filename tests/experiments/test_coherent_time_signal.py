"""A scenario's coherent interval T is checked against the scenario's own signal (issue 36):
`SignalCoherentTime` reads the bounds and the code period off the parameter model's
``signal``, which must be the scenario's."""

from __future__ import annotations

import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments.limits import SignalCoherentTime
from gnssframework.experiments.scenarios import get_scenario, scenario_kinds
from gnssframework.signal.gps_l1ca import GPS_L1CA


def test_every_scenarios_interval_counts_the_periods_of_the_signal_it_simulates():
    checked = 0
    for kind, cls in scenario_kinds().items():
        for model in (cls.Params, cls.CaseParams):
            if issubclass(model, SignalCoherentTime):
                assert model.signal is getattr(cls, "signal", GPS_L1CA), (kind, model.__name__)
                checked += 1
    assert checked >= 7  # tracking-threshold, scintillation (params and cases), vector, deep, boc (both)


@pytest.mark.parametrize("T", [0.004, 0.008, 0.04, 0.1])
def test_the_boc_scenario_takes_whole_e1c_periods_up_to_its_overlay(T):
    # E1-C: 4092 chips at 1.023 Mchip/s = 4 ms; its CS25 overlay, 25 periods = 100 ms
    # (Galileo OS SIS ICD, sections 3.4 and 3.5).
    assert get_scenario({"kind": "boc-tracking", "coherent_time_s": T}).params.coherent_time_s == T


@pytest.mark.parametrize(
    "kind, T, message",
    [
        ("boc-tracking", 0.002, "Input should be greater than or equal to 0.004 (got 0.002)"),
        (
            "boc-tracking",
            0.006,
            "must be a whole multiple of the 4 ms galileo-e1c-boc11 code period, from 0.004 to 0.1 s (got 0.006)",
        ),
        ("boc-tracking", 0.104, "Input should be less than or equal to 0.1 (got 0.104)"),
        (
            "tracking-threshold",
            0.0015,
            "must be a whole multiple of the 1 ms C/A code period, from 0.001 to 0.02 s (got 0.0015)",
        ),
        ("tracking-threshold", 0.04, "Input should be less than or equal to 0.02 (got 0.04)"),
    ],
)
def test_a_scenario_refuses_intervals_off_its_signal_naming_the_field(kind, T, message):
    """In the scenario and in a case alike: the T of each scenario's own signal (C/A's 1 to 20
    whole milliseconds, E1-C's whole 4 ms periods up to its 100 ms overlay)."""
    with pytest.raises(ConfigError) as err:
        get_scenario({"kind": kind, "coherent_time_s": T})
    assert str(err.value) == f"scenario.coherent_time_s: {message}"
    with pytest.raises(ConfigError) as err:
        get_scenario({"kind": kind}).check_case({"coherent_time_s": T}, "cases[0]")
    assert str(err.value) == f"cases[0].coherent_time_s: {message}"


def test_a_ca_scenario_takes_twenty_whole_milliseconds():
    assert get_scenario({"kind": "tracking-threshold", "coherent_time_s": 0.02}).params.coherent_time_s == 0.02
