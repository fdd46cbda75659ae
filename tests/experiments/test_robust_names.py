"""Issue 38: names that are paths are refused (on main a case or candidate named '..'
wrote raw series into the parent of --out, a comparison named '../../../x' wrote outside
results/, '' wrote into results/ itself and a NUL gave a traceback); a config cannot name
a Dask scheduler (its protocol carries pickles)."""

from __future__ import annotations

import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config

from two_candidates import two_candidate_config


def _load(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return load_config(path)


@pytest.mark.parametrize(
    "old, new, field",
    [
        ('name = "x"', 'name = ".."', "name"),
        ('name = "x"', 'name = "../../../x"', "name"),
        ('name = "x"', 'name = ""', "name"),
        ('name = "x"', 'name = "a\\u0000b"', "name"),
        ('name = "x"', 'name = "a\\\\b"', "name"),
        ('name = "only"', 'name = ".."', "cases[0].name"),
        ('name = "only"', 'name = "."', "cases[0].name"),
        ('name = "a"', 'name = ".."', "candidates[0].name"),
    ],
)
def test_names_that_are_paths_are_refused(tmp_path, old, new, field):
    text = two_candidate_config("x").replace(old, new, 1)
    assert new in text
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, text)
    assert err.value.field == field, str(err.value)


def test_a_sweep_named_like_a_folder_is_refused(tmp_path):
    sweep = '[[sweeps]]\npath = "scenario.psi"\nname = ".."\nvalues = [0.5]\n'
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, two_candidate_config("x", sweeps=sweep))
    assert err.value.field == "sweeps[0].name"


def test_plain_names_still_load(tmp_path):
    config = _load(tmp_path, two_candidate_config("my comparison 2.0"))
    assert config.name == "my comparison 2.0"


@pytest.mark.slow
def test_a_nul_in_the_name_is_one_line_from_the_cli(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("x").replace('name = "x"', 'name = "a\\u0000b"', 1))
    assert main(["compare", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: name:")


def test_a_config_cannot_name_a_dask_scheduler(tmp_path):
    text = two_candidate_config("x").replace(
        "[executor]\nworkers = 1", '[executor]\nkind = "dask"\naddress = "tcp://example.org:8786"'
    )
    with pytest.raises(ConfigError) as err:
        _load(tmp_path, text)
    assert err.value.field == "executor.address" and "pickles" in str(err.value)
    assert "--dask-address" in str(err.value) and "GNSSFRAMEWORK_DASK_ADDRESS" in str(err.value)


@pytest.mark.slow
def test_the_address_comes_from_the_command_line(tmp_path, monkeypatch):
    seen = {}

    def run(config, out, progress=True, **kwargs):
        seen["executor"] = config.executor
        raise KeyboardInterrupt

    monkeypatch.setattr("gnssframework.experiments.run_comparison", run)
    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("x"))
    assert main(["compare", str(path), "--out", str(tmp_path / "o"), "--dask-address", "tcp://h:8786"]) == 130
    assert seen["executor"].kind == "dask" and seen["executor"].address == "tcp://h:8786"
