"""A claim's replication as a stated part of it (`Claim.replicates`, issue 42).

`compare --check --replicate` re-checks every claim on a second, disjoint set of runs and
fails when one does not hold there. A claim that holds on the evaluation runs only is
stated so in its config (``replicates = false``) and on its page: the check then demands
it on the evaluation runs and reports its replicate outcome, marked, whatever it is (it
sits near the edge of significance there, where rounding may tip it)."""

from __future__ import annotations

import json

import pytest
from pydantic import ValidationError

from gnssframework.cli import _report_claims
from gnssframework.experiments.claims import Claim, replication_failed
from gnssframework.experiments.report import replicate_claims

ORDERING = {"candidate": "a", "reference": "b", "metric": "m", "direction": "lower"}


def _row(i: int, outcome: str = "holds") -> dict:
    return {"claim": i, "case": "c", "outcome": outcome, "statement": f"claim {i}", "n": 12}


@pytest.mark.parametrize(
    ("stated", "replicate", "failed"),
    [
        (True, "holds", False),
        (True, "not significant", True),
        (True, "fails", True),
        (False, "not significant", False),
        (False, "fails", False),
        (False, "holds", False),  # reported, not checked: near the edge, rounding may tip it
    ],
)
def test_replication_is_checked_against_what_the_claim_states(stated, replicate, failed):
    (row,) = [_row(0)]
    replicate_claims([row], [{"outcome": replicate}], [stated])
    assert row["replicates"] is stated and row["replicate_outcome"] == replicate
    assert replication_failed(row) is failed


def test_a_row_not_run_on_replicate_runs_has_no_replication_to_fail():
    assert not replication_failed(_row(0))
    assert not replication_failed({**_row(0), "replicates": False})


def test_the_statement_is_the_configs_strict_bool():
    assert Claim(**ORDERING).replicates is True
    assert Claim(**ORDERING, replicates=False).replicates is False
    with pytest.raises(ValidationError):
        Claim(**ORDERING, replicates="no")


def _summary(tmp_path, rows: list[dict]):
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"name": "x", "claims": rows}))
    return path


def test_compare_check_passes_a_claim_stated_and_found_to_hold_on_one_seed_set(tmp_path, capsys):
    rows = [_row(0), _row(1)]
    replicate_claims(rows, [{"outcome": "holds"}, {"outcome": "not significant"}], [True, False])
    assert _report_claims(_summary(tmp_path, rows), check=True) == 0
    out = capsys.readouterr().out
    assert "2 of 2 hold on both seed sets as stated (1 stated to hold on the evaluation runs only)" in out
    assert "replicate seed set: not significant (stated: holds on the evaluation runs only)" in out


@pytest.mark.parametrize("replicate", ["not significant", "fails", "refused"])
def test_compare_check_fails_a_claim_stated_to_replicate_that_does_not(tmp_path, replicate):
    rows = [_row(0)]
    replicate_claims(rows, [{"outcome": replicate}], [True])
    assert _report_claims(_summary(tmp_path, rows), check=True) == 1


def test_a_claim_that_fails_on_the_evaluation_runs_fails_whatever_it_states(tmp_path):
    rows = [_row(0, "not significant")]
    replicate_claims(rows, [{"outcome": "fails"}], [False])
    assert _report_claims(_summary(tmp_path, rows), check=True) == 1


def test_the_report_says_which_claims_are_stated_to_hold_on_one_seed_set():
    from gnssframework.experiments.report import _claims_markdown

    rows = [{**_row(0), "diff": 1.0}, {**_row(1), "diff": 1.0}]
    replicate_claims(rows, [{"outcome": "holds"}, {"outcome": "fails"}], [True, False])
    text = "\n".join(_claims_markdown(rows, replicated=True))
    assert "1 hold on both, 1 on one seed set only (1 stated so: `replicates = false`)" in text
    assert "| holds (replicate: fails; stated: evaluation runs only) | c | claim 1 |" in text


def test_every_kind_of_claim_row_names_its_replicate_outcome():
    from gnssframework.experiments.claims import claim_evidence

    threshold = {**_row(0), "point": "threshold", "threshold_difference": 1.8, "threshold_ci95": [1.2, 2.2]}
    refused = {**_row(1, "refused"), "reason": "no spread"}
    for row in (threshold, refused):
        replicate_claims([row], [{"outcome": "holds"}], [True, True])
        assert claim_evidence(row).endswith("; replicate seed set: holds")
