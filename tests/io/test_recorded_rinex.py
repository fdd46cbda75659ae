"""RINEX integrity checks around georinex: truncation, time order, plausibility, located
georinex errors, and the smooth command's report (issue 13)."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.cli import main
from gnssframework.io.observations import read_code_carrier

RNX = Path(__file__).resolve().parents[2] / "examples" / "data" / "simulated_pass.rnx"
HEAD = 12  # header lines; then epochs of 3 lines: "> ...", "G08 ...", "G16 ..."
LINES = RNX.read_text().splitlines()[: HEAD + 3 * 100]  # the first 100 epochs keep the tests fast


def _epoch(k: int) -> int:
    """Index (0-based) of epoch k's header line; its line number is one more."""
    return HEAD + 3 * k


def _write(tmp_path, lines, name="obs.rnx", newline=True):
    path = tmp_path / name
    path.write_text("\n".join(lines) + ("\n" if newline else ""))
    return path


def test_the_clean_excerpt_is_read_whole(tmp_path):
    data = read_code_carrier(_write(tmp_path, LINES), "G08")
    assert data.time_s.size == 100 and data.skipped == [] and data.truncated is None


def test_a_file_cut_inside_an_observation_line_is_reported_truncated(tmp_path):
    lines = LINES[: _epoch(60) + 2]
    lines[-1] = lines[-1][:12]  # "G16  2116..." cut mid-number, no newline at the end
    data = read_code_carrier(_write(tmp_path, lines, newline=False), "G08")
    assert "no newline" in data.truncated
    assert data.skipped == [(_epoch(60) + 1, f"truncated epoch dropped: {data.truncated}")]
    assert data.time_s.size == 60 and data.time_s[-1] == 59.0  # epochs before the cut, none after


def test_a_file_cut_between_the_lines_of_an_epoch_is_reported_truncated(tmp_path):
    data = read_code_carrier(_write(tmp_path, LINES[: _epoch(30) + 2]), "G08")  # G16 line of epoch 30 lost
    assert data.truncated == (
        f"the file ends inside the epoch at line {_epoch(30) + 1}: it declares 2 satellites, the file holds 1"
    )
    assert data.time_s.size == 30


def test_a_duplicated_epoch_is_skipped_with_its_line(tmp_path):
    lines = LINES[: _epoch(6)] + LINES[_epoch(5) : _epoch(6)] + LINES[_epoch(6) :]
    data = read_code_carrier(_write(tmp_path, lines), "G08")
    assert data.skipped == [
        (_epoch(6) + 1, f"duplicate epoch 2020-05-01 10:30:05.0000000 (first at line {_epoch(5) + 1}): epoch skipped")
    ]
    assert data.time_s.size == 100 and np.all(np.diff(data.time_s) == 1.0)


def test_an_epoch_going_backwards_is_skipped(tmp_path):
    lines = LINES[: _epoch(5)] + LINES[_epoch(6) : _epoch(7)] + LINES[_epoch(5) : _epoch(6)] + LINES[_epoch(7) :]
    data = read_code_carrier(_write(tmp_path, lines), "G08")
    assert data.skipped == [
        (
            _epoch(6) + 1,
            "epoch 2020-05-01 10:30:05.0000000 goes backwards (after 2020-05-01 10:30:06.0000000): epoch skipped",
        )
    ]
    assert data.time_s.size == 99 and np.all(np.diff(data.time_s) > 0)


@pytest.mark.parametrize(
    "field, value", [("     1.000e+12", 1e12), ("9999999999.999", 9999999999.999), (" -20402487.070", -20402487.070)]
)
def test_an_impossible_pseudorange_is_skipped_and_the_bound_is_a_parameter(tmp_path, field, value):
    lines = LINES.copy()
    j = _epoch(20) + 1  # G08 of epoch 20
    lines[j] = lines[j][:3] + field + lines[j][17:]
    path = _write(tmp_path, lines)
    data = read_code_carrier(path, "G08")
    assert data.skipped == [
        (
            j + 1,
            f"G08 C1C = {value:.6g} m outside [1e+07, 5e+07] m "
            "(pseudorange_min_m/pseudorange_max_m): observation skipped",
        )
    ]
    assert data.time_s.size == 99 and 20.0 not in data.time_s  # only that epoch of G08 lost
    assert read_code_carrier(path, "G16").time_s.size == 100  # the other satellite keeps it
    if value > 0:
        assert read_code_carrier(path, "G08", pseudorange_max_m=1e13).skipped == []


def test_an_error_inside_georinex_names_the_epoch_line(tmp_path):
    lines = LINES.copy()
    lines[_epoch(40) + 2] = lines[_epoch(40) + 1]  # G08 twice in epoch 40: georinex raises
    with pytest.raises(
        gf.DataFileError,
        match=rf"obs.rnx:{_epoch(40) + 1}: georinex could not read it in the "
        r"epoch starting at this line: ValueError: .*duplicate",
    ):
        read_code_carrier(_write(tmp_path, lines), "G08")


def test_an_epoch_with_fewer_lines_than_declared_is_refused(tmp_path):
    lines = LINES[: _epoch(10) + 2] + LINES[_epoch(11) :]
    with pytest.raises(
        gf.DataFileError,
        match=rf"obs.rnx:{_epoch(10) + 1}: epoch declares 2 satellites but has "
        r"only 1 observation lines",
    ):
        read_code_carrier(_write(tmp_path, lines), "G08")


def test_strict_refuses_at_the_first_skipped_line(tmp_path):
    lines = LINES[: _epoch(6)] + LINES[_epoch(5) : _epoch(6)] + LINES[_epoch(6) :]
    with pytest.raises(gf.DataFileError, match=rf"obs.rnx:{_epoch(6) + 1}: duplicate epoch"):
        read_code_carrier(_write(tmp_path, lines), "G08", strict=True)


@pytest.mark.slow
def test_cli_smooth_exit_status_summary_and_sidecar(tmp_path, capsys):
    out = tmp_path / "s.csv"
    dup = _write(tmp_path, LINES[: _epoch(6)] + LINES[_epoch(5) : _epoch(6)] + LINES[_epoch(6) :], "dup.rnx")
    # One real process for the exit status the shell sees; the other cases run in-process.
    proc = subprocess.run(
        [sys.executable, "-m", "gnssframework", "smooth", str(dup), "--prn", "G08", "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 3, proc.stderr
    assert "100 epochs of 1 satellites smoothed" in proc.stdout and "1 epochs or observations skipped" in proc.stdout
    assert f"skipped line {_epoch(6) + 1}: duplicate epoch" in proc.stdout
    with open(tmp_path / "s.csv.skipped.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["file", "line", "reason"] and rows[1][:2] == [str(dup), str(_epoch(6) + 1)] and len(rows) == 2
    assert len(out.read_text().splitlines()) == 101

    def smooth(path, *extra):
        capsys.readouterr()
        code = main(["smooth", str(path), "--prn", "G08", "--out", str(out), *extra])
        return code, capsys.readouterr()

    cut = _write(tmp_path, LINES[: _epoch(50) + 2], "cut.rnx")
    code, std = smooth(cut)
    assert code == 4 and "TRUNCATED FILE" in std.out and "50 epochs of 1 satellites smoothed" in std.out
    code, std = smooth(cut, "--strict")
    assert code == 2 and f"cut.rnx:{_epoch(50) + 1}: truncated" in std.err
    code, std = smooth(_write(tmp_path, LINES, "clean.rnx"))
    assert code == 0 and (tmp_path / "s.csv.skipped.csv").read_text().splitlines() == ["file,line,reason"]


def test_any_cut_is_reported_or_falls_on_an_epoch_boundary(tmp_path):
    """Cut the file at random characters of its data part: either the reader reports the
    truncation and keeps exactly the epochs completed before the cut, or the cut fell at
    the end of an epoch (with its newline) and the file reads as that many whole epochs."""
    text = "\n".join(LINES[: HEAD + 3 * 30]) + "\n"
    data_start = len("\n".join(LINES[:HEAD])) + 1
    ends = [len("\n".join(LINES[: _epoch(k)])) + 1 for k in range(1, 31)]  # char after epoch k-1's newline
    rng = np.random.default_rng(13)
    cuts = list(rng.integers(data_start + 1, len(text), 12)) + ends[4:6]
    for cut in cuts:
        path = _write(tmp_path, [text[:cut]], "cut.rnx", newline=False)
        complete = sum(e <= cut for e in ends)  # epochs whose lines all end before the cut
        data = read_code_carrier(path, "G08")
        if cut in ends:
            assert data.truncated is None and data.time_s.size == complete, cut
        else:
            assert data.truncated is not None and data.time_s.size == complete, cut
            assert data.skipped[-1][1].startswith("truncated epoch dropped")


@pytest.mark.parametrize(
    "epoch_line, why",
    [
        ("> 2020 13 01 10 30 30.0000000  0  2", "month must be in 1..12"),
        ("> 2020 05 32 10 30 30.0000000  0  2", "day is out of range"),
        ("> 2020 05 01 24 30 30.0000000  0  2", "hour must be in 0..23"),
        ("> 2020 05 01 10 30 61.5000000  0  2", r"seconds 61.5 outside \[0, 61\)"),
    ],
)
def test_an_impossible_epoch_time_is_refused_with_its_line(tmp_path, epoch_line, why):
    lines = LINES.copy()
    lines[_epoch(30)] = epoch_line  # was: a raw ValueError traceback from datetime
    with pytest.raises(gf.DataFileError, match=rf"obs.rnx:{_epoch(30) + 1}: impossible epoch time .*{why}"):
        read_code_carrier(_write(tmp_path, lines), "G08")


def test_an_epoch_georinex_silently_stops_at_is_refused_with_its_line(tmp_path):
    """A leap-second epoch (seconds 60.0) is valid RINEX; georinex stops reading there
    without an error, so the epochs after it would vanish uncounted."""
    lines = LINES[: _epoch(31)] + LINES[_epoch(61) : _epoch(90)]  # epochs 0-30, then 61-89 (10:31:01 on)
    lines[_epoch(30)] = "> 2020 05 01 10 30 60.0000000  0  2"  # in time order: 10:30:29 < 10:30:60 < 10:31:01
    path = _write(tmp_path, lines)
    assert not gf.io.rinex.check_rinex3_obs(path).skipped  # the line-level pass accepts every epoch
    with pytest.raises(
        gf.DataFileError,
        match=rf"obs.rnx:{_epoch(30) + 1}: georinex did not return the epoch at "
        r"this line \(2020-05-01 10:30:60.0000000\), nor 29 later epochs",
    ):
        read_code_carrier(path, "G08")


@pytest.mark.parametrize(
    "bounds", [["--pseudorange-min", "5e7", "--pseudorange-max", "1e7"], ["--pseudorange-min", "nan"]]
)
def test_bad_plausibility_bounds_are_a_config_error_naming_them(tmp_path, capsys, bounds):
    # was: "G08 has no epoch with both C1C and L1C", blaming the file for the option
    assert main(["smooth", str(RNX), "--prn", "G08", "--out", str(tmp_path / "s.csv"), *bounds]) == 2
    err = capsys.readouterr().err  # NaN: refused by the command line's check of every number option
    assert (
        "error: --pseudorange-min/--pseudorange-max: need 0 <= min < max" in err
        or "error: --pseudorange-min: must be a finite number, got nan" in err
    ), err


def test_no_data_left_after_the_checks_says_what_was_skipped(tmp_path):
    with pytest.raises(
        gf.DataFileError,
        match=r"G08 has no epoch with both C1C and L1C left after the checks: 200 "
        r"epochs or observations skipped, the first at line 14: G08 C1C",
    ):
        read_code_carrier(_write(tmp_path, LINES), "G08", pseudorange_max_m=1.1e7)  # every range is above
