"""The deep-integration scenario: which compositions it runs, and clear errors for the others."""

from __future__ import annotations

import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.experiments.scenarios.deep_integration import _kind
from gnssframework.registry import create


def _plugins(channel, nav, **ch):
    return {"channel_filter": create("channel_filter", channel, **ch), "nav_filter": create("nav_filter", nav)}


def test_candidates_are_told_apart_by_what_they_compose():
    assert _kind(_plugins("iq-filter", "ins-ekf", output="equivalent")) == "deep"
    assert _kind(_plugins("scalar", "ins-ekf")) == "loose"
    assert _kind(_plugins("iq-filter", "ekf-pv")) == "vector"


def test_compositions_that_cannot_run_are_refused_naming_the_field():
    sc = get_scenario({"kind": "deep-integration", "duration_s": 1.0, "settle_s": 0.5})
    with pytest.raises(ConfigError, match=r"candidates\[0\]\.nav_filter\.name"):
        sc.check_composition(_plugins("iq-filter", "position-ca"), "candidates[0]")
    with pytest.raises(ConfigError, match=r"candidates\[1\]\.channel_filter\.name.*neither feed deep"):
        sc.check_composition(_plugins("kf-smoother", "ins-ekf"), "candidates[1]")


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("update_interval_s", 0.0125, "whole multiple"),
        ("nco_interval_s", 0.0015, "whole multiple"),
        ("settle_s", 2.0, "settle_s"),
        ("clock", "rubidium", "allowed"),
    ],
)
def test_bad_rates_and_settings_get_config_errors(field, value, match):
    with pytest.raises(ConfigError, match=match):
        get_scenario({"kind": "deep-integration", "duration_s": 1.0, "settle_s": 0.5, field: value})
