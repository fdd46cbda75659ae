"""Failures that were tracebacks end in one line: OS errors with their path, a corrupted
store with its path, Ctrl-C, endless input files, values pydantic would quietly convert,
an unbounded number of runs, a deep-integration flight at a pole."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest

import gnssframework as gf
import gnssframework.experiments as experiments
from gnssframework.cli import main
from gnssframework.experiments import load_config
from gnssframework.io.text import MAX_INPUT_FILE_BYTES, read_input_text

TINY = """
name = "tiny"
runs = 2
batch_size = 2
[executor]
workers = 1
[scenario]
kind = "multipath"
epochs = 50
[[cases]]
name = "psi"
psi = 0.8
[[candidates]]
name = "ukf"
estimator = { name = "ukf", params = { ESTIMATOR } }
nav_filter = "position-ca"
"""

GOOD = TINY.replace("ESTIMATOR", "alpha = 0.01")


def _config(tmp_path, text=GOOD):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return path


def _cli(capsys, *argv) -> tuple[int, str]:
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return status, err.strip()


def _compare(capsys, config, out) -> tuple[int, str]:
    return _cli(capsys, "compare", config, "--out", out, "--quiet")


@pytest.mark.slow
def test_the_fixture_config_runs(tmp_path, capsys):
    assert main(["compare", str(_config(tmp_path)), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    assert (tmp_path / "out" / "results.sqlite").is_file()


def test_an_out_path_under_a_file_is_named_with_exit_2(tmp_path, capsys):
    (tmp_path / "afile").write_text("")
    out = tmp_path / "afile" / "sub"
    assert _compare(capsys, _config(tmp_path), out) == (2, f"error: {out}: Not a directory")


@pytest.mark.slow
@pytest.mark.parametrize(
    "code, status, hint",
    [
        (errno.EACCES, 2, "not writable or readable by this user; choose another path"),
        (errno.EROFS, 2, "on a read-only file system; choose another path"),
        (errno.ENOSPC, 1, "no space left on the device; free some or choose another --out"),
    ],
)
def test_os_errors_while_writing_name_the_path_in_one_line(tmp_path, capsys, monkeypatch, code, status, hint):
    # Running as root ignores permissions and a test cannot fill a disk: the OS error is
    # raised where the runner would meet it (creating or writing a file under --out).
    target = tmp_path / "out" / "results.sqlite"

    def fail(*args, **kwargs):
        raise OSError(code, os.strerror(code), str(target))

    monkeypatch.setattr(experiments, "run_comparison", fail)
    got_status, err = _compare(capsys, _config(tmp_path), tmp_path / "out")
    assert got_status == status
    assert err.startswith(f"error: {target}: {os.strerror(code)} ({hint}")


def test_a_corrupted_store_is_named_with_exit_2(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.sqlite").write_bytes(b"not an sqlite file\n" * 100)
    status, err = _compare(capsys, _config(tmp_path), out)
    assert status == 2
    assert err.startswith(f"error: {out / 'results.sqlite'}: ") and "file is not a database" in err


@pytest.mark.slow
@pytest.mark.parametrize(
    "sqlite_message, status, hint",
    [
        ("database or disk is full", 1, "no space left on the device"),
        ("attempt to write a readonly database", 2, "not writable or readable by this user"),
    ],
)
def test_sqlite_write_failures_name_the_store_as_the_os_error_they_are(
    tmp_path, capsys, monkeypatch, sqlite_message, status, hint
):
    import sqlite3

    def fail(*args, **kwargs):
        raise sqlite3.OperationalError(sqlite_message)

    monkeypatch.setattr(experiments, "run_comparison", fail)
    got_status, err = _compare(capsys, _config(tmp_path), tmp_path / "out")
    assert got_status == status
    assert err.startswith(f"error: {tmp_path / 'out' / 'results.sqlite'}: {sqlite_message} ({hint}")


@pytest.mark.slow
def test_ctrl_c_ends_with_one_line_and_exit_130(tmp_path, capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(experiments, "run_comparison", interrupted)
    status, err = _compare(capsys, _config(tmp_path), tmp_path / "out")
    assert status == 130
    assert err.startswith("error: interrupted (Ctrl-C); finished batches are kept")


@pytest.mark.parametrize(
    "command",
    [
        ["compare", "FILE"],
        ["filter-positions", "FILE", "--out", "OUT"],
        ["smooth", "FILE", "--prn", "G01", "--out", "OUT"],
    ],
)
def test_an_endless_input_file_is_refused_not_read(tmp_path, capsys, command):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)  # opening it to read would block forever: it must not be opened
    for path, kind in ((fifo, "a pipe"), ("/dev/zero", "a device"), (tmp_path, "a directory")):
        argv = [str(path) if a == "FILE" else str(tmp_path / "o.csv") if a == "OUT" else a for a in command]
        assert _cli(capsys, *argv) == (2, f"error: {path}: is {kind}, not a regular file; give a file")


def test_a_scenario_input_file_that_is_a_device_is_refused_naming_the_field(tmp_path):
    text = """
[scenario]
kind = "vector-tracking"
trajectory_file = "/dev/zero"
[[cases]]
name = "c45"
cn0_dbhz = 45.0
[[candidates]]
name = "d"
channel_filter = "discriminator"
nav_filter = "ekf-pv"
"""
    with pytest.raises(gf.ConfigError) as err:
        load_config(_config(tmp_path, text))
    assert str(err.value) == "scenario.trajectory_file: /dev/zero: is a device, not a regular file; give a file"


def test_undecodable_bytes_in_a_config_name_the_line(tmp_path):
    path = tmp_path / "c.toml"
    path.write_bytes(b'name = "a"\nrnus = 2\n\xff\xfe = 1\n')
    with pytest.raises(gf.DataFileError) as err:
        load_config(path)
    assert str(err.value) == f"{path}:3: not UTF-8 text (byte 0xff)"


def test_a_file_larger_than_the_reader_holds_is_refused(tmp_path):
    path = tmp_path / "big.nmea"
    with open(path, "wb") as fh:  # sparse: no disk used
        fh.truncate(MAX_INPUT_FILE_BYTES + 1)
    with pytest.raises(gf.DataFileError, match=rf"is {MAX_INPUT_FILE_BYTES + 1} bytes, more than the"):
        read_input_text(path)


def _error(tmp_path, text) -> str:
    with pytest.raises(gf.ConfigError) as err:
        load_config(_config(tmp_path, text))
    assert "\n" not in str(err.value)
    return str(err.value)


@pytest.mark.parametrize(
    "change, message",
    [
        (("runs = 2", "runs = 9223372036854775807"), "runs: Input should be less than or equal to 1000000"),
        (("runs = 2", 'runs = "2"'), "runs: Input should be a valid integer (got '2')"),
        (("runs = 2", "runs = 2.0"), "runs: Input should be a valid integer (got 2.0)"),
        (("batch_size = 2", "batch_size = true"), "batch_size: Input should be a valid integer (got True)"),
        (
            ("alpha = 0.01", "alpha = true"),
            "candidates[0].estimator.params.alpha: must be a number, not a bool (got True)",
        ),
        (
            ("alpha = 0.01", 'alpha = "0.5"'),
            "candidates[0].estimator.params.alpha: must be a number, not a str (got '0.5')",
        ),
        (("epochs = 50", 'epochs = "50"'), "scenario.epochs: must be a number, not a str (got '50')"),
        (("psi = 0.8", "psi = true"), "cases[0].psi: must be a number, not a bool (got True)"),
    ],
)
def test_values_pydantic_would_quietly_convert_are_refused(tmp_path, change, message):
    assert _error(tmp_path, GOOD.replace(*change)).startswith(message)


def test_a_string_for_a_boolean_is_refused():
    with pytest.raises(gf.ConfigError, match=r"adaptive: must be true or false \(got 'false'\)"):
        gf.registry.create("channel_filter", "iq-filter", adaptive="false")


def test_toml_integers_are_still_numbers(tmp_path):
    config = load_config(_config(tmp_path, TINY.replace("ESTIMATOR", "alpha = 1")))
    assert config.candidates[0].estimator.params == {"alpha": 1}
    assert gf.registry.create("estimator", "ukf", alpha=1).params.alpha == 1.0


def test_the_cli_runs_override_is_bounded_too(tmp_path, capsys):
    status, err = _cli(capsys, "compare", _config(tmp_path), "--runs", str(2**63 - 1), "--out", tmp_path / "o")
    assert status == 2 and err.startswith("error: runs: Input should be less than or equal to 1000000")


@pytest.mark.parametrize("profile", ["straight", "pull-up", "jerk-pulse"])
@pytest.mark.parametrize("lat", [89.5, -89.5])
def test_a_deep_integration_flight_within_a_degree_of_a_pole_is_refused(tmp_path, profile, lat):
    text = f"""
[scenario]
kind = "deep-integration"
profile = "{profile}"
lat_deg = {lat}
[[cases]]
name = "c45"
cn0_dbhz = 45.0
[[candidates]]
name = "loose"
channel_filter = "scalar"
nav_filter = "ins-ekf"
"""
    bound = "less than or equal to 89" if lat > 0 else "greater than or equal to -89"
    assert _error(tmp_path, text) == f"scenario.lat_deg: Input should be {bound} (got {lat})"


LONG = """
name = "long"
runs = 2000
batch_size = 2
[executor]
workers = 1
[scenario]
kind = "scintillation"
duration_s = 60.0
coherent_time_s = 0.001
settle_s = 0.2
[[cases]]
name = "s4"
s4 = 0.5
[[candidates]]
name = "pll"
channel_filter = "scalar"
"""


@pytest.mark.slow
@pytest.mark.parametrize("workers", [1, 2])
def test_a_real_ctrl_c_during_a_run_ends_with_one_line_and_exit_130(tmp_path, workers):
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "out"
    # workers = 2: the pool's workers are stopped at once, not waited for (a batch takes minutes).
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "gnssframework",
            "compare",
            str(_config(tmp_path, LONG.replace("workers = 1", f"workers = {workers}"))),
            "--out",
            str(out),
            "--quiet",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while not (out / "results.sqlite").exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        if workers > 1:  # the pool's workers exist: the kernels are compiled, batches computing
            deadline = time.monotonic() + 300
            children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
            while time.monotonic() < deadline and proc.poll() is None and not children.read_text().split():
                time.sleep(0.2)
        time.sleep(1.0)  # computing now (the store exists before the first batch)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err[-2000:]
    assert err.splitlines() == [
        "error: interrupted (Ctrl-C); finished batches are kept in --out and the same command resumes"
    ]
