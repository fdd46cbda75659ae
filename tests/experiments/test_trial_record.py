"""A tuning's trials as a file (gnssframework.experiments.trial_record): a second machine
evaluates at the values the first one's tuning selected without rerunning a trial, and a
record of another config is refused."""

from __future__ import annotations

import json
import math

import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config, run_comparison
from gnssframework.experiments import tuning as tuning_module
from gnssframework.experiments.trial_record import TRIALS_FILE

from test_tuning import BASE


def _config(tmp_path, name="t.toml", trials=4, seed=None):
    text = BASE.format(sampler="random", trials=trials, path="candidates.ar1.nav_filter.params.r0")
    if seed is not None:
        text = text.replace("seed = 3", f"seed = {seed}")
    (tmp_path / name).write_text(text)
    return load_config(tmp_path / name)


@pytest.mark.slow
def test_a_record_selects_the_same_values_without_rerunning_a_trial(tmp_path, monkeypatch):
    pytest.importorskip("optuna", reason="the 'tune' extra")
    first = json.loads(run_comparison(_config(tmp_path), tmp_path / "first", progress=False).read_text())
    record = json.loads((tmp_path / "first" / TRIALS_FILE).read_text())
    assert [len(v) for v in record["trials"].values()] == [4]  # ar1 only: the one candidate tuned
    objectives = [t["objective"] for t in record["trials"]["ar1"]]
    assert first["tuning"][0]["objective"] == min(objectives)

    def no_trial(*args):
        raise AssertionError("a recorded trial was rerun")

    monkeypatch.setattr(tuning_module, "_run_trial", no_trial)
    second = json.loads(
        run_comparison(
            _config(tmp_path), tmp_path / "second", progress=False, trials_from=tmp_path / "first" / TRIALS_FILE
        ).read_text()
    )
    assert second["tuning"] == first["tuning"] and second["rows"] == first["rows"]
    assert json.loads((tmp_path / "second" / TRIALS_FILE).read_text()) == record


@pytest.mark.slow
def test_a_record_of_another_budget_is_refused_before_any_trial(tmp_path, monkeypatch):
    pytest.importorskip("optuna", reason="the 'tune' extra")
    run_comparison(_config(tmp_path, trials=3), tmp_path / "three", progress=False)
    calls = []
    real = tuning_module._run_trial

    def counted(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(tuning_module, "_run_trial", counted)
    # A budget of 4 is another config (the identity holds the tuning): its record is refused,
    # before a trial runs, rather than continued by a sampler that saw other trials.
    with pytest.raises(ConfigError, match="another identity"):
        run_comparison(
            _config(tmp_path, trials=4), tmp_path / "four", progress=False, trials_from=tmp_path / "three" / TRIALS_FILE
        )
    assert not calls


def test_records_of_other_configs_and_broken_files_are_refused(tmp_path):
    config = _config(tmp_path)
    other = _config(tmp_path, name="o.toml", seed=4)
    record = tmp_path / "r.json"
    record.write_text(
        json.dumps(
            {
                "config": other.name,
                "identity": other.identity(),
                "trials": {"ar1": [{"values": [1.0], "objective": 1.0}]},
            }
        )
    )
    with pytest.raises(ConfigError, match=r"trials_from: .*r\.json: recorded for config 'tuned' with another"):
        run_comparison(config, tmp_path / "a", progress=False, trials_from=record)
    record.write_text(
        json.dumps(
            {
                "config": config.name,
                "identity": config.identity(),
                "trials": {"kf": [{"values": [1.0], "objective": 1.0}]},
            }
        )
    )
    with pytest.raises(ConfigError, match="candidate 'kf' is not tuned by 'tuned'"):
        run_comparison(config, tmp_path / "b", progress=False, trials_from=record)
    record.write_text(
        json.dumps(
            {
                "config": config.name,
                "identity": config.identity(),
                "trials": {"ar1": [{"values": [1.0, 2.0], "objective": 1.0}]},
            }
        )
    )
    with pytest.raises(ConfigError, match="trial 0: 2 values for 1 free parameters"):
        run_comparison(config, tmp_path / "c", progress=False, trials_from=record)
    record.write_text("{not json")
    with pytest.raises(ConfigError, match=r"r\.json: not a trial record"):
        run_comparison(config, tmp_path / "d", progress=False, trials_from=record)
    untuned = load_config(tmp_path / "t.toml")
    untuned.tuning = None
    with pytest.raises(ConfigError, match="has no \\[tuning\\] to seed"):
        run_comparison(untuned, tmp_path / "e", progress=False, trials_from=record)


def test_a_failed_trial_is_recorded_as_null_and_read_back_as_inf(tmp_path):
    from gnssframework.experiments.store import ResultStore
    from gnssframework.experiments.trial_record import seed_trials, write_trial_record

    config = _config(tmp_path)
    write_trial_record(
        tmp_path / "r.json",
        config,
        {"ar1": {"trials": [{"values": [1.0], "objective": math.inf}, {"values": [2.0], "objective": 0.5}]}},
    )
    assert json.loads((tmp_path / "r.json").read_text())["trials"]["ar1"][0]["objective"] is None
    store = ResultStore(tmp_path / "s.sqlite")
    assert seed_trials(tmp_path / "r.json", config, store) == 2
    assert store.trials(config.identity(), "ar1") == [([1.0], math.inf), ([2.0], 0.5)]
