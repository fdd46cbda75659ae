"""Every recorded file is read with a one-line summary or refused in one line (issue 26)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

import gnssframework as gf
from gnssframework.io.recordings import describe_recording, recording_kind

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
# Precise orbits (SP3) are a truth for tests/navigation/test_ephemeris_gnss.py, not a recording; raw
# front-end samples (.bin) are read by the sample sources (tests/receiver/test_frontend.py); RTKLIB's
# solution (.pos) is a peer's output that tests/navigation/test_rtklib_weighting.py compares with; the
# SBAS messages as text (.txt, a receiver's log as hex) are a truth for tests/navigation/test_sbas_message.py,
# GNSSTk's CNAV messages (.hex) for tests/navigation/test_cnav.py.
FILES = sorted(
    p
    for p in DATA.iterdir()
    if p.name != "README.md" and p.suffix.lower() not in (".sp3", ".bin", ".pos", ".txt", ".hex", ".sbs")
)

KINDS = {
    "07590920.05n": "rinex-nav",
    "07590920.05o": "rinex-obs",
    "CEBR00ESP_R_20182002200_01H_30S_MO.crx.gz": "rinex-obs",
    "beidou-bd.log": "nmea",
    "gsdc2022_device_gnss.csv": "gsdc-device",
    "gsdc2022_ground_truth.csv": "gsdc-truth",
    "pixel6.23o": "rinex-obs",
    "pixel6.nmea": "nmea",
    "ublox-zed-f9p-nmea.log": "nmea",
    "gnssframework_receive_13s.rnx": "rinex-obs",
    "sbas_sim_0759.rnx": "rinex-obs",
    "VILL00ESP_R_20181700000_06H_MN.rnx": "rinex-nav",
    "BRDC00IGS_R_20201361400_02H_EN.rnx": "rinex-nav",
    "galileo_inav_20feb2022_05h.rnx": "rinex-nav",
    "BRD400DLR_S_20230710000_04H_MN.rnx": "rinex-nav",
    "KMS300DNK_R_20221591000_01H_MN.rnx": "rinex-nav",
}


def test_every_copied_recording_has_a_known_kind():
    assert {p.name: recording_kind(p) for p in FILES} == KINDS


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_every_copied_recording_reads_to_one_line(path):
    line = describe_recording(path, "G" if path.name.startswith("CEBR") else "all")
    assert line.startswith(f"{path.name}: ") and "\n" not in line


@pytest.mark.parametrize(
    "content, why",
    [
        (b"\x00\x01binary samples", r"junk.bin:1: not a RINEX, NMEA or GSDC 2022 file"),
        (
            b"     3.04           METEOROLOGICAL DATA M                   RINEX VERSION / TYPE\n",
            r"junk.bin:1: a RINEX file of a type this framework does not read",
        ),
    ],
)
def test_other_files_are_refused_in_one_line(tmp_path, content, why):
    path = tmp_path / "junk.bin"
    path.write_bytes(content)
    with pytest.raises(gf.DataFileError, match=why):
        describe_recording(path)


def test_the_script_prints_one_line_per_file(tmp_path, capsys):
    spec = importlib.util.spec_from_file_location("read_recordings", ROOT / "examples" / "read_recordings.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    folder = tmp_path / "d"
    folder.mkdir()
    for name in ("pixel6.nmea", "07590920.05n"):
        (folder / name).symlink_to(DATA / name)
    (folder / "noise.bin").write_bytes(b"\x00\xff")
    assert module.main([str(folder)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[1].startswith("REFUSED ") and "noise.bin:1:" in lines[1]  # sorted by name
