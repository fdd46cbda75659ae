"""Reference 004's fair tuning (examples/multipath.toml, issue 42): every filter is tuned
by the same procedure, budget and ranges; the rows left as given say so."""

from pathlib import Path

import pytest

from gnssframework.experiments import load_config
from gnssframework.experiments.claims import untuned_candidates
from gnssframework.experiments.tuning import resolve_free

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "multipath.toml"


@pytest.fixture(scope="module")
def config():
    return load_config(EXAMPLE)


def test_every_candidate_is_tuned_or_marked_as_given(config):
    tuned = set(resolve_free(config))
    given = {c.name for c in config.candidates if c.as_given}
    names = {c.name for c in config.candidates}
    assert tuned | given == names and not tuned & given
    paper = {"UKF-paper", "UKF1-paper", "AUKF-paper", "AUKF1-paper"}
    assert set(untuned_candidates(config)) == given == {"raw", "oracle"} | paper
    # Every other filter is tuned (raw has none; the oracle picks its own grid point).
    filters = {c.name for c in config.candidates if c.nav_filter is not None} - {"oracle"} - paper
    assert filters == tuned == {"UKF", "UKF1", "UKF1-lag1", "UKF1-exact", "AUKF", "AUKF1"}


def test_the_as_given_filters_are_the_papers_literal_settings(config):
    # Reference 004 (/work/shared/references/README.md): Q0 = diag(1, 0.1, 0.01), R0 = 1,
    # alpha1 = alpha2 = 0.5, UKF alpha 0.01, beta 2, kappa 0.
    for cand in (c for c in config.candidates if c.name.endswith("-paper")):
        assert cand.as_given
        assert cand.nav_filter.params["q0"] == [1.0, 0.1, 0.01] and cand.nav_filter.params["r0"] == 1.0
        assert cand.estimator.params == {"alpha": 0.01, "beta": 2.0, "kappa": 0.0}
        if cand.noise_adapter is not None:
            assert cand.noise_adapter.params["alpha_r"] == cand.noise_adapter.params["alpha_q"] == 0.5


def test_every_tuned_candidate_gets_the_same_ranges_and_the_claims_metric(config):
    ranges: dict[str, set] = {}
    for _cand, params in resolve_free(config).items():
        for free, _keys, label in params:
            ranges.setdefault(label, set()).add((free.low, free.high, free.scale, free.type))
    assert all(len(r) == 1 for r in ranges.values()), ranges
    # Q0 and R0 free for every filter, the Sage-Husa factors for the adaptive ones, and
    # no psi: it is the case's truth (or UKF1-lag1's estimate), not a tuning knob.
    by_candidate = {c: {label for _, _, label in p} for c, p in resolve_free(config).items()}
    common = {f"nav_filter.params.q0.{i}" for i in range(3)} | {"nav_filter.params.r0"}
    adaptive = {"noise_adapter.params.alpha_r", "noise_adapter.params.alpha_q"}
    for cand, labels in by_candidate.items():
        has_adapter = next(c for c in config.candidates if c.name == cand).noise_adapter is not None
        assert labels == (common | adaptive if has_adapter else common), cand
    assert {c.metric for c in config.claims} == {config.tuning.metric}
