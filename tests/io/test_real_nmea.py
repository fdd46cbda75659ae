"""NMEA logs as receivers and loggers write them (issue 26): copies of real logs in tests/data."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pymap3d
import pytest

from gnssframework.cli import main
from gnssframework.io.nmea import read_nmea

DATA = Path(__file__).resolve().parents[1] / "data"
F9P = DATA / "ublox-zed-f9p-nmea.log"
SIRF = DATA / "beidou-bd.log"
PIXEL = DATA / "pixel6.nmea"


def _types_by_pattern(path: Path) -> dict[str, int]:
    """Sentence types counted by a regular expression on the raw text (independent of the reader)."""
    counts: dict[str, int] = {}
    for line in path.read_text().splitlines():
        m = re.search(r"\$(?:P([A-Z]{3})[A-Z0-9]*|[A-Z]{2}([A-Z]{3})),", line)
        if m:
            kind = "P" + m[1] if m[1] else m[2]
            counts[kind] = counts.get(kind, 0) + 1
    return counts


def test_gpsd_log_comments_are_not_errors_and_unused_types_are_counted():
    fixes = read_nmea(F9P)
    raw = F9P.read_text().splitlines()
    assert fixes.skipped == []
    assert fixes.comments == sum(line.startswith("#") for line in raw)
    expected = _types_by_pattern(F9P)
    assert fixes.time_s.size == expected.pop("GGA") == expected.pop("RMC")
    assert fixes.ignored == expected


def test_zed_f9p_fixes_are_near_the_antenna_position_its_header_states():
    fixes = read_nmea(F9P)
    # Header: "Location: 45.877591500S 170.500124833E" (no height stated: compare horizontally).
    e, n, _ = pymap3d.geodetic2enu(fixes.lat_deg, fixes.lon_deg, 0.0, -45.877591500, 170.500124833, 0.0)
    horizontal = np.hypot(e, n)
    assert np.all(horizontal < 5.0), horizontal.max()  # a GNSS fix of an open-sky static antenna: metres


def test_multi_talker_log_reads_gn_fixes_and_counts_bd_and_proprietary_sentences():
    fixes = read_nmea(SIRF)
    assert fixes.ignored["PSRF"] == _types_by_pattern(SIRF)["PSRF"]
    assert fixes.ignored["GSA"] == _types_by_pattern(SIRF)["GSA"]  # GPGSA and BDGSA alike
    # The first epochs have no fix yet (GGA quality 0, RMC status V): listed, not used.
    reasons = {reason for _, reason in fixes.skipped}
    assert reasons == {"GGA without a fix (quality 0)", "RMC status V (no fix)"}
    fixed = [
        line
        for line in SIRF.read_text().splitlines()
        if re.match(r"\s*\$GNGGA,[^,]*,[^,]*,[^,]*,[^,]*,[^,]*,[1-9]", line)
    ]
    assert fixes.time_s.size == len(fixed) > 0
    assert np.all(np.abs(fixes.lat_deg - 31.248) < 0.01)  # 3114.89 N


@pytest.mark.parametrize("talker", ["GP", "GN", "BD", "GB", "GA", "GL"])
def test_every_talker_gives_the_same_fix(tmp_path, talker):
    lines = [line.replace("$GN", f"${talker}", 1) for line in F9P.read_text().splitlines() if "GGA" in line]
    path = tmp_path / "t.nmea"
    # Checksums change with the talker: recompute them.
    out = []
    for line in lines:
        body = line[1 : line.index("*")]
        checksum = 0
        for ch in body:
            checksum ^= ord(ch)
        out.append(f"${body}*{checksum:02X}")
    path.write_text("\n".join(out) + "\n")
    assert np.array_equal(read_nmea(path).lat_deg, read_nmea(F9P).lat_deg)


def test_gnsslogger_wrapped_sentences_are_unwrapped():
    fixes = read_nmea(PIXEL)
    rows = [line.split(",") for line in PIXEL.read_text().splitlines()]
    assert fixes.skipped == [] and fixes.time_s.size == sum(r[1].endswith("GGA") for r in rows) == 48
    # GGA latitude field 3 (ddmm.mmmmmm), N: the first wrapped sentence, converted by hand.
    first = rows[0]
    assert fixes.lat_deg[0] == pytest.approx(float(first[3][:2]) + float(first[3][2:]) / 60, abs=1e-9)


def test_binary_data_between_sentences_is_one_entry_per_run(tmp_path):
    rng = np.random.default_rng(26)
    raw = F9P.read_bytes().split(b"\n")
    runs = []  # (index in the output line list of the run's first line, lines in the run)
    out: list[bytes] = []
    for k, line in enumerate(raw):
        if k in (40, 200, 600):  # a UBX frame: sync chars, then bytes that never hold '$' or a newline
            body = bytes(int(b) for b in rng.integers(0, 256, 300) if b not in (0x0A, 0x0D, 0x24, 0x21))
            frame = b"\xb5\x62" + body
            pieces = [frame[:100], frame[100:200], frame[200:]]
            runs.append((len(out) + 1, len(pieces)))
            out.extend(pieces)
        out.append(line)
    glued = len(out) + 1
    out.append(b"\xb5\x62\x01\x07" + raw[700])  # binary glued in front of a sentence on the same line
    path = tmp_path / "mixed.log"
    path.write_bytes(b"\n".join(out) + b"\n")
    fixes = read_nmea(path)
    expected = [(first, f"binary or non-NMEA data: {n} lines ({first}-{first + n - 1})") for first, n in runs]
    expected.append((glued, f"binary or non-NMEA data: 1 line ({glued}-{glued})"))
    assert fixes.skipped == expected
    assert fixes.time_s.size == read_nmea(F9P).time_s.size + ("GGA" in raw[700].decode() or "RMC" in raw[700].decode())


def test_cli_on_the_gpsd_log_exits_0_and_says_what_it_did_not_use(tmp_path, capsys):
    assert main(["filter-positions", str(F9P), "--out", str(tmp_path / "f.csv"), "--filter", "UKF"]) == 0
    out = capsys.readouterr().out
    assert "29 fixes filtered" in out and "696 GSV" in out and "12 comment lines" in out


@pytest.mark.slow
def test_a_closed_pipe_ends_quietly_with_the_commands_status(tmp_path):
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "gnssframework",
            "filter-positions",
            str(SIRF),
            "--out",
            str(tmp_path / "f.csv"),
            "--filter",
            "UKF",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # the reader is gone before the command prints (as `| head -0` would)
    err = proc.stderr.read().decode()
    assert proc.wait() == 3 and err == ""  # 3: the no-fix epochs were skipped
    assert (tmp_path / "f.csv").exists()
