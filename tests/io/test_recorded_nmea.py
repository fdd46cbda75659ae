"""NMEA integrity checks: impossible positions, jumps, time order, empty fields (issue 13)."""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pynmea2
import pytest

import gnssframework as gf
from gnssframework.cli import main
from gnssframework.io.nmea import read_nmea

LOG = Path(__file__).resolve().parents[2] / "examples" / "data" / "static_receiver.nmea"
LINES = LOG.read_text().splitlines()  # GGA on even indices, RMC on odd: epoch k at lines 2k+1, 2k+2


def _edit(sentence: str, **fields: str) -> str:
    """The sentence with named fields replaced and a valid checksum (pynmea2 renders it)."""
    msg = pynmea2.parse(sentence)
    names = [f[1] for f in msg.fields]
    for name, value in fields.items():
        msg.data[names.index(name)] = value
    return str(msg)


def _write(tmp_path, lines, name="log.nmea"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_latitude_outside_90_deg_is_skipped_with_its_line(tmp_path):
    lines = LINES.copy()
    lines[10] = _edit(lines[10], lat="9130.0000")  # GGA of epoch 5: 91.5 deg
    fixes = read_nmea(_write(tmp_path, lines))
    assert fixes.skipped == [(11, "latitude 91.500000 deg outside +-90 deg")]
    # The epoch keeps its RMC fix (no height), so no epoch is lost.
    assert fixes.time_s.size == 500 and np.isnan(fixes.height_m[5]) and fixes.line[5] == 12
    assert np.all(np.abs(fixes.lat_deg) <= 90)


def test_gga_with_an_empty_latitude_and_a_valid_checksum_is_skipped_and_counted(tmp_path):
    lines = LINES.copy()
    lines[20] = _edit(lines[20], lat="", lat_dir="")
    assert pynmea2.parse(lines[20], check=True).gps_qual == 1  # checksum valid, quality says fix
    fixes = read_nmea(_write(tmp_path, lines))
    assert fixes.skipped == [(21, "GGA with an empty latitude")]
    assert abs(fixes.lat_deg[10] - 30.528) < 1e-3  # not 0 deg: the RMC fix of that epoch


def test_a_longitude_jump_is_skipped_by_the_speed_threshold(tmp_path):
    lines = LINES.copy()
    for i in (40, 41):  # both sentences of epoch 20 jump 30 deg east
        lines[i] = _edit(lines[i], lon="14421.2728")
    fixes = read_nmea(_write(tmp_path, lines))
    assert [line for line, _ in fixes.skipped] == [41, 42]
    assert "GGA position jumps" in fixes.skipped[0][1] and "> max_speed_mps 1000" in fixes.skipped[0][1]
    assert fixes.time_s.size == 499 and 20.0 not in fixes.time_s and np.ptp(fixes.lon_deg) < 1e-3
    # The threshold is a parameter: a limit above 3000 km/s lets the jump through.
    assert read_nmea(_write(tmp_path, lines), max_speed_mps=1e7).skipped == []


def test_duplicated_timestamps_are_skipped_with_the_first_line(tmp_path):
    lines = LINES[:22] + [LINES[20], LINES[21]] + LINES[22:]  # epoch 10 logged twice
    fixes = read_nmea(_write(tmp_path, lines))
    assert fixes.skipped == [
        (23, "duplicate GGA timestamp 03:00:10.000 (first at line 21)"),
        (24, "duplicate RMC timestamp 03:00:10.000 (first at line 22)"),
    ]
    assert fixes.time_s.size == 500 and np.all(np.diff(fixes.time_s) == 1.0)


def test_backwards_timestamps_are_skipped(tmp_path):
    lines = LINES[:22] + [_edit(LINES[20], timestamp="030004.50")] + LINES[22:]
    fixes = read_nmea(_write(tmp_path, lines))
    assert fixes.skipped == [(23, "timestamp 03:00:04.500 goes backwards (after 03:00:10.000)")]
    assert np.all(np.diff(fixes.time_s) > 0)


def test_midnight_rollover_is_not_backwards(tmp_path):
    stamps = ["235958.00", "235959.00", "000000.00", "000001.00"]
    lines = [_edit(LINES[0], timestamp=s) for s in stamps]
    fixes = read_nmea(_write(tmp_path, lines))
    assert fixes.skipped == [] and fixes.time_s.tolist() == [0.0, 1.0, 2.0, 3.0]


def test_strict_refuses_the_file_at_the_first_bad_line(tmp_path):
    lines = LINES.copy()
    lines[30] = _edit(lines[30], lat="9130.0000")
    lines[50] = _edit(lines[50], lat="")
    with pytest.raises(gf.DataFileError, match=r"log.nmea:31: latitude 91.5.* \(and 1 more bad lines\)"):
        read_nmea(_write(tmp_path, lines), strict=True)


@pytest.mark.slow
def test_cli_exit_status_and_sidecar_say_what_was_skipped(tmp_path, capsys):
    lines = LINES[:200]
    lines[10] = _edit(lines[10], lat="9130.0000")
    lines[40] = _edit(lines[40], lat="")
    bad, out = _write(tmp_path, lines), tmp_path / "f.csv"
    # One real process for the exit status the shell sees; the other cases run in-process.
    proc = subprocess.run(
        [sys.executable, "-m", "gnssframework", "filter-positions", str(bad), "--out", str(out), "--filter", "UKF"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 3, proc.stderr
    assert "2 sentences skipped" in proc.stdout and "skipped line 41: GGA with an empty latitude" in proc.stdout
    with open(tmp_path / "f.csv.skipped.csv", newline="") as fh:
        assert list(csv.reader(fh)) == [
            ["file", "line", "reason"],
            [str(bad), "11", "latitude 91.500000 deg outside +-90 deg"],
            [str(bad), "41", "GGA with an empty latitude"],
        ]
    assert main(["filter-positions", str(bad), "--out", str(out), "--strict"]) == 2
    assert f"{bad}:11: latitude" in capsys.readouterr().err
    # A clean log: exit 0 and an empty list (no stale one left from the run above).
    assert (
        main(
            ["filter-positions", str(_write(tmp_path, LINES[:200], "clean.nmea")), "--out", str(out), "--filter", "UKF"]
        )
        == 0
    )
    assert (tmp_path / "f.csv.skipped.csv").read_text().splitlines() == ["file,line,reason"]


def test_no_gga_line_disappears_silently_under_random_damage(tmp_path):
    """Duplicate, move back and damage random sentences: the accepted epochs stay strictly
    increasing and on the globe, and every GGA line is either the fix of its epoch or listed
    as skipped (a GGA is preferred, so a kept one is always the line of its epoch)."""
    rng = np.random.default_rng(8)
    for trial in range(10):
        lines = LINES[:100]
        for _ in range(8):
            i = int(rng.integers(len(lines)))
            op = rng.integers(4)
            if op == 0:
                lines.insert(i, lines[int(rng.integers(len(lines)))])  # a copy anywhere (dup or backwards)
            elif op == 1:
                lines[i] = _edit(lines[i], lat="9" + lines[i].split(",")[2 if "GGA" in lines[i] else 3][1:])
            elif op == 2:
                lines[i] = _edit(lines[i], lon="")
            else:
                lines[i] = lines[i][: int(rng.integers(5, len(lines[i])))]  # truncated sentence
        fixes = read_nmea(_write(tmp_path, lines, f"t{trial}.nmea"))
        assert np.all(np.diff(fixes.time_s) > 0) and np.all(np.abs(fixes.lat_deg) <= 90)
        skipped = {line for line, _ in fixes.skipped}
        used = set(fixes.line.tolist())
        for no, sentence in enumerate(lines, 1):
            if sentence.startswith("$GNGGA"):
                assert (no in used) != (no in skipped), (trial, no, sentence)


@pytest.mark.parametrize(
    "fields, reason",
    [
        ({"lat_dir": "X"}, "GGA latitude hemisphere 'X' is not N or S"),  # pynmea2 reads it as 0 deg
        ({"lon_dir": ""}, "GGA longitude hemisphere '' is not E or W"),
        ({"timestamp": "250005.00"}, "GGA timestamp '250005.00' is not a time hhmmss.ss"),
        ({"timestamp": "03a005.00"}, "GGA timestamp '03a005.00' is not a time hhmmss.ss"),
        ({"altitude": "nan"}, r"GGA altitude nan m outside \+-100000 m \(max_abs_height_m\)"),
        ({"altitude": "1e300"}, r"GGA altitude 1e\+300 m outside \+-100000 m"),  # was: LinAlgError in the filter
    ],
)
def test_a_gga_with_an_impossible_field_is_skipped_with_its_line_and_reason(tmp_path, fields, reason):
    lines = LINES[:60]
    lines[10] = _edit(lines[10], **fields)  # epoch 5's GGA; its RMC (line 12) stands in for it
    fixes = read_nmea(_write(tmp_path, lines))
    assert len(fixes.skipped) == 1 and fixes.skipped[0][0] == 11, fixes.skipped
    assert re.match(reason, fixes.skipped[0][1]), fixes.skipped
    assert fixes.time_s.size == 30 and fixes.line[5] == 12  # the epoch is kept, from its RMC


def test_the_altitude_bound_is_a_parameter_and_a_corrupted_altitude_cannot_break_the_filter(tmp_path, capsys):
    lines = LINES[:60]
    lines[10] = _edit(lines[10], altitude="1e300")
    lines[20] = _edit(lines[20], altitude="2500.0")
    path = _write(tmp_path, lines)
    assert [s[0] for s in read_nmea(path, max_abs_height_m=1000.0).skipped] == [11, 21]
    out = tmp_path / "track.csv"
    assert main(["filter-positions", str(path), "--out", str(out)]) == 3  # AUKF1: was a raw LinAlgError
    assert "skipped line 11: GGA altitude 1e+300 m" in capsys.readouterr().out


@pytest.mark.parametrize("option", [["--max-speed", "0"], ["--max-height", "-1"], ["--max-speed", "nan"]])
def test_a_bad_threshold_is_a_config_error_naming_it(tmp_path, capsys, option):
    assert main(["filter-positions", str(LOG), "--out", str(tmp_path / "t.csv"), *option]) == 2
    err = capsys.readouterr().err
    # NaN is refused by the command line's check of every number option, before the library's
    assert err.startswith(
        (f"error: {option[0]}: must be a positive number", f"error: {option[0]}: must be a finite number")
    ), err


def test_a_log_with_no_usable_fix_says_what_was_skipped_first(tmp_path):
    lines = [_edit(line, lat_dir="Q") if line.startswith("$GNGGA") else line[:-2] + "00" for line in LINES[:20]]
    with pytest.raises(
        gf.DataFileError,
        match=r"log.nmea: no valid GGA or RMC fix \(20 sentences skipped, the first "
        r"at line 1: GGA latitude hemisphere 'Q' is not N or S\)",
    ):
        read_nmea(_write(tmp_path, lines))
