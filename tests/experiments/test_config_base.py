"""``[base]``: a comparison config laid over another (`experiments.config_base`).

The truth for the examples built so is the file written out in full: the realistic and CI
variants were, before they took a base, whole files; each is checked against the same
config assembled here from its control by the documented rule (tables merged, arrays
replaced unless extended, dropped names gone), independently of the resolver. And the rules' edges: a
chain of bases, a base that reaches itself, a dropped name the base lacks, an unknown key.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.experiments import ComparisonConfig, load_config
from gnssframework.experiments.config_base import read_config_data

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

#: Each variant, its control, and what it changes (as its comments state).
VARIANTS = {
    "vector_tracking_realistic": "vector_tracking",
    "deep_integration_realistic_ci": "deep_integration_ci",
    "deep_integration_elevation_ci": "deep_integration_ci",
    "deep_integration_lock_ci": "deep_integration_lock",
}


def _by_hand(variant: str) -> dict:
    """The variant assembled from the two files' raw TOML by the documented rule."""
    raw = tomllib.loads((EXAMPLES / f"{variant}.toml").read_text())
    out = copy.deepcopy(tomllib.loads((EXAMPLES / f"{VARIANTS[variant]}.toml").read_text()))
    spec = raw.pop("base")
    for key in spec.get("drop", []):
        del out[key]
    for kind in ("candidates", "cases"):
        out[kind] = [c for c in out[kind] if c["name"] not in spec.get(f"drop_{kind}", [])]
    for dotted in spec.get("extend", []):  # the base's array first, then the variant's
        *tables, key = dotted.split(".")
        mine, theirs = raw, out
        for t in tables:
            mine, theirs = mine[t], theirs[t]
        mine[key] = theirs[key] + mine[key]
    for key, value in raw.items():
        if isinstance(value, dict):
            out[key] = {**out.get(key, {}), **value}  # one level deep: the variants' tables are flat merges
        else:
            out[key] = value
    return out


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_each_variant_is_its_control_with_what_it_says_it_changes(variant):
    resolved = read_config_data(EXAMPLES / f"{variant}.toml")
    assert "base" not in resolved
    assert resolved == _by_hand(variant)
    # The config, and so the results' key, is that of the whole file.
    whole = ComparisonConfig.model_validate(_by_hand(variant))
    assert load_config(EXAMPLES / f"{variant}.toml").identity() == whole.identity()


TINY = """
name = "tiny"
runs = 2
batch_size = 2
seed = 1

[scenario]
kind = "vector-tracking"
duration_s = 0.5
channels = 4
coherent_time_s = 0.01
settle_s = 0.1

[[cases]]
name = "45dBHz"
cn0_dbhz = 45.0

[[cases]]
name = "30dBHz"
cn0_dbhz = 30.0

[[candidates]]
name = "a"
channel_filter = "discriminator"
nav_filter = "ekf-pv"

[[candidates]]
name = "b"
channel_filter = "discriminator"
nav_filter = { name = "ekf-pv", params = { accel_psd = 1.0 } }
"""


def test_bases_chain_tables_merge_deeply_and_arrays_replace(tmp_path):
    (tmp_path / "a.toml").write_text(TINY)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.toml").write_text(
        'seed = 2\n[base]\nfile = "../a.toml"\ndrop_cases = ["30dBHz"]\n[scenario]\nduration_s = 0.3\n'
    )
    (tmp_path / "c.toml").write_text(
        'name = "c"\n[base]\nfile = "sub/b.toml"\ndrop_candidates = ["a"]\n'
        '[[cases]]\nname = "40dBHz"\ncn0_dbhz = 40.0\n'
    )
    c = load_config(tmp_path / "c.toml")
    assert (c.name, c.seed, c.runs) == ("c", 2, 2)
    assert [x.name for x in c.candidates] == ["b"] and [x.name for x in c.cases] == ["40dBHz"]
    assert c.scenario["duration_s"] == 0.3 and c.scenario["channels"] == 4


def test_extend_appends_to_the_named_arrays_and_others_still_replace(tmp_path):
    tiny = TINY + '[tuning]\ntrials = 2\nruns = 1\nmetric = "velocity_error_rmse"\n'
    tiny += '[[tuning.free]]\npath = "candidates.b.nav_filter.params.accel_psd"\nlow = 0.1\nhigh = 1.0\n'
    (tmp_path / "a.toml").write_text(tiny)
    (tmp_path / "v.toml").write_text(
        '[base]\nfile = "a.toml"\nextend = ["candidates", "tuning.free"]\n'
        '[[candidates]]\nname = "c"\nchannel_filter = "discriminator"\nnav_filter = "ekf-pv"\n'
        '[[tuning.free]]\npath = "candidates.c.nav_filter.params.accel_psd"\nlow = 0.1\nhigh = 1.0\n'
        '[[cases]]\nname = "40dBHz"\ncn0_dbhz = 40.0\n'
    )
    c = load_config(tmp_path / "v.toml")
    assert [x.name for x in c.candidates] == ["a", "b", "c"]
    assert [f.path for f in c.tuning.free] == [
        "candidates.b.nav_filter.params.accel_psd",
        "candidates.c.nav_filter.params.accel_psd",
    ]
    assert c.tuning.trials == 2  # the table still merges
    assert [x.name for x in c.cases] == ["40dBHz"]  # an array not named in extend replaces


@pytest.mark.parametrize(
    "text, field, words",
    [
        ('[base]\nfile = "a.toml"\nextend = ["claims"]\n[[claims]]\n', "base.extend", "a.toml has no array 'claims'"),
        ('[base]\nfile = "a.toml"\nextend = ["cases"]\n', "base.extend", "v.toml has no array 'cases'"),
        ('[base]\nfile = "a.toml"\nextend = ["name.x"]\n', "base.extend", "'name' is not a table"),
        ('[base]\nfile = "a.toml"\ndrop_candidates = ["z"]\n', "base.drop_candidates", "a.toml has no candidate 'z'"),
        ('[base]\nfile = "a.toml"\ndrop_cases = ["z"]\n', "base.drop_cases", "has no case 'z'"),
        ('[base]\nfile = "a.toml"\ndrop = ["published"]\n', "base.drop", "no key 'published'"),
        ('[base]\nfile = "a.toml"\nextends = 1\n', "base.extends", "unknown key"),
        ('base = "a.toml"\n', "base", "a table with file"),
        ('[base]\nfile = "a.toml"\ndrop = "claims"\n', "base.drop", "a list of names"),
        ('[base]\nfile = "x.toml"\n', "base.file", "includes itself"),
    ],
)
def test_a_bad_base_is_one_line_naming_its_field(tmp_path, text, field, words):
    (tmp_path / "a.toml").write_text(TINY)
    (tmp_path / "y.toml").write_text('[base]\nfile = "x.toml"\n')
    path = tmp_path / ("x.toml" if "x.toml" in text else "v.toml")
    if path.name == "x.toml":
        text = '[base]\nfile = "y.toml"\n'
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert info.value.field == field and words in str(info.value), str(info.value)


def test_the_compare_command_reports_a_bad_base_in_one_line(tmp_path, capsys):
    (tmp_path / "a.toml").write_text(TINY)
    (tmp_path / "v.toml").write_text('[base]\nfile = "a.toml"\ndrop_candidates = ["z"]\n')
    assert main(["compare", str(tmp_path / "v.toml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "base.drop_candidates" in err[0] and "'a', 'b'" in err[0]
