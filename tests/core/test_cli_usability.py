"""The command line as a new user meets it: defaults in --help, no reST markup, a quiet
closed pipe, an empty listing that says so, did-you-mean for a mistyped name, one wording
for a missing file, a navigation file named as such, PRNs written any usual way, no
progress bar in a log."""

from __future__ import annotations

import argparse
import csv
import re
import subprocess
import sys
from pathlib import Path

import pytest

import gnssframework.experiments as experiments
from conftest import builtin_plugins
from gnssframework import registry
from gnssframework.cli import build_parser, main, plain_text
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.suggest import closest

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).parents[1] / "data"
EXAMPLE = (ROOT / "examples" / "vector_tracking.toml").read_text()
REST = re.compile(r"``|:(class|func|meth|mod|attr|data):`")


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


@pytest.mark.parametrize("command", sorted(_subparsers()))
def test_help_shows_every_default(command):
    parser = _subparsers()[command]
    text = " ".join(parser.format_help().split())  # the help wraps lines
    for action in parser._actions:
        if action.option_strings and action.default not in (None, False, argparse.SUPPRESS) and action.help:
            # The default as the help writes it: %(default)s or %(default)g.
            shown = {str(action.default), f"{action.default:g}" if isinstance(action.default, float) else ""}
            assert any(f"default: {s})" in text or f"default {s}" in text for s in shown if s), (
                command,
                action.dest,
                action.default,
            )


def test_no_rest_markup_in_help_or_the_plugin_listing(capsys):
    texts = [build_parser().format_help()] + [p.format_help() for p in _subparsers().values()]
    assert main(["plugins"]) == 0
    texts.append(capsys.readouterr().out)
    for info in builtin_plugins():
        assert main(["plugins", "--kind", info.kind, "--describe", info.name]) == 0
        texts.append(capsys.readouterr().out)
    assert not [t for t in texts if REST.search(t)]
    assert plain_text("a ``b`` :class:`~x.y.Z` :func:`f <m.f>` :mod:`gnssframework.io`") == "a b Z f gnssframework.io"


@pytest.mark.slow
def test_schema_into_a_closed_pipe_ends_quietly():
    proc = subprocess.run(
        f"'{sys.executable}' -m gnssframework schema | head -n 2", shell=True, capture_output=True, text=True, cwd=ROOT
    )
    assert proc.stdout.splitlines() == ["{", '  "$defs": {'] and proc.stderr == ""


def test_an_empty_kind_says_so(capsys, monkeypatch):
    monkeypatch.setattr(registry, "describe", lambda: [])
    assert main(["plugins", "--kind", "metric"]) == 0
    assert capsys.readouterr().out == "no metric plugin is registered\n"


@pytest.mark.parametrize(
    ("old", "new", "hint"),
    [
        ("runs = 12", "runz = 12", "; did you mean 'runs'?"),
        ('window = 20, output = "split"', 'windw = 20, output = "split"', "; did you mean 'window'?"),
        ('clock = "ocxo"       #', 'clock = "OCXO"       #', "; did you mean 'ocxo'?"),
        (
            'estimator = "svd-ckf", adapter = "innovation", window = 20, output = "split"',
            'estimator = "UKF", adapter = "innovation", window = 20, output = "split"',
            "; did you mean 'ukf'?",
        ),
        ('output = "split"', 'output = "Split"', "; did you mean 'split'?"),
    ],
)
def test_a_mistyped_name_gets_did_you_mean(tmp_path, old, new, hint):
    assert old in EXAMPLE
    path = tmp_path / "c.toml"
    path.write_text(EXAMPLE.replace(old, new, 1))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value).endswith(hint)


def test_describe_suggests_a_plugin_written_in_another_case(capsys):
    assert main(["plugins", "--describe", "SVD-CKF"]) == 2
    assert capsys.readouterr().err.endswith("did you mean 'svd-ckf'?\n")


def test_closest_prefers_a_case_fold_and_suggests_nothing_far():
    assert closest("SVD-CKF", ["ckf", "svd-ckf"]) == "svd-ckf"
    assert closest("qqqq", ["window", "warmup"]) is None


@pytest.mark.parametrize(
    "argv",
    [
        ["compare", "{p}"],
        ["smooth", "{p}", "--prn", "G08", "--out", "{o}"],
        ["filter-positions", "{p}", "--out", "{o}"],
        ["acquire", "{p}", "--out", "{o}", "--fs", "4e6", "--format", "ci8"],
        ["track", "{p}", "--out", "{o}", "--fs", "4e6", "--format", "ci8"],
    ],
)
def test_a_missing_file_is_worded_the_same_by_every_command(tmp_path, capsys, argv):
    missing = tmp_path / "not-there.dat"
    assert main([a.format(p=missing, o=tmp_path / "out") for a in argv]) == 2
    assert capsys.readouterr().err == f"error: {missing}: no such file\n"


@pytest.mark.parametrize("name", ["07590920.05n", "BRDC00IGS_R_20201361400_02H_EN.rnx"])
def test_smooth_names_a_navigation_file(tmp_path, capsys, name):
    assert main(["smooth", str(DATA / name), "--prn", "G08", "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "a navigation file (broadcast ephemeris" in err and "not an observation file" in err


def test_prn_written_any_usual_way_selects_the_same_satellite(tmp_path, capsys):
    outputs = []
    for i, prn in enumerate(["G08", "g08", "8", "g8"]):
        out = tmp_path / f"{i}.csv"
        assert main(["smooth", str(DATA / "07590920.05o"), "--prn", prn, "--out", str(out)]) == 0
        assert " G08: " in capsys.readouterr().out
        with out.open() as fh:
            rows = list(csv.DictReader(fh))
        assert rows and {r["sv"] for r in rows} == {"G08"}
        outputs.append(out.read_text())
    assert all(o == outputs[0] for o in outputs)


@pytest.mark.slow
def test_progress_unless_quiet_the_runner_choosing_bar_or_lines(tmp_path, monkeypatch, capsys):
    seen = {}

    def fake_run(config, out, progress, **kwargs):
        seen["progress"] = progress
        (Path(out) / "summary.json").parent.mkdir(parents=True, exist_ok=True)
        (Path(out) / "summary.json").write_text("{}")
        return Path(out) / "summary.json"

    monkeypatch.setattr(experiments, "run_comparison", fake_run)
    path = tmp_path / "c.toml"
    path.write_text(EXAMPLE)
    assert main(["compare", str(path), "--out", str(tmp_path / "o")]) == 0
    # off a terminal too (a log, CI): `Progress` prints lines there, a bar on a terminal
    assert seen["progress"] is True
    assert main(["compare", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    assert seen["progress"] is False


def test_every_built_in_without_parameters_says_why(capsys):
    bare = [(i.kind, i.name) for i in builtin_plugins() if not i.cls.Params.model_fields]
    assert ("cn0_estimator", "m2m4") in bare and ("sample_source", "ci8") in bare
    for kind, name in bare:
        assert main(["plugins", "--kind", kind, "--describe", name]) == 0
        out = capsys.readouterr().out
        assert re.search(r"\(no parameters: \w[^)]*", out), (kind, name)
