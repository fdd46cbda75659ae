"""Issue 38: configs that misled or did unbounded work (each accepted, or refused in
other words, on main): a UTF-8 byte-order mark, an unbounded sweep values list and
case/candidate lists, no work estimate before a long comparison, a candidate named by
index only, an AR(1) psi = 1e6 caught only after a run."""

from __future__ import annotations

import time

import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.experiments.runner import work_estimate

from two_candidates import two_candidate_config


def _write(tmp_path, text, name="c.toml", bom=False):
    path = tmp_path / name
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    return path


def test_a_config_with_a_byte_order_mark_loads(tmp_path):
    config = load_config(_write(tmp_path, two_candidate_config("bom"), bom=True))
    assert config.name == "bom" and [c.name for c in config.candidates] == ["a", "b"]


def test_a_long_explicit_sweep_values_list_is_refused_quickly(tmp_path):
    values = ", ".join(str(0.1 + i * 1e-6) for i in range(100_000))
    sweep = f'[[sweeps]]\npath = "scenario.psi"\nvalues = [{values}]\n'
    started = time.monotonic()
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, two_candidate_config("big", sweeps=sweep)))
    assert time.monotonic() - started < 20  # main spent about two minutes validating them
    assert str(err.value).startswith("sweeps[0].values") and "1000" in str(err.value), str(err.value)


@pytest.mark.parametrize("sweep", ["start = nan\nstop = 1.0\nnum = 3", "start = 0.1\nstop = 0.5\nstep = inf"])
def test_a_non_finite_sweep_range_is_refused(tmp_path, sweep):
    text = two_candidate_config("r", sweeps=f'[[sweeps]]\npath = "scenario.psi"\n{sweep}\n')
    with pytest.raises(ConfigError, match="sweeps\\[0\\].*finite"):
        load_config(_write(tmp_path, text))


def test_more_cases_than_the_bound_are_refused(tmp_path):
    text = two_candidate_config("many")
    extra = "".join(f'[[cases]]\nname = "c{i}"\n' for i in range(1001))
    text = text.replace("[[candidates]]", extra + "[[candidates]]", 1)
    with pytest.raises(ConfigError, match=r"^cases: .*1000"):
        load_config(_write(tmp_path, text))


def test_the_work_estimate_counts_cases_candidates_batches_and_sweep_points(tmp_path):
    sweep = '[[sweeps]]\npath = "scenario.psi"\nvalues = [0.5, 0.7, 0.9]\n'
    config = load_config(_write(tmp_path, two_candidate_config("w", sweeps=sweep)))
    # 1 case x 2 candidates x 2 batches (4 runs in 2s), for the comparison and 3 points
    # (none equal to the comparison's own scenario: psi is not set there)
    assert work_estimate(config) == (4 * 2 * 2 * 1, 4 * 2 * 4 * 1)


@pytest.mark.slow
def test_a_long_comparison_prints_its_work_before_it_starts(tmp_path, capsys, monkeypatch):
    from gnssframework.experiments import runner

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "run_comparison", stop)
    monkeypatch.setattr("gnssframework.experiments.run_comparison", stop)
    sweep = '[[sweeps]]\npath = "scenario.psi"\nstart = 0.1\nstop = 0.9\nnum = 30\n'
    path = _write(tmp_path, two_candidate_config("long", sweeps=sweep))
    assert main(["compare", str(path), "--out", str(tmp_path / "out")]) == 130
    out = capsys.readouterr().out
    assert out.startswith("work: 124 batches, 248 filter runs")


@pytest.mark.slow
def test_a_config_error_names_the_candidate_as_written(tmp_path, capsys):
    text = two_candidate_config("n").replace(
        'nav_filter = { name = "position-ca" }\nestimator = { name = "ckf" }',
        'nav_filter = { name = "position-ca", params = { r0 = -1.0 } }\nestimator = { name = "ckf" }',
    )
    assert main(["compare", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "candidates[1].nav_filter.params.r0" in err and "(candidates[1] is 'b')" in err, err


def test_an_ar1_psi_outside_the_unit_interval_is_refused_at_load(tmp_path):
    text = two_candidate_config("psi").replace(
        'estimator = { name = "ckf" }',
        'estimator = { name = "ckf" }\naugmentation = { name = "colored-ar1", params = { psi = 1e6 } }',
    )
    with pytest.raises(ConfigError, match=r"candidates\[1\]\.augmentation.*psi.*\|psi\| < 1"):
        load_config(_write(tmp_path, text))
