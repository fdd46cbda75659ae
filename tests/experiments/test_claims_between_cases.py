"""Claims between cases (``reference_case``) and cases on common random numbers (``streams``).

A case that differs from another only by a scenario option (an error source switched on)
is compared with it by pairing run ``r`` of both; the pairing removes the shared noise only
when both cases draw the same random numbers, which a case's ``streams`` gives.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.experiments.claims import evaluate_claims
from gnssframework.experiments.runner import run_comparison
from gnssframework.experiments.store import ResultStore

CONFIG = """
name = "between-cases"
runs = {runs}
batch_size = 2
seed = 11
[executor]
workers = 1
[scenario]
kind = "multipath"
epochs = 60
[[cases]]
name = "nominal"
[[cases]]
name = "psi9"
psi = 0.9
{streams}
[[candidates]]
name = "a"
nav_filter = {{ name = "position-ca" }}
estimator = {{ name = "kf" }}
{claims}
"""


def _config(tmp_path, claims: str = "", streams: str = 'streams = "nominal"', runs: int = 4):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.format(claims=claims, streams=streams, runs=runs))
    return load_config(path)


def _claim(**fields) -> str:
    return "[[claims]]\n" + "\n".join(f"{k} = {json.dumps(v)}" for k, v in fields.items()) + "\n"


def _store(tmp_path, config, nominal, other):
    store = ResultStore(tmp_path / "results.sqlite")
    key = config.identity()
    store.register(key, config.batch_size)
    for case, values in (("nominal", nominal), ("psi9", other)):
        for first in (0, 2):
            store.add_batch(
                key, case, "a", first, {m: np.asarray(values[first : first + 2], float) for m in config.metric_names}
            )
    return store


# psi9 minus nominal, run by run: d = (0.5, 0.5, 1.0, 0.5): mean 0.625, SE 0.125,
# t(0.975, 3) = 3.182 -> interval (0.227, 1.023): higher in psi9, significantly. Unpaired,
# the same values would not tell (the runs' spread, about 1.3, dwarfs the difference).
NOMINAL = [1.0, 2.0, 3.0, 4.0]
OTHER = [1.5, 2.5, 4.0, 4.5]


@pytest.mark.parametrize("direction, outcome", [("higher", "holds"), ("lower", "fails")])
def test_a_claim_between_cases_is_decided_by_the_paired_differences(tmp_path, direction, outcome):
    config = _config(
        tmp_path, _claim(candidate="a", metric="lat_error_rmse", reference_case="nominal", direction=direction)
    )
    (row,) = evaluate_claims(config, _store(tmp_path, config, NOMINAL, OTHER))
    assert (row["case"], row["reference"], row["reference_case"]) == ("psi9", "a", "nominal")
    assert row["diff"] == pytest.approx(0.625) and row["se"] == pytest.approx(0.125) and row["n"] == 4
    assert row["outcome"] == outcome
    assert row["statement"] == f"a: lat_error_rmse {direction} than in nominal"


def test_a_claim_between_cases_the_runs_cannot_tell_is_not_significant(tmp_path):
    config = _config(
        tmp_path,
        _claim(candidate="a", metric="lat_error_rmse", reference_case="nominal", case="psi9", direction="higher"),
    )
    noisy = [2.0, 1.5, 5.0, 3.6]  # d = (1.0, -0.5, 2.0, -0.4): mean 0.525, SE 0.59
    (row,) = evaluate_claims(config, _store(tmp_path, config, NOMINAL, noisy))
    assert row["outcome"] == "not significant"


def test_a_ratio_between_cases_and_another_candidate_as_reference(tmp_path):
    # reference = the same candidate named explicitly gives the same row as the default.
    config = _config(
        tmp_path,
        _claim(candidate="a", reference="a", metric="lat_error_rmse", reference_case="nominal", ratio_min=1.05),
    )
    (row,) = evaluate_claims(config, _store(tmp_path, config, NOMINAL, OTHER))
    assert row["ratio"] == pytest.approx(12.5 / 10.0)
    assert row["outcome"] in ("holds", "not significant")  # decided by the ratio's interval (its SE)
    half = 3.182 * row["ratio_se"]
    assert row["outcome"] == ("holds" if row["ratio"] - half > 1.05 else "not significant")


@pytest.mark.parametrize(
    "fields, field, message",
    [
        (
            {"reference_case": "x", "direction": "higher"},
            "claims[0].reference_case",
            "unknown reference_case 'x'; allowed: nominal, psi9",
        ),
        ({"reference_case": "nominal", "case": "nominal", "direction": "higher"}, "claims[0]", "compare two cases"),
        ({"reference_case": "nominal"}, "claims[0]", "an ordering between cases needs direction"),
        ({"reference_case": "nominal", "direction": "higher", "within": [0, 1]}, "claims[0]", "separate claim"),
    ],
)
def test_bad_claims_between_cases_are_refused_at_load(tmp_path, fields, field, message):
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, _claim(candidate="a", metric="lat_error_rmse", **fields))
    assert str(err.value).startswith(field) and message in str(err.value)


def test_a_bad_streams_name_is_refused_naming_the_field(tmp_path):
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, streams='streams = "no such/name"')
    assert "cases[1].streams" in str(err.value)
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, streams='streams = "nominl"')
    assert str(err.value).startswith("cases[1].streams") and "unknown case 'nominl'; allowed: nominal, psi9" in str(
        err.value
    )


@pytest.mark.slow
def test_a_case_on_another_cases_streams_draws_its_random_numbers(tmp_path):
    # psi equal to the scenario's: with the nominal case's streams the runs are the same
    # run for run, to the bit; on its own streams they are other runs.
    values = {}
    for label, streams in (("shared", 'streams = "nominal"'), ("own", "")):
        path = tmp_path / f"{label}.toml"
        path.write_text(CONFIG.format(claims="", streams=streams, runs=4).replace("psi = 0.9", "psi = 0.95"))
        config = load_config(path)
        run_comparison(config, tmp_path / label, progress=False)
        store = ResultStore(tmp_path / label / "results.sqlite")
        values[label] = [
            store.run_values(config.identity(), case, "a", "lat_error_rmse", 4) for case in ("nominal", "psi9")
        ]
    assert values["shared"][0] == values["shared"][1]
    assert values["own"][0] == values["shared"][0]  # the nominal case keeps its streams
    assert all(values["own"][0][r] != values["own"][1][r] for r in range(4))


@pytest.mark.slow
def test_the_pairing_between_cases_is_real_on_common_random_numbers(tmp_path):
    # Two cases that differ only by an option (the AR(1) coefficient of the multipath), the
    # second on the first's streams: the paired difference's SE is far below the unpaired
    # one (the SE of the difference of two independent means), i.e. the shared noise cancels:
    # their ratio is sqrt(1 - rho) for runs correlated rho between the cases, about 1 on
    # independent streams and below 0.5 once rho > 0.75 (about 0.9 here: AR(1) noise with
    # psi 0.95 and 0.9 from the same innovations).
    runs = 16
    config = _config(
        tmp_path, _claim(candidate="a", metric="lat_error_rmse", reference_case="nominal", direction="lower"), runs=runs
    )
    run_comparison(config, tmp_path / "out", progress=False)
    (row,) = evaluate_claims(config, ResultStore(tmp_path / "out" / "results.sqlite"))
    store = ResultStore(tmp_path / "out" / "results.sqlite")
    x, y = (
        np.array(list(store.run_values(config.identity(), c, "a", "lat_error_rmse", runs).values()))
        for c in ("psi9", "nominal")
    )
    unpaired_se = float(np.sqrt(np.var(x, ddof=1) / runs + np.var(y, ddof=1) / runs))
    assert row["n"] == runs and row["se"] == pytest.approx(float(np.std(x - y, ddof=1) / np.sqrt(runs)))
    assert row["se"] < 0.5 * unpaired_se, (row["se"], unpaired_se)
