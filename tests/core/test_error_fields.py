"""Library errors name the parameter; the command line names its option (issue 36).

A library user calls ``open_recording(sample_rate_hz=...)`` and reads
``sample_rate_hz: ...``; a command-line user typed ``--fs`` and reads ``--fs: ...``. The
library never words its errors after the command line's flags, and ``cli.py`` holds the
one table from parameters to options (`gnssframework.cli.OPTION_OF_PARAMETER`).
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from gnssframework.cli import OPTION_OF_PARAMETER, TABLE_PARAMETERS, build_parser, main, option_field
from gnssframework.errors import ConfigError
from gnssframework.io.positions import composition
from gnssframework.receiver.frontend import open_recording, write_recording
from gnssframework.receiver.navigation.receiver_config import receiver_filters

ROOT = Path(__file__).resolve().parents[2]
RNX = ROOT / "examples" / "data" / "simulated_pass.rnx"
FS = 4.092e6


def _commands_options() -> dict[str, set[str]]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return {name: {o for a in p._actions for o in a.option_strings} for name, p in sub.choices.items()}


def test_the_library_names_no_error_after_a_command_line_flag():
    # Every ConfigError(...) of the library whose field is a literal: none is an option
    # ("--fs") or carries one ("max_gap_s (--max-gap)").
    flagged = []
    for path in sorted((ROOT / "gnssframework").rglob("*.py")):
        if path.name == "cli.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            called = getattr(node.func, "id", getattr(node.func, "attr", None)) if isinstance(node, ast.Call) else None
            if (
                called == "ConfigError"
                and node.args
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)
                and "--" in node.args[0].value
            ):
                flagged.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.args[0].value!r}")
            if isinstance(node, ast.FunctionDef) and any(
                isinstance(d, ast.Constant) and isinstance(d.value, str) and d.value.startswith("--")
                for d in node.args.defaults
            ):
                flagged.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.name} defaults to an option")
    assert not flagged, (
        "library errors named after CLI flags (name the parameter; cli.OPTION_OF_PARAMETER "
        "maps it):\n" + "\n".join(flagged)
    )


def test_every_option_of_the_table_is_an_option_of_a_command():
    everything = set().union(*_commands_options().values())
    assert sorted(set(OPTION_OF_PARAMETER.values()) - everything) == []
    assert set(TABLE_PARAMETERS) <= set(OPTION_OF_PARAMETER)


@pytest.mark.parametrize(
    "field, options, reported",
    [
        ("sample_rate_hz", {"--fs"}, "--fs"),
        ("sample_rate_hz", {"--out"}, "sample_rate_hz"),  # a command without --fs keeps the parameter
        ("out", {"--out"}, "--out"),
        ("channel_params.pll_bandwidth_hz", {"--channel-params"}, "--channel-params.pll_bandwidth_hz"),
        ("channel_filter.params.pll_bandwidth_hz", {"--channel-filter"}, "channel_filter.params.pll_bandwidth_hz"),
        ("nav_filter.name", {"--nav-filter"}, "nav_filter.name"),  # a config file's path, not the option
        (
            "pseudorange_min_m/pseudorange_max_m",
            {"--pseudorange-min", "--pseudorange-max"},
            "--pseudorange-min/--pseudorange-max",
        ),
        ("pseudorange_min_m/runs", {"--pseudorange-min"}, "pseudorange_min_m/runs"),
        ("candidates[0].estimator.alpha", {"--out"}, "candidates[0].estimator.alpha"),
    ],
)
def test_option_field(field, options, reported):
    assert option_field(field, frozenset(options)) == reported


@pytest.mark.parametrize(
    "kwargs, field, detail, options",
    [
        ({"format": "ci4"}, "format", "unknown sample format 'ci4'", ["--format", "ci4"]),
        ({"format": "ci8"}, "sample_rate_hz", "not given and no SigMF metadata", ["--format", "ci8"]),
        (
            {"format": "ci8", "sample_rate_hz": 1e6},
            "sample_rate_hz",
            "1e+06 Hz is below the C/A main lobe",
            ["--format", "ci8", "--fs", "1e6"],
        ),
        (
            {"format": "ri8", "sample_rate_hz": FS, "if_hz": 3e6},
            "if_hz",
            "real samples need 0 < IF < fs/2",
            ["--format", "ri8", "--fs", str(FS), "--if", "3e6"],
        ),
    ],
)
def test_a_recording_error_names_the_parameter_and_the_command_its_option(
    tmp_path, capsys, kwargs, field, detail, options
):
    path = tmp_path / "r.bin"
    path.write_bytes(bytes(100))
    with pytest.raises(ConfigError) as info:
        open_recording(path, **kwargs)
    assert info.value.field == field and str(info.value).startswith(f"{field}: {detail}")
    flag = OPTION_OF_PARAMETER[field]
    assert main(["acquire", str(path), "--out", str(tmp_path / "a.csv"), *options]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {flag}: {detail}") and len(err.strip().splitlines()) == 1, err


@pytest.mark.slow
def test_the_filters_of_receive_name_the_parameter_and_receive_its_option(tmp_path, capsys):
    with pytest.raises(ConfigError, match=r"^channel_params\.pll_bandwidth_hz: ") as info:
        receiver_filters(channel_params={"pll_bandwidth_hz": -1})
    assert "--" not in info.value.field
    with pytest.raises(ConfigError, match=r"^channel_filter: unknown channel_filter 'scalr'"):
        receiver_filters(channel_filter="scalr")
    with pytest.raises(ConfigError, match=r"^nav_filter: unknown nav_filter 'ekf-p'"):
        receiver_filters(nav_filter="ekf-p")
    # The command line: its options for what it was given, the file's paths for the file.
    rec = write_recording(tmp_path / "r.sigmf-data", np.ones(4000, complex), "ci8", FS, 0.0)
    toml = tmp_path / "receiver.toml"
    toml.write_text('[channel_filter]\nname = "scalar"\nparams = { pll_bandwidth_hz = -1 }\n')
    for options, start in (
        (["--channel-params", '{"pll_bandwidth_hz": -1}'], "error: --channel-params.pll_bandwidth_hz: "),
        (["--channel-filter", "scalr"], "error: --channel-filter: unknown channel_filter 'scalr'"),
        (["--nav-filter", "ekf-p"], "error: --nav-filter: unknown nav_filter 'ekf-p'"),
        (["--config", str(toml)], "error: channel_filter.params.pll_bandwidth_hz: "),
    ):
        assert main(["receive", str(rec), "--out", str(tmp_path / "o"), "--quiet", *options]) == 2
        assert capsys.readouterr().err.startswith(start)


@pytest.mark.slow
def test_filter_positions_and_smooth_name_parameters_and_options(tmp_path, capsys):
    with pytest.raises(ConfigError, match=r"^noise_adapter: unknown noise_adapter 'sage-hus'"):
        composition("ckf", noise_adapter="sage-hus")
    with pytest.raises(ConfigError, match=r"^augmentation: unknown augmentation 'ar1'"):
        composition("ckf", augmentation="ar1")
    assert main(["smooth", str(RNX), "--prn", "G08", "--out", str(tmp_path / "s.csv"), "--max-gap", "-1"]) == 2
    assert capsys.readouterr().err.startswith("error: --max-gap: must be a positive number of seconds")
    assert main(["smooth", str(RNX), "--prn", "X9", "--out", str(tmp_path / "s.csv")]) == 2
    assert capsys.readouterr().err.startswith("error: --prn: 'X9' is neither satellites")


@pytest.mark.parametrize(
    "params, field",
    [
        ({"format": "ci4"}, "scenario.format"),
        ({"format": "ci8"}, "scenario.sample_rate_hz"),
        ({"format": "ri8", "sample_rate_hz": FS, "if_hz": 3e6}, "scenario.if_hz"),
    ],
)
def test_a_comparison_config_names_its_own_field(tmp_path, params, field):
    # The sample-recording scenario passes its parameters to open_recording: the error
    # continues the config's path (no option of any command appears).
    from gnssframework.experiments.scenarios import get_scenario

    path = tmp_path / "r.bin"
    path.write_bytes(bytes(4000))
    with pytest.raises(ConfigError) as info:
        get_scenario({"kind": "sample-recording", "recording": str(path), "segment_s": 5.0, **params}).open()
    assert info.value.field == field
