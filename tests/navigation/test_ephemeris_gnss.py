"""Galileo and BeiDou broadcast records (Galileo OS SIS ICD, BDS-SIS-ICD-B1I 3.0) on a real file.

Data: tests/data/VILL00ESP_R_20181700000_06H_MN.rnx, six hours of a station's RINEX 3.03
mixed navigation file (georinex test data; see tests/data/README.md). No expected number
comes from this code: the checks are physical.

* Consecutive records of one satellite (Galileo every 10 min, BDS every hour) are two
  independent fits of the same orbit: propagated to a time between their Toe they must
  agree to the broadcast fit error (decimetres to metres).
* A BDS GEO record stays near one point of the geostationary ring; the MEO formula on the
  same record leaves the 5 degree tilt of the GEO elements in it.
* Orbit radii are those of the constellations' semi-major axes.
* Galileo I/NAV (clock for E1,E5b) and F/NAV (clock for E1,E5a) records of one epoch are
  two independent clock fits: their E1 single-frequency clocks (with the matching BGD)
  must agree, as their dual-frequency clocks need not.
* Galileo positions agree with CODE's final MGEX orbit of the same day (another file
  pair, BRDC00IGS_R_20201361400_02H_EN.rnx and COD0MGXFIN_..._E01E02.SP3): the check
  that sees the time system and the Earth rotation rate. No such pair with BeiDou
  records was at hand, so BDT = GPST - 14 s and the CGCS2000 rotation rate are applied
  as the ICD states but not checked against a truth here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.navigation import ephemeris as ephem
from gnssframework.navigation.ephemeris import Ephemerides, read_rinex_nav, satellite_state

NAV = Path(__file__).resolve().parents[1] / "data" / "VILL00ESP_R_20181700000_06H_MN.rnx"
BRDC = NAV.parent / "BRDC00IGS_R_20201361400_02H_EN.rnx"
SP3 = NAV.parent / "COD0MGXFIN_20201361420_01H_05M_ORB_E01E02.SP3"
TUESDAY_S = 2 * 86400.0  # 2018-06-19 00:00 is 2 days into its GPS week (and its BDT week)
C_MPS = 299_792_458.0


@pytest.fixture(scope="module")
def eph() -> Ephemerides:
    return read_rinex_nav(NAV, "GEC")


def _records(path: Path) -> dict[str, list[list[str]]]:
    """The file's records as text lines, per satellite (RINEX 3: a header line, then orbit lines)."""
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    out: dict[str, list[list[str]]] = {}
    current: list[str] = []
    for line in lines[start:]:
        if line[:1] != " ":
            current = [line]
            out.setdefault(line[:3], []).append(current)
        else:
            current.append(line)
    return out


def _field(record: list[str], row: int, col: int) -> float:
    """Field ``col`` (0-3) of BROADCAST ORBIT ``row`` (0: the SV/epoch/clock line), RINEX 3 layout."""
    start = (23 if row == 0 else 4) + 19 * (col - (1 if row == 0 else 0))
    return float(record[row][start : start + 19].replace("D", "E"))


def _consecutive_gaps(eph: Ephemerides, sv: str) -> np.ndarray:
    """Distance (m) between consecutive records' positions at the midpoint of their Toe."""
    idx = np.flatnonzero(eph.sv == sv)
    idx = idx[np.argsort(eph.elements["Toe"][idx], kind="stable")]
    offset = ephem.SYSTEM_TIME_OFFSET_S[sv[0]]
    gaps = []
    for a, b in zip(idx[:-1], idx[1:]):
        toe_a, toe_b = eph.elements["Toe"][a], eph.elements["Toe"][b]
        if toe_b == toe_a or toe_b - toe_a > 3600.0:
            continue  # I/NAV and F/NAV of one epoch, or a gap in the file
        p = satellite_state(eph.subset(np.array([a, b])), (toe_a + toe_b) / 2 + offset).position_m
        gaps.append(np.linalg.norm(p[0] - p[1]))
    return np.array(gaps)


def test_the_file_is_read_per_system_and_glonass_is_refused_in_one_line(eph):
    text = _records(NAV)
    for letter in "GEC":
        n_text = sum(len(v) for k, v in text.items() if k[0] == letter)
        assert eph.of_systems(letter).sv.size == n_text, letter  # every record, I/NAV and F/NAV alike
    assert read_rinex_nav(NAV).sv.size == sum(len(v) for k, v in text.items() if k[0] == "G")  # default: GPS
    assert "R01" in text and not np.any(eph.sv.astype("U1") == "R")
    with pytest.raises(ValueError, match=r"^GLONASS \(R\) records are position/velocity/acceleration state vectors"):
        read_rinex_nav(NAV, "GR")
    with pytest.raises(ValueError, match="GLONASS"):
        eph.select(["E19", "R01"], TUESDAY_S)
    with pytest.raises(ValueError, match=r"system 'I' \(NavIC/IRNSS\) is not handled"):
        eph.of_systems("I")
    assert eph.select(["G05", "E19", "C05"], TUESDAY_S + 3600).sv.tolist() == ["G05", "E19", "C05"]


def test_a_system_missing_from_the_file_is_named():
    gps_only = NAV.parent / "07590920.05n"  # RINEX 2: georinex returns its GPS records whatever it is asked
    assert read_rinex_nav(gps_only, "GEC").sv.size == read_rinex_nav(gps_only).sv.size
    with pytest.raises(ephem.DataFileError, match=r"07590920.05n: not a Galileo navigation file: it holds no Galileo"):
        read_rinex_nav(gps_only, "E")
    with pytest.raises(ephem.DataFileError, match=r"not a BeiDou navigation file: it holds no BeiDou \(C\) record"):
        read_rinex_nav(BRDC, "C")


def test_health_and_accuracy_fields_are_carried(eph):
    text = _records(NAV)
    c16 = eph.of_systems("C").subset(np.flatnonzero(eph.of_systems("C").sv == "C16"))
    sat_h1 = [_field(r, 6, 1) for r in text["C16"]]
    assert sorted(c16.health.tolist()) == sorted(sat_h1) and set(sat_h1) == {1.0}  # SatH1 = 1: not healthy
    with pytest.raises(KeyError, match="no healthy ephemeris of C16"):
        eph.select(["C16"], TUESDAY_S)
    e19 = eph.subset(np.flatnonzero(eph.sv == "E19"))
    assert sorted(e19.accuracy_m.tolist()) == sorted(_field(r, 6, 0) for r in text["E19"])  # SISA, m
    assert sorted(e19.iode.tolist()) == sorted(_field(r, 1, 0) for r in text["E19"])  # IODnav


def test_consecutive_records_agree_between_their_toe(eph, monkeypatch):
    gaps = {sv: _consecutive_gaps(eph, sv) for sv in ("E01", "E19", "E24", "C05", "C10", "C14", "C11")}
    assert all(g.size for g in gaps.values())
    # Galileo, 10 min to 1 h apart: decimetres (measured at most 0.17 m).
    assert max(gaps[sv].max() for sv in ("E01", "E19", "E24")) < 0.4, gaps
    # BDS, 1 h apart: metres (measured 0.15-0.8 m, 6 m for C11's 05:00-06:00 pair).
    assert max(gaps[sv].max() for sv in ("C05", "C10", "C14", "C11")) < 10.0, gaps
    # GPS's GM on Galileo records: the mean motion is off by 7e-8 relative, the fit no
    # longer closes (measured 0.8 m on E19).
    monkeypatch.setattr(ephem, "GM_GAL_BDS_M3_S2", ephem.GM_GPS_M3_S2)
    assert _consecutive_gaps(eph, "E19").max() > 0.5
    monkeypatch.undo()
    # The MEO formula on the GEO records: consecutive records disagree by far more.
    monkeypatch.setattr(ephem, "is_bds_geo", lambda sv: np.zeros(np.size(sv), bool))
    assert _consecutive_gaps(eph, "C05").max() > 1000.0


def test_a_bds_geo_record_stays_on_the_geostationary_ring(eph, monkeypatch):
    record = eph.select(["C05"], TUESDAY_S + 3 * 3600)
    t = TUESDAY_S + np.arange(0.0, 6 * 3600 + 1, 600.0)[:, None]  # 00:00-06:00 GPS time

    def track():
        p = satellite_state(record, t).position_m[:, 0]
        r = np.linalg.norm(p, axis=-1)
        return p, r, np.degrees(np.arcsin(p[:, 2] / r)), np.degrees(np.arctan2(p[:, 1], p[:, 0]))

    p, r, lat, lon = track()
    assert np.all(np.abs(r - 42_164e3) < 50e3), r  # the geostationary radius (measured 42,149-42,155 km)
    assert np.all(np.abs(lat) < 2.0), lat  # an inclination of about 1.4 degrees (measured -1.44 to -0.15)
    assert np.all(np.abs(lon - 58.75) < 0.5), lon  # C05's slot, 58.75 E
    assert np.linalg.norm(p - p.mean(0), axis=-1).max() < 800e3  # measured 628 km, the inclination's swing
    monkeypatch.setattr(ephem, "is_bds_geo", lambda sv: np.zeros(np.size(sv), bool))
    p, r, lat, lon = track()
    assert np.abs(lat).max() > 4.0 and np.linalg.norm(p - p.mean(0), axis=-1).max() > 1200e3


def test_orbit_radii_of_the_constellations(eph):
    t = TUESDAY_S + 3 * 3600
    for svs, radius_m in ((["E01", "E19", "E24"], 29_600e3), (["C11", "C14"], 27_906e3), (["C10"], 42_164e3)):
        rec = eph.select(svs, t, healthy_only=False)
        r = np.linalg.norm(satellite_state(rec, t + np.arange(0.0, 3600.0, 600.0)[:, None]).position_m, axis=-1)
        assert np.all(np.abs(r - radius_m) < 100e3), (svs, r)  # eccentricities below 1e-3 (E, C MEO), 0.01 (IGSO)


def test_velocity_is_the_derivative_of_position_for_galileo_and_bds_geo(eph):
    rec = eph.select(["E19", "C05", "C10", "C14"], TUESDAY_S + 3600, healthy_only=False)
    t = TUESDAY_S + 3600 + np.array([-1500.0, 0.0, 1700.0])[:, None]
    h = 0.5
    state = satellite_state(rec, t)
    numeric = (satellite_state(rec, t + h).position_m - satellite_state(rec, t - h).position_m) / (2 * h)
    np.testing.assert_allclose(state.velocity_mps, numeric, atol=1e-4)  # as the GPS test: 4e-6 m/s expected
    drift = (satellite_state(rec, t + h).clock_s - satellite_state(rec, t - h).clock_s) / (2 * h)
    np.testing.assert_allclose(state.clock_drift_s_s, drift, atol=1e-16)


def test_clock_terms_and_group_delays_as_the_icds_state(eph):
    # F = -2 sqrt(mu) / c^2 with the Galileo/BDS mu (Galileo ICD 5.1.4, BDS ICD 5.2.4.10).
    assert ephem.F_RELATIVISTIC_GAL_BDS_S_SQRTM == pytest.approx(-2 * np.sqrt(3.986004418e14) / C_MPS**2, rel=1e-9)
    text = _records(NAV)
    # E19's 01:00 records: I/NAV (data source 517, clock for E5b,E1) then F/NAV (258, E5a,E1).
    inav, fnav = [r for r in text["E19"] if r[0][4:23] == "2018 06 19 01 00 00"]
    assert (_field(inav, 5, 1), _field(fnav, 5, 1)) == (517.0, 258.0)
    idx = np.flatnonzero((eph.sv == "E19") & (eph.toc_s == TUESDAY_S + 3600))
    state = satellite_state(eph.subset(idx), TUESDAY_S + 3600 + 250.0)  # GST seconds = GPS seconds
    for k, rec, bgd in ((0, inav, _field(inav, 6, 3)), (1, fnav, _field(fnav, 6, 2))):
        af0, af1, af2 = (_field(rec, 0, j) for j in (1, 2, 3))
        expected = af0 + af1 * 250.0 + af2 * 250.0**2 + state.relativistic_s[k]
        assert state.clock_s[k] == pytest.approx(expected, abs=1e-18)
        assert state.clock_s[k] - state.clock_l1_s[k] == pytest.approx(bgd, abs=1e-18)  # E1 user: BGD of its pair
    # Two independent clock fits: their E1 clocks agree (measured 0.35 ns at most over the file), as the
    # dual-frequency clocks do not (up to 5 ns apart): so the BGD of the pair matters.
    gaps_e1, gaps_dual = [], []
    for sv in ("E01", "E19", "E24"):
        idx = np.flatnonzero(eph.sv == sv)
        for toc in np.unique(eph.toc_s[idx]):
            pair = idx[eph.toc_s[idx] == toc]
            if pair.size == 2:
                s = satellite_state(eph.subset(pair), toc + 300.0)
                gaps_e1.append(abs(s.clock_l1_s[0] - s.clock_l1_s[1]))
                gaps_dual.append(abs(s.clock_s[0] - s.clock_s[1]))
    assert len(gaps_e1) > 20 and max(gaps_e1) < 0.5e-9 and max(gaps_dual) > 2e-9, (max(gaps_e1), max(gaps_dual))
    # C14's 01:00 record (BDT): B1I user clock = clock - T_GD1; GPS time t is BDT t - 14 s.
    rec = next(r for r in text["C14"] if r[0][4:23] == "2018 06 19 01 00 00")
    af0, af1, af2 = (_field(rec, 0, j) for j in (1, 2, 3))
    c14 = eph.select(["C14"], TUESDAY_S + 3600 + 14, healthy_only=False)
    assert c14.toc_s[0] == TUESDAY_S + 3600  # the record's epoch, in BDT
    state = satellite_state(c14, TUESDAY_S + 3600 + 14 + 100.0)  # BDT 01:01:40
    assert state.clock_s[0] == pytest.approx(af0 + af1 * 100.0 + af2 * 1e4 + state.relativistic_s[0], abs=1e-18)
    assert state.clock_s[0] - state.clock_l1_s[0] == pytest.approx(_field(rec, 6, 2), abs=1e-18)


def _sp3_positions(path: Path) -> dict[str, np.ndarray]:
    """``{sv: (epochs, 4)}`` of GPS seconds of week and ECEF position (m) from an SP3-d file."""
    lines = path.read_text().splitlines()
    assert next(line for line in lines if line.startswith("%c"))[9:12] == "GPS"  # the file's time system
    out: dict[str, list] = {}
    t = None
    for line in lines:
        if line.startswith("*  "):
            y, mo, d, h, mi, sec = line[3:].split()[:6]
            epoch = np.datetime64(f"{int(y):04d}-{int(mo):02d}-{int(d):02d}T{int(h):02d}:{int(mi):02d}")
            t = ephem.gps_seconds_of_week(epoch) + float(sec)
        elif line.startswith("P") and t is not None:
            out.setdefault(line[1:4], []).append((t, *(float(x) * 1e3 for x in line[4:46].split())))
    return {k: np.array(v) for k, v in out.items()}


def _errors_to_precise_orbit(eph: Ephemerides, ref: dict[str, np.ndarray]) -> np.ndarray:
    errors = []
    for sv, rows in ref.items():
        for t, *position in rows:
            state = satellite_state(eph.select([sv], t), t)
            errors.append(np.linalg.norm(state.position_m[0] - position))
    return np.array(errors)


def test_galileo_positions_against_a_precise_orbit(monkeypatch):
    # CODE's final MGEX orbit (centre of mass, GPS time) of the same day: the broadcast
    # orbit (antenna phase centre) agrees to the antenna offset and the broadcast error.
    # The IGS merge writes up to four records per epoch, some with a spare field more per line;
    # georinex shifts the later fields of those (health 3.12, a BGD as transmission time).
    with pytest.warns(UserWarning, match=r"BRDC00IGS_R_20201361400_02H_EN.rnx: 6 Galileo records misread by georinex"):
        eph = read_rinex_nav(BRDC, "E")
    assert eph.sv.size == 48 - 6 and np.all(eph.health == 0) and np.all(eph.accuracy_m == 3.12)
    ref = _sp3_positions(SP3)
    assert sorted(ref) == ["E01", "E02"] and all(rows.shape == (17, 4) for rows in ref.values())
    errors = _errors_to_precise_orbit(eph, ref)
    assert errors.max() < 3.0, errors  # measured 0.83-1.30 m over 80 min
    # That is what checks the time system and the Earth rotation rate, which consecutive
    # records cannot (both records move together): a 1 s offset of GST from GPS time is
    # km, BeiDou's rotation rate on Galileo records about 20 m.
    monkeypatch.setitem(ephem.SYSTEM_TIME_OFFSET_S, "E", 1.0)
    assert _errors_to_precise_orbit(eph, ref).min() > 1000.0
    monkeypatch.undo()
    monkeypatch.setattr(ephem, "OMEGA_EARTH_RAD_S", ephem.OMEGA_EARTH_BDS_RAD_S)
    assert _errors_to_precise_orbit(eph, ref).min() > 10.0


def test_qzss_records_take_gps_constants_and_time(eph):
    # IS-QZSS-PNT-005: the L1 C/A ephemeris and its user algorithm are IS-GPS-200's, on GPS
    # time. A GPS record renamed J01 must give the same state to the bit; renamed E01 (the
    # Galileo GM) it must not (GM 3.986004418e14 against 3.986005e14 moves a MEO metres).
    g = eph.of_systems("G").subset(np.array([0]))
    t = float(g.elements["Toe"][0]) + 3000.0
    renamed = {
        letter: Ephemerides(np.array([f"{letter}01"]), g.toc_s, g.elements, g.health, g.iode, g.accuracy_m)
        for letter in "JE"
    }
    gps, qzss, gal = (satellite_state(e, t) for e in (g, renamed["J"], renamed["E"]))
    assert np.array_equal(gps.position_m, qzss.position_m) and np.array_equal(gps.clock_l1_s, qzss.clock_l1_s)
    assert np.linalg.norm(gps.position_m - gal.position_m) > 0.5
    with pytest.raises(ephem.DataFileError, match=r"not a QZSS navigation file: it holds no QZSS \(J\) record"):
        read_rinex_nav(NAV, "J")


def test_a_qzss_record_is_read_with_gps_fields(tmp_path):
    # A RINEX 3 QZSS record has the GPS record's layout (RINEX 3.03 A-31); the file's first
    # GPS record written again as J01 must read back with the same elements and group delay.
    lines = NAV.read_text().splitlines()
    end = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    g05 = lines[end : end + 8]
    assert g05[0].startswith("G05")
    path = tmp_path / "qzss.rnx"
    path.write_text("\n".join(lines[:end] + g05 + ["J01" + g05[0][3:]] + g05[1:]) + "\n")
    both = read_rinex_nav(path, "GJ")
    assert both.sv.tolist() == ["G05", "J01"]
    for name in ephem.ORBIT_FIELDS + ephem.CLOCK_FIELDS:
        assert both.elements[name][0] == both.elements[name][1], name
    assert both.toc_s[0] == both.toc_s[1] and both.health[1] == 0 and both.iode[0] == both.iode[1]
