"""Issue 38: a tuning range that is not finite is refused at load, and a tuning whose
trials mostly failed is an error, not a "tuned" value (on main `high = inf` failed 2 of 3
trials and reported the lower bound as tuned, exit 0)."""

from __future__ import annotations

import math

import pytest

from gnssframework.errors import ConfigError, GnssFrameworkError
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments import tuning as tuning_module

from test_tuning import BASE


def _text(**replace):
    text = BASE.format(sampler="grid", trials=4, path="candidates.kf.nav_filter.params.r0")
    for old, new in replace.items():
        text = text.replace(old, new)
    return text


@pytest.mark.parametrize(
    "old, new",
    [
        ("high = 100.0", "high = inf"),
        ("low = 0.1", "low = -inf"),
        ("high = 100.0", "high = nan"),
        ('low = 0.1\nhigh = 100.0\nscale = "log"', "values = [1.0, nan]"),
    ],
)
def test_non_finite_free_bounds_are_refused_at_load(tmp_path, old, new):
    path = tmp_path / "t.toml"
    path.write_text(BASE.format(sampler="grid", trials=4, path="candidates.kf.nav_filter.params.r0").replace(old, new))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert "tuning.free" in str(err.value) and "finite" in str(err.value), str(err.value)


@pytest.mark.slow
def test_a_tuning_whose_trials_mostly_fail_is_an_error(tmp_path, monkeypatch):
    path = tmp_path / "t.toml"
    path.write_text(_text())
    config = load_config(path)

    def run(config, store, trial, execute):  # every trial but the one at the lower bound fails
        return 1.0 if trial.candidates[0].nav_filter.params["r0"] < 0.2 else math.inf

    monkeypatch.setattr(tuning_module, "_run_trial", run)
    with pytest.raises(GnssFrameworkError, match=r"3 of 4 trials of candidate 'kf' failed"):
        run_comparison(config, tmp_path / "out", progress=False)
