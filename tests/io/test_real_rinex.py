"""RINEX 2.1x and 3.0x as receivers write them (issue 26), on copies of real files in tests/data.

Truths used: the files' own text read at the columns the RINEX specifications fix
(RINEX 2.11 table A3, RINEX 3.04 table A13), the header's GLONASS channels with the
GLONASS ICD's FDMA plan, and numbers read off the files by eye.
"""

from __future__ import annotations

import gzip
from pathlib import Path

import hatanaka
import numpy as np
import pytest

import gnssframework as gf
from gnssframework.io.observations import SPEED_OF_LIGHT_MPS, arc_starts, read_observations
from gnssframework.io.observations import read_code_carrier

DATA = Path(__file__).resolve().parents[1] / "data"
RINEX2 = DATA / "07590920.05o"
NAV2 = DATA / "07590920.05n"
PIXEL = DATA / "pixel6.23o"
CEBR = DATA / "CEBR00ESP_R_20182002200_01H_30S_MO.crx.gz"


@pytest.fixture(scope="module")
def cebr():
    return read_observations(CEBR, "all")


def _rinex3_lli_flags(text: str) -> set[tuple[int, str]]:
    """(epoch index, satellite) with bit 0 of the primary carrier's LLI set, read from
    the columns of RINEX 3.04 table A13: field f spans 3 + 16 f .. 3 + 16 f + 16, its
    LLI at offset 14. The primary carrier is the second field of every system here
    (G/E/R: C1C L1C ...; C: C2I L2I ...), as the header states."""
    flags, k = set(), -1
    for line in text.split("\n")[
        text.split("\n").index(next(x for x in text.split("\n") if "END OF HEADER" in x)) + 1 :
    ]:
        if line.startswith(">"):
            k += 1
        elif len(line) > 3 + 16 + 14 and line[3 + 16 + 14].strip() and int(line[3 + 16 + 14]) & 1:
            flags.add((k, line[:3]))
    return flags


def test_rinex2_file_is_read_with_its_epochs_as_written():
    obs = read_observations(RINEX2, "G")
    assert obs.version == 2.1 and obs.signal["G"] == ("C1", "L1", "L2") and obs.epoch.size == 120
    # Line 399: " 05  4  2  0 21 30.0020000": georinex returns 30.001 s; the file's value is kept.
    assert obs.epoch[43] == np.datetime64("2005-04-02T00:21:30.002")
    # First epoch, first satellite G03 (line 18): L1 55923622.160 cycles, C1 24767686.375 m.
    j = obs.satellite("G03")
    assert obs.pseudorange_m[0, j] == 24767686.375
    assert obs.carrier_m[0, j] == pytest.approx(55923622.160 * SPEED_OF_LIGHT_MPS / 1575.42e6, abs=1e-6)
    np.testing.assert_allclose(obs.position_m, [-3976219.5082, 3382372.5671, 3652512.9849])


def test_phone_rinex_keeps_the_100ns_epochs_georinex_truncates():
    obs = read_observations(PIXEL, "G")
    # "> 2023 11 07 23 43 15.0002755": georinex gives 15.000275; the file states 100 ns more.
    assert obs.epoch[0] == np.datetime64("2023-11-07T23:43:15.0002755")
    assert obs.epoch.size == 48 and obs.skipped == []


def test_a_rinex4_observation_file_reads_as_its_3_05_records(tmp_path):
    """RINEX 4.0x kept 3.05's observation records (GnssLogger writes 4.01 now): the phone's
    file relabelled 4.01 reads to the same values, epochs and flags as the 3.03 original.
    No real 4.0x observation file was at hand; this checks the reading path, not a
    producer's 4.01 header."""
    text = PIXEL.read_text()
    relabelled = tmp_path / "pixel6_v401.26o"
    relabelled.write_text(f"{'4.01':>9}" + text[9:])
    ours, original = read_observations(relabelled, "all"), read_observations(PIXEL, "all")
    assert ours.version == 4.01 and original.version == 3.03
    np.testing.assert_array_equal(ours.epoch, original.epoch)
    np.testing.assert_array_equal(ours.sv, original.sv)
    for name in ("pseudorange_m", "carrier_m", "lli", "snr_dbhz", "ssi", "wavelength_m"):
        np.testing.assert_array_equal(getattr(ours, name), getattr(original, name), err_msg=name)
    (tmp_path / "v5.26o").write_text(f"{'5.00':>9}" + text[9:])
    with pytest.raises(gf.DataFileError, match="RINEX version 5: this reader reads 2.1x, 3.0x and 4.0x"):
        read_observations(tmp_path / "v5.26o", "G")


def test_phone_glonass_wavelengths_follow_the_header_channels():
    obs = read_observations(PIXEL, "R")
    # Header: "R01  1 R02 -4 R03  5 R12 -1 R13 -2 R21  4"; L1 = 1602 + 0.5625 k MHz (GLONASS ICD).
    for sv, k in {"R01": 1, "R02": -4, "R03": 5, "R12": -1, "R13": -2, "R21": 4}.items():
        assert obs.wavelength_m[obs.satellite(sv)] == pytest.approx(SPEED_OF_LIGHT_MPS / (1602e6 + 0.5625e6 * k))


@pytest.mark.slow
def test_hatanaka_multi_gnss_file_reads_every_constellation(cebr):
    systems = {sv[0] for sv in cebr.sv}
    assert systems == {"G", "E", "C", "R"} and cebr.version == 3.03
    assert cebr.signal["C"][:2] == ("C2I", "L2I") and cebr.signal["G"][:2] == ("C1C", "L1C")
    # The same content as the plain text (hatanaka decompresses, as crx2rnx would).
    text = hatanaka.decompress(gzip.decompress(CEBR.read_bytes())).decode()
    first = text.split("> 2018 07 19 22 00  0.0000000  0 36\n")[1].split("\n")[0]  # "G19  25670286.804 5 ..."
    j = cebr.satellite(first[:3])
    assert cebr.pseudorange_m[0, j] == float(first[3:17])
    assert cebr.snr_dbhz[0, j] == float(first[3 + 48 : 3 + 62])  # S1C, the fourth GPS field
    assert cebr.ssi[0, j] == int(first[3 + 16 + 15])


def test_every_loss_of_lock_flag_in_the_file_is_read_and_starts_an_arc(cebr):
    text = hatanaka.decompress(gzip.decompress(CEBR.read_bytes())).decode()
    flags = _rinex3_lli_flags(text)
    read = {(k, str(cebr.sv[j])) for k, j in zip(*np.nonzero(cebr.lli & 1))}
    assert read == flags and len(flags) > 20
    starts = arc_starts(cebr.time_s, cebr.valid, cebr.lli, max_gap_s=45.0)
    for k, sv in flags:
        j = cebr.satellite(sv)
        if cebr.valid[k, j]:
            assert starts[k, j], (k, sv)


def test_a_gap_ends_an_arc_and_nothing_else_does(cebr):
    valid = cebr.valid
    starts = arc_starts(cebr.time_s, valid, cebr.lli, max_gap_s=45.0)
    flagged = (cebr.lli & 1) != 0
    seen_before = np.cumsum(valid, axis=0) - valid > 0
    gap_after = np.vstack([np.zeros((1, valid.shape[1]), bool), ~valid[:-1]]) & seen_before & valid
    assert gap_after.sum() > 0  # the excerpt has gaps (C05 among others)
    expected = valid & (~seen_before | gap_after | flagged)
    np.testing.assert_array_equal(starts, expected)
    # A longer threshold bridges one missing 30 s epoch (a 60 s step), not a 90 s one.
    bridged = arc_starts(cebr.time_s, valid, cebr.lli, max_gap_s=61.0)
    assert bridged.sum() < starts.sum()


def test_read_code_carrier_takes_any_system_and_carries_the_flags(cebr):
    data = read_code_carrier(CEBR, "C10")
    j = cebr.satellite("C10")
    ok = cebr.valid[:, j]
    np.testing.assert_array_equal(data.lli, cebr.lli[ok, j])
    assert data.wavelength_m == pytest.approx(SPEED_OF_LIGHT_MPS / 1561.098e6)


@pytest.mark.parametrize("select, systems", [("G", {"G"}), ("GC", {"G", "C"}), ("E24,R05", {"E", "R"})])
def test_selection_by_system_or_satellite(select, systems):
    obs = read_observations(PIXEL, select) if "24" not in select else None
    if obs is not None:
        assert {sv[0] for sv in obs.sv} <= systems
    else:
        with pytest.raises(gf.DataFileError, match="no observations of the selection"):
            read_observations(PIXEL, select)


def test_a_bad_selection_is_a_config_error():
    with pytest.raises(gf.ConfigError, match=r"^select: .*'X12'"):
        read_observations(PIXEL, "X12")


@pytest.mark.parametrize(
    "path, why",
    [
        (NAV2, r"07590920.05n:1: a navigation file \(broadcast ephemeris, RINEX type N\), not an observation file"),
        (DATA / "beidou-bd.log", r"beidou-bd.log:1: not a RINEX file"),
    ],
)
def test_files_that_are_not_observations_are_refused_in_one_line(path, why):
    with pytest.raises(gf.DataFileError, match=why):
        read_observations(path)


def test_a_corrupt_hatanaka_archive_is_refused_in_one_line(tmp_path):
    bad = tmp_path / "bad.crx.gz"
    bad.write_bytes(CEBR.read_bytes()[:5000])
    with pytest.raises(gf.DataFileError, match=r"bad.crx.gz: .*"):
        read_observations(bad)


def test_a_rinex2_epoch_out_of_order_is_refused_with_its_line(tmp_path):
    lines = RINEX2.read_text().splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith(" 05  4  2")]
    block = lines[starts[5] : starts[6]]  # epoch 5 again after epoch 6
    edited = lines[: starts[7]] + block + lines[starts[7] :]
    path = tmp_path / "dup.05o"
    path.write_text("\n".join(edited) + "\n")
    with pytest.raises(
        gf.DataFileError,
        match=rf"dup.05o:{starts[7] + 1}: epoch 2005-04-02 00:02:30.0000000 goes "
        rf"backwards from the epoch at line {starts[6] + 1}",
    ):
        read_observations(path)
