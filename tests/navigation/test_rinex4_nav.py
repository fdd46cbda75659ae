"""RINEX 4 navigation files (`navigation.rinex4_nav`), read from real ones (DLR's merged
broadcast file and a station's file by sbf2rin, `tests/data/README.md`) against two independent truths: georinex's RINEX 3
reader on the same records written as RINEX 3 (the layouts RINEX 4 kept), and the LNAV
records of the same satellites for the CNAV records (two products of the control segment:
a misread field moves a satellite by kilometres)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import DataFileError
from gnssframework.navigation.ephemeris import CLOCK_FIELDS, ORBIT_FIELDS, read_rinex_nav, satellite_state
from gnssframework.navigation.rinex4_nav import is_rinex4, scan_rinex4_nav
from gnssframework.navigation.rinex_nav_header import read_nav_file_info

DATA = Path(__file__).parents[1] / "data"
BRD4 = DATA / "BRD400DLR_S_20230710000_04H_MN.rnx"
KMS3 = DATA / "KMS300DNK_R_20221591000_01H_MN.rnx"
#: The layouts RINEX 4 took over from RINEX 3 unchanged.
RINEX3_MESSAGES = ("LNAV", "INAV", "FNAV", "D1", "D2")


def _as_rinex3(path: Path, out: Path) -> Path:
    """The file's records of `RINEX3_MESSAGES` (GPS, QZSS, Galileo, BeiDou) as a RINEX 3.04
    mixed file: its record lines unchanged, the ``>`` lines dropped."""
    lines = path.read_text().splitlines(keepends=True)
    end = next(i for i, line in enumerate(lines) if "END OF HEADER" in line)
    body, keep = [], False
    for line in lines[end + 1 :]:
        if line.startswith(">"):
            kind, sv, message = line[1:].split()[:3]
            keep = kind == "EPH" and message in RINEX3_MESSAGES and sv[0] in "GJEC"
            continue
        if keep and line[:1] != " ":
            body.append(line)
        elif keep:  # a blank spare field written as 0 (georinex shifts the fields after a blank one)
            text = line.rstrip("\n").ljust(80)
            slots = [text[4 + 19 * k : 23 + 19 * k] for k in range(4)]
            last = max(k for k in range(4) if slots[k].strip())
            filled = [slot if slot.strip() or k > last else f"{0.0:19.12e}" for k, slot in enumerate(slots)]
            body.append(("    " + "".join(filled)).rstrip() + "\n")
    head = [
        f"{'3.04':>9}{'':11}{'N: GNSS NAV DATA':<20}{'M: MIXED':<20}RINEX VERSION / TYPE\n",
        f"{'':60}END OF HEADER\n",
    ]
    out.write_text("".join(head + body))
    return out


def _key_order(eph) -> np.ndarray:
    return np.lexsort((eph.elements["FNAV"], eph.elements["Toe"], eph.toc_s, eph.sv))


@pytest.mark.parametrize(
    ("path", "count"),
    [
        # 13 GPS LNAV, 5 QZSS LNAV, 26 Galileo (13 I/NAV, 13 F/NAV), 15 BeiDou D1/D2 records.
        (BRD4, 59),
        # sbf2rin's (another producer: D exponents as E, ION records with a region code):
        # 6 GPS LNAV, 28 Galileo, 4 BeiDou D1.
        (KMS3, 38),
    ],
)
def test_shared_layouts_read_as_georinex_reads_them(path, count, tmp_path):
    ours = read_rinex_nav(path, "GJEC")  # a RINEX 4 file: `rinex4_nav`
    zeros = np.zeros(ours.sv.size)
    lnav_style = (ours.elements.get("CNAV", zeros) == 0) & (ours.elements.get("BDS_CNAV", zeros) == 0)
    ours = ours.subset(np.flatnonzero(lnav_style))  # georinex reads no CNAV or B-CNAV record
    theirs = read_rinex_nav(_as_rinex3(path, tmp_path / "v3.rnx"), "GJEC")
    assert ours.sv.size == theirs.sv.size == count
    a, b = ours.subset(_key_order(ours)), theirs.subset(_key_order(theirs))
    np.testing.assert_array_equal(a.sv, b.sv)
    np.testing.assert_array_equal(a.toc_s, b.toc_s)
    for name in (*ORBIT_FIELDS, *CLOCK_FIELDS, "FNAV"):
        np.testing.assert_array_equal(a.elements[name], b.elements[name], err_msg=name)
    np.testing.assert_array_equal(a.health, b.health)
    np.testing.assert_array_equal(a.iode, b.iode)
    np.testing.assert_array_equal(a.accuracy_m, b.accuracy_m)


def test_cnav_records_place_satellites_where_lnav_does():
    eph = read_rinex_nav(BRD4, "GJ")
    cnav = eph.elements["CNAV"] == 1
    assert sorted(set(eph.sv[cnav])) == ["G01", "G04", "G08", "G10", "J02"]
    worst = 0.0
    for sv in ("G01", "G04", "G08", "G10", "J02"):
        lnav_idx = np.flatnonzero((eph.sv == sv) & ~cnav)
        cnav_idx = np.flatnonzero((eph.sv == sv) & cnav)
        for t in np.arange(0.0, 4 * 3600.0 + 1, 900.0):  # 2023-03-12 is day 0 of GPS week 2253
            li = lnav_idx[np.argmin(np.abs(eph.elements["Toe"][lnav_idx] - t))]
            ci = cnav_idx[np.argmin(np.abs(eph.elements["Toe"][cnav_idx] - t))]
            lnav = satellite_state(eph.subset(np.array([li])), t)
            cnav_state = satellite_state(eph.subset(np.array([ci])), t)
            # The L1 C/A user's clock: LNAV's minus T_GD, CNAV's minus T_GD plus ISC_L1CA.
            e = eph.elements
            clock_gap_m = 299_792_458.0 * abs(
                float(lnav.clock_s[0] - e["TGD"][li] - (cnav_state.clock_s[0] - e["TGD"][ci] + e["ISC_L1CA"][ci]))
            )
            orbit_gap_m = float(np.linalg.norm(lnav.position_m - cnav_state.position_m))
            # Each product errs by about its stated accuracy (URA, URA_ED): three sigmas of both.
            bound_m = 3.0 * np.hypot(eph.accuracy_m[li], eph.accuracy_m[ci])
            assert orbit_gap_m < bound_m and clock_gap_m < bound_m, (sv, t, orbit_gap_m, clock_gap_m)
            worst = max(worst, orbit_gap_m)
    assert worst > 0.1  # two products, not one record read twice


def test_cnav_fields_as_the_record_writes_them():
    eph = read_rinex_nav(BRD4, "G")
    first = np.flatnonzero(eph.elements["CNAV"] == 1)[0]
    e = {k: float(v[first]) for k, v in eph.elements.items()}
    # > EPH G01 CNAV at 2023-03-12 01:30:00 (the file's lines, read by eye).
    assert eph.sv[first] == "G01" and eph.toc_s[first] == e["Toe"] == 5400.0
    assert e["Adot"] == 1.004886627197e-02 and e["DeltaN0dot"] == -1.056170179553e-13
    assert e["Top"] == 5.427e05 and e["ISC_L2C"] == -2.532033249736e-09
    # Health word 1: L5 flagged (IS-GPS-200 30.3.3.1.1.2); the L2 user's bit is clear.
    assert e["HealthL1L2L5"] == 1.0 and eph.health[first] == 0.0
    assert read_rinex_nav(BRD4, "G", cnav_band="L5").health[first] == 1.0
    assert eph.accuracy_m[first] == pytest.approx(2.0 ** (1 - 1 / 2))  # URA_ED index -1
    assert eph.iode[first] == 18.0  # t_oe / 300


def test_other_messages_are_left_out_and_counted():
    _, records = scan_rinex4_nav(BRD4)
    kinds = {(r.kind, r.sv, r.message) for r in records}
    assert ("EPH", "C20", "CNV1") in kinds and ("EPH", "R01", "FDMA") in kinds
    beidou = read_rinex_nav(BRD4, "C")
    assert sorted(set(beidou.sv)) == ["C01", "C06", "C20"] and beidou.sv.size == 15  # D1/D2 by default
    assert list(read_rinex_nav(BRD4, "C", bds_messages="CNAV").sv) == ["C20"] * 5
    with pytest.raises(ValueError, match="GLONASS"):
        read_rinex_nav(BRD4, "R")


def test_info_from_ion_and_sto_records():
    info = read_nav_file_info(BRD4)
    # ION G12 LNAV, ION C05 D1D2 and STO E IFNV GAGP, the first of each (the file's lines).
    assert info.iono.alpha == (3.259629011154e-08, 7.450580596924e-09, -1.788139343262e-07, 0.0)
    assert info.iono.beta == (1.35168e05, 0.0, -2.62144e05, 1.31072e05)
    assert info.iono.dt_ls_s == 18
    assert info.bds_iono.alpha[0] == 4.190951585770e-08 and info.bds_iono.beta[3] == 8.323072e06
    # GGTO reference 2023-03-13 00:00: day 1 of GPS week 2253.
    assert info.ggto == (1.073931343853e-08, 1.865174681370e-14, 86400.0, 2253)
    assert info.dates() == "2023-03-12 00:00:00 to 2023-03-12 04:00:00 GPS"
    assert is_rinex4(BRD4) and not is_rinex4(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx")
    # sbf2rin's file: ION G29 LNAV (a ninth number, the region code) and STO E01 IFNV GAGP.
    info = read_nav_file_info(KMS3)
    assert info.iono.beta == (9.6256e04, 1.31072e05, -6.5536e04, -5.89824e05)
    assert info.ggto == (3.201421350241e-09, -4.440892098501e-15, 259200.0, 2213)  # 2022-06-08: day 3


def test_bad_lines_are_named(tmp_path):
    lines = BRD4.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("> EPH G01 LNAV"))
    broken = lines[: at + 2] + [lines[at + 2].replace("3.651580674421e-09", "x.651580674421e-09")] + lines[at + 3 :]
    path = tmp_path / "broken.rnx"
    path.write_text("".join(broken))
    with pytest.raises(DataFileError, match=rf"broken.rnx:{at + 3}: EPH G01 LNAV: 'x.651580674421e-09'"):
        read_rinex_nav(path, "G")
    (tmp_path / "v3.rnx").write_text("".join(lines[:1]).replace("4.00", "3.04"))
    with pytest.raises(DataFileError, match="not RINEX 4"):
        scan_rinex4_nav(tmp_path / "v3.rnx")
    (tmp_path / "short.rnx").write_text("".join(lines[:at]) + "> EPH G01\n" + "".join(lines[at + 1 :]))
    with pytest.raises(DataFileError, match=rf"short.rnx:{at + 1}: record line '> EPH G01'"):
        scan_rinex4_nav(tmp_path / "short.rnx")


def test_the_simulator_takes_a_rinex4_files_lnav_records():
    from gnssframework.simulation.ephemeris import load_rinex_nav

    sim = load_rinex_nav(BRD4, t_s=5000.0)  # nearest Toe: CNAV's 5400 s, LNAV's 7200 s
    eph = read_rinex_nav(BRD4, "G")
    assert sorted(sim.prn) == [1, 4, 8, 10]
    for k, prn in enumerate(sim.prn):
        lnav = (eph.sv == f"G{prn:02d}") & (eph.elements["CNAV"] == 0)
        pick = np.flatnonzero(lnav)[np.argmin(np.abs(eph.elements["Toe"][lnav] - 5000.0))]
        assert eph.elements["Toe"][pick] != 5400.0
        assert (
            sim.elements["sqrtA"][k] == eph.elements["sqrtA"][pick]
            and sim.elements["M0"][k] == eph.elements["M0"][pick]
        )


def test_a_gzipped_file_reads_as_the_plain_one(tmp_path):
    import gzip

    packed = tmp_path / "BRD400DLR_S_20230710000_04H_MN.rnx.gz"  # as IGS distributes it
    packed.write_bytes(gzip.compress(BRD4.read_bytes()))
    assert is_rinex4(packed)
    a, b = read_rinex_nav(packed, "GEC"), read_rinex_nav(BRD4, "GEC")
    np.testing.assert_array_equal(a.sv, b.sv)
    np.testing.assert_array_equal(a.elements["sqrtA"], b.elements["sqrtA"])
    assert read_nav_file_info(packed).ggto == read_nav_file_info(BRD4).ggto


def test_beidou_b_cnav1_records_share_d1s_orbit_and_keep_their_own_group_delays():
    # DLR's file carries C20's D1 and B-CNAV1 (CNV1) records for the same hours: one orbit and
    # one B3I clock written twice, each message with its own group delays.
    from gnssframework.navigation.ephemeris import Ephemerides, clock_defined, single_frequency_clock_s

    d1s = read_rinex_nav(BRD4, "C")
    cnvs = read_rinex_nav(BRD4, "C", bds_messages="CNAV")
    eph = Ephemerides.concatenate([d1s.subset(np.flatnonzero(d1s.sv == "C20")), cnvs])
    c20 = np.arange(eph.sv.size)
    cnav = eph.elements["BDS_CNAV"] == 1
    assert cnav.sum() == 5 and (~cnav).sum() == 5
    d1, cnv1 = eph.subset(c20[~cnav][:1]), eph.subset(c20[cnav][:1])
    assert cnv1.toc_s[0] == d1.toc_s[0] and np.isnan(cnv1.elements["TGD"][0])
    assert list(eph.iode[cnav]) == [0, 1, 2, 3, 4]  # CNV1's IODE, one a record
    with pytest.raises(DataFileError, match="RINEX 4's"):
        read_rinex_nav(DATA / "VILL00ESP_R_20181700000_06H_MN.rnx", "C", bds_messages="CNAV")
    for dt in (-3600.0, -1800.0, 0.0, 1800.0, 3600.0):
        t = d1.toc_s[0] + 14.0 + dt  # GPS time of the records' BDT epoch, +- an hour
        a, b = satellite_state(d1, t), satellite_state(cnv1, t)
        # Two fits of one orbit (D1's and CNV1's rates Adot and dn0dot): within 0.5 m (GPS
        # CNAV against LNAV: 1.04 m); one clock solution: within the af0 LSBs (2^-33 s: 4 cm).
        assert np.linalg.norm(a.position_m - b.position_m) < 0.5
        assert abs(a.clock_s[0] - b.clock_s[0]) * 299_792_458.0 < 0.04
    state_d1, state_cnv1 = satellite_state(d1, t), satellite_state(cnv1, t)
    b1i, b1c, b2a = 1561.098e6, 1575.42e6, 1176.45e6
    # CNV1: the B1C and B2a pilots' own delays (BDS-SIS-ICD-B1C 7.6.2), no B1I clock (no T_GD1);
    # D1: T_GD1 on every carrier.
    assert single_frequency_clock_s(cnv1, state_cnv1, b1c)[0] == state_cnv1.clock_s[0] - cnv1.elements["TGD_B1Cp"][0]
    assert single_frequency_clock_s(cnv1, state_cnv1, b2a)[0] == state_cnv1.clock_s[0] - cnv1.elements["TGD_B2ap"][0]
    assert np.isnan(single_frequency_clock_s(cnv1, state_cnv1, b1i)[0])
    for carrier in (b1i, b1c, b2a):
        assert single_frequency_clock_s(d1, state_d1, carrier)[0] == state_d1.clock_s[0] - d1.elements["TGD"][0]
    assert clock_defined(eph, b1c).all() and clock_defined(eph, b2a).all()
    assert list(clock_defined(eph, b1i)) == list(~cnav)
