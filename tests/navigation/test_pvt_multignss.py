"""The multi-GNSS least squares (`pvt.solve_position` and `pvt.solve_position_sv` with one
receiver clock per time system) on synthetic pseudoranges from real multi-GNSS geometries.

Two skies: the broadcast records of tests/data/VILL00ESP_R_20181700000_06H_MN.rnx (RINEX 3.03
mixed navigation, 2018-06-19; it holds ten satellites: two GPS, two Galileo and three BeiDou,
the GEO C05 among them, above 5 degrees at a receiver near the station at 01:30) through
`solve_position`; and the satellite positions of the first epoch of the GSDC 2022 excerpt
(tests/data/gsdc2022_device_gnss.csv: seven GPS, five Galileo, five BeiDou) at its ground-truth
position through `solve_position_sv`, where the residual test's degrees of freedom and RAIM
have room. The truth is built here: flight times by the tests' own light-time iteration
(tests/light_time.py, or the loop below), known receiver clocks per system injected into the
ranges, and the design matrix of the textbook model written out from the true geometry (rows
``[-u_ENU, e_system]``). QZSS: no QZSS record is in the file, so one is made from a GPS record
moved along its orbit and named J01: it must take GPS's clock (QZSST is aligned to GPST).

Tolerances: the solver stops when its step is under 0.1 mm and takes the Earth's rotation
over a flight time from the unrotated distance (a 0.1 mm approximation), so "exact" is 1 mm
in position and 0.01 ns (3 mm) in an offset; DOPs are closed forms of the same matrix (1e-7).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pymap3d
import pytest

from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import Ephemerides, read_rinex_nav, satellite_state
from gnssframework.navigation.pvt import solve_position, solve_position_sv
from gnssframework.navigation.rinex_nav_header import read_nav_file_info
from light_time import C, signal_flight

NAV = Path(__file__).resolve().parents[1] / "data" / "VILL00ESP_R_20181700000_06H_MN.rnx"
LAT, LON, HEIGHT = 40.4433, -3.9522, 647.0  # near the station
RECEIVER = np.array(pymap3d.geodetic2ecef(LAT, LON, HEIGHT))
T_RX = 2 * 86400.0 + 1.5 * 3600.0  # 2018-06-19 01:30 GPS time
#: Receiver clocks (m) injected per clock state: GPS (and QZSS), Galileo, BeiDou.
CLOCK_M = {"G": 1234.5, "E": 1234.5 + 37e-9 * C, "C": 1234.5 - 120e-9 * C}
GROUP = {"G": "G", "J": "G", "E": "E", "C": "C"}


def _qzss_from(record: Ephemerides) -> Ephemerides:
    """A QZSS record: a GPS record's orbit 40 degrees further along, named J01."""
    elements = {k: v.copy() for k, v in record.elements.items()}
    elements["M0"] = elements["M0"] + np.radians(40.0)
    return Ephemerides(
        np.array(["J01"]),
        record.toc_s.copy(),
        elements,
        record.health.copy(),
        record.iode.copy(),
        None if record.accuracy_m is None else record.accuracy_m.copy(),
    )


def _join(a: Ephemerides, b: Ephemerides) -> Ephemerides:
    acc = None if a.accuracy_m is None or b.accuracy_m is None else np.r_[a.accuracy_m, b.accuracy_m]
    return Ephemerides(
        np.r_[a.sv, b.sv],
        np.r_[a.toc_s, b.toc_s],
        {k: np.r_[a.elements[k], b.elements[k]] for k in a.elements},
        np.r_[a.health, b.health],
        np.r_[a.iode, b.iode],
        acc,
    )


def _elevation_deg(eph: Ephemerides) -> np.ndarray:
    up = np.array(pymap3d.geodetic2ecef(LAT, LON, HEIGHT + 1.0)) - RECEIVER
    los = satellite_state(eph, T_RX).position_m - RECEIVER
    return np.degrees(np.arcsin(los @ up / np.linalg.norm(los, axis=1)))


@pytest.fixture(scope="module")
def sky() -> Ephemerides:
    nav = read_rinex_nav(NAV, "GEC")
    sel = nav.select(np.unique(nav.sv[nav.health == 0]), T_RX)
    gps = sel.subset(np.flatnonzero(sel.sv.astype("U1") == "G"))
    # The GPS record whose copy 40 degrees along is highest.
    qzss = max(
        (_qzss_from(gps.subset(np.array([i]))) for i in range(gps.sv.size)), key=lambda r: float(_elevation_deg(r)[0])
    )
    sky = _join(sel, qzss)
    return sky.subset(np.flatnonzero(_elevation_deg(sky) > 5.0))


def _ranges(sky: Ephemerides, clock_m: dict[str, float]):
    """Pseudoranges with each satellite's system clock, transmit times and the true geometry."""
    flight = signal_flight(sky, T_RX, RECEIVER)
    bias = np.array([clock_m[GROUP[s[0]]] for s in sky.sv])
    return C * flight.tau_s + bias - C * flight.clock_s, T_RX - flight.tau_s + flight.clock_s, flight


def _textbook_dops(names, sat_m: np.ndarray, clocks: str, receiver=RECEIVER, lat=LAT, lon=LON) -> np.ndarray:
    """sqrt of the diagonal sums of (H^T H)^-1, H = [-u_ENU, one-hot of the system's clock],
    of satellites ``names`` at ``sat_m`` (ECEF of reception)."""
    u = sat_m - receiver
    u = u / np.linalg.norm(u, axis=1)[:, None]
    la, lo = np.radians(lat), np.radians(lon)
    enu = np.array(
        [
            [-np.sin(lo), np.cos(lo), 0.0],
            [-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)],
            [np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)],
        ]
    )
    column = np.array([clocks.index(GROUP[s[0]]) for s in names])
    H = np.hstack([-(u @ enu.T), (column[:, None] == np.arange(len(clocks))).astype(float)])
    d = np.diag(np.linalg.inv(H.T @ H))
    return np.sqrt([d.sum(), d[:3].sum(), d[:2].sum(), d[2]])


def test_the_sky_has_every_system(sky):
    letters = sky.sv.astype("U1").tolist()
    assert [letters.count(s) for s in "GJEC"] == [2, 1, 2, 3] and "C05" in sky.sv


def test_noise_free_ranges_give_the_position_and_the_injected_offsets(sky):
    pr, tx, flight = _ranges(sky, CLOCK_M)
    fix = solve_position(pr, tx, sky, elevation_mask_deg=0.0)
    assert np.linalg.norm(fix.position_ecef_m - RECEIVER) < 1e-3
    assert fix.clock_systems == "GEC" and fix.used.all()
    assert fix.clock_bias_m == pytest.approx(CLOCK_M["G"], abs=1e-3)
    assert fix.system_offsets_ns["E"] == pytest.approx(37.0, abs=1e-2)
    assert fix.system_offsets_ns["C"] == pytest.approx(-120.0, abs=1e-2)
    assert np.nanmax(np.abs(fix.residuals_m)) < 1e-3
    # DOPs with three clock states are the textbook (H^T H)^-1 of the true geometry.
    assert [fix.gdop, fix.pdop, fix.hdop, fix.vdop] == pytest.approx(
        _textbook_dops(sky.sv, flight.position_m, "GEC"), rel=1e-7
    )
    # A single clock cannot absorb 37 and -120 ns: the same ranges forced into one clock
    # (the offsets given as zero) leave metres of residuals.
    single = solve_position(pr, tx, sky, elevation_mask_deg=0.0, time_offsets_s={"E": 0.0, "C": 0.0})
    assert single.clock_systems == "G" and np.nanmax(np.abs(single.residuals_m)) > 5.0


def test_a_constellation_selection_estimates_its_own_clocks(sky):
    pr, tx, flight = _ranges(sky, CLOCK_M)
    assert solve_position(pr, tx, sky, systems="C") is None  # three satellites: too few
    for systems, clocks in (("GJE", "GE"), ("GJC", "GC"), ("EC", "EC"), ("GEC", "GEC")):
        fix = solve_position(pr, tx, sky, elevation_mask_deg=0.0, systems=systems)
        letters = sky.sv.astype("U1")
        assert np.array_equal(fix.used, np.isin(letters, list(systems))), systems
        assert fix.clock_systems == clocks
        assert np.linalg.norm(fix.position_ecef_m - RECEIVER) < 1e-3, systems
        assert fix.clock_bias_m == pytest.approx(CLOCK_M[clocks[0]], abs=1e-3)
        for other in clocks[1:]:  # each offset against the reference clock (GPS's, else the first)
            assert fix.system_offsets_ns[other] == pytest.approx(
                (CLOCK_M[other] - CLOCK_M[clocks[0]]) / C * 1e9, abs=1e-2
            )
        chosen = np.isin(letters, list(systems))
        textbook = _textbook_dops(sky.sv[chosen], flight.position_m[chosen], clocks)
        assert [fix.gdop, fix.pdop, fix.hdop, fix.vdop] == pytest.approx(textbook, rel=1e-7)


def test_a_known_ggto_replaces_the_galileo_clock(sky):
    # The Galileo satellites' clock is GPS's less c GGTO (GGTO = GST - GPST, Galileo OS SIS ICD
    # 5.1.8): a receiver with no inter-system hardware bias, given GGTO, needs no Galileo clock.
    # GGTO as the file's header broadcasts it (GPGA: 22.32 ns at 259200 s, -1.02e-14 s/s):
    # 23.15 ns at 01:30 Tuesday (178200 s).
    ggto_s = read_nav_file_info(NAV).ggto_s(2006, T_RX)
    assert ggto_s == pytest.approx(2.2322637960e-08 - 1.021405183e-14 * (178200 - 259200), rel=1e-12)
    clocks = dict(CLOCK_M, E=CLOCK_M["G"] - C * ggto_s)
    pr, tx, _ = _ranges(sky, clocks)
    fix = solve_position(pr, tx, sky, elevation_mask_deg=0.0, time_offsets_s={"E": ggto_s})
    assert fix.clock_systems == "GC" and set(fix.system_offsets_ns) == {"C"}
    assert np.linalg.norm(fix.position_ecef_m - RECEIVER) < 1e-3
    wrong = solve_position(pr, tx, sky, elevation_mask_deg=0.0, time_offsets_s={"E": -ggto_s})
    assert np.linalg.norm(wrong.position_ecef_m - RECEIVER) > 1.0  # the sign matters
    with pytest.raises(ConfigError, match="time_offsets_s"):
        solve_position(pr, tx, sky, time_offsets_s={"G": 1e-9})
    with pytest.raises(ConfigError, match="systems"):
        solve_position(pr, tx, sky, systems="GR")


GSDC = Path(__file__).resolve().parents[1] / "data" / "gsdc2022_device_gnss.csv"
OMEGA_E = 7.2921151467e-5


@pytest.fixture(scope="module")
def phone_sky():
    """The first GSDC epoch's GPS L1, Galileo E1 and BeiDou B1I satellites: their positions
    (ECEF at transmit time), system letters, and the ground-truth receiver position."""
    from gnssframework.io.gsdc import read_gsdc_measurements, read_gsdc_truth

    m = read_gsdc_measurements(GSDC)
    truth = read_gsdc_truth(GSDC.parent / "gsdc2022_ground_truth.csv")
    rows = (m.utc_ms == m.utc_ms[0]) & np.isin(m.signal, ["GPS_L1", "GAL_E1", "BDS_B1I"])
    rows &= np.isfinite(m.pseudorange_m)
    i = int(np.flatnonzero(truth.utc_ms == m.utc_ms[0])[0])
    receiver = np.array(pymap3d.geodetic2ecef(truth.lat_deg[i], truth.lon_deg[i], truth.height_m[i]))
    return m.sv_position_ecef_m[rows], m.system[rows], receiver, (truth.lat_deg[i], truth.lon_deg[i], truth.height_m[i])


def _phone_ranges(sv_pos, letters, receiver, clock_m):
    """Geometric ranges with the Earth rotated over the flight (iterated here), plus clocks."""
    tau = np.full(len(letters), 0.07)
    for _ in range(6):
        th = OMEGA_E * tau
        rot = np.stack(
            [
                np.cos(th) * sv_pos[:, 0] + np.sin(th) * sv_pos[:, 1],
                -np.sin(th) * sv_pos[:, 0] + np.cos(th) * sv_pos[:, 1],
                sv_pos[:, 2],
            ],
            axis=1,
        )
        tau = np.linalg.norm(rot - receiver, axis=1) / C
    return C * tau + np.array([clock_m[GROUP[s]] for s in letters]), rot


def test_the_phone_sky_is_recovered_with_its_offsets_and_textbook_dops(phone_sky):
    sv_pos, letters, receiver, (lat, lon, _) = phone_sky
    assert [int((letters == s).sum()) for s in "GEC"] == [7, 4, 5]
    pr, rot = _phone_ranges(sv_pos, letters, receiver, CLOCK_M)
    sv_clock = np.linspace(-3e5, 3e5, len(letters))  # satellite clocks (m), added back by the solver
    fix = solve_position_sv(pr - sv_clock, sv_pos, sv_clock, letters, sigma_m=1.0)
    assert np.linalg.norm(fix.position_ecef_m - receiver) < 1e-3 and fix.clock_systems == "GEC"
    assert fix.system_offsets_ns == pytest.approx({"E": 37.0, "C": -120.0}, abs=1e-2)
    textbook = _textbook_dops(letters, rot, "GEC", receiver, lat, lon)
    assert [fix.gdop, fix.pdop, fix.hdop, fix.vdop] == pytest.approx(textbook, rel=1e-7)
    # A GPS satellite named QZSS keeps the GPS clock: the same solution.
    as_qzss = letters.copy()
    as_qzss[0] = "J"
    again = solve_position_sv(pr - sv_clock, sv_pos, sv_clock, as_qzss, sigma_m=1.0)
    assert again.clock_systems == "GEC" and np.linalg.norm(again.position_ecef_m - receiver) < 1e-3


def test_a_lone_satellite_of_a_system_is_left_out(phone_sky):
    sv_pos, letters, receiver, _ = phone_sky
    pr, _ = _phone_ranges(sv_pos, letters, receiver, CLOCK_M)
    keep = np.flatnonzero((letters != "C") | (np.cumsum(letters == "C") == 1))  # one BeiDou satellite
    fix = solve_position_sv(pr[keep], sv_pos[keep], np.zeros(keep.size), letters[keep])
    lone = int(np.flatnonzero(letters[keep] == "C")[0])
    assert not fix.used[lone] and fix.used.sum() == keep.size - 1 and fix.clock_systems == "GE"
    assert np.linalg.norm(fix.position_ecef_m - receiver) < 1e-3


def test_the_residual_test_counts_one_degree_of_freedom_per_clock(phone_sky):
    # Unit-variance noise and 1/sigma^2 weights: the weighted sum of squared residuals of a
    # linear(ised) least squares is chi-square with n - 3 - k degrees of freedom (k = 3
    # clocks: 16 - 6 = 10, mean 10). Counting one clock (n - 4) would put the mean 2 higher:
    # over 300 trials the standard error is sqrt(2 * 10 / 300) = 0.26, so 7.7 of them.
    sv_pos, letters, receiver, _ = phone_sky
    pr, _ = _phone_ranges(sv_pos, letters, receiver, CLOCK_M)
    rng = np.random.default_rng(39)
    trials = 300
    zero = np.zeros(len(letters))
    stats = np.array(
        [
            solve_position_sv(
                pr + rng.standard_normal(pr.size), sv_pos, zero, letters, sigma_m=1.0, raim="chi2", false_alarm=1e-9
            ).test_statistic
            for _ in range(trials)
        ]
    )
    dof = len(letters) - 6
    assert abs(stats.mean() - dof) < 4 * np.sqrt(2 * dof / trials)


@pytest.mark.parametrize("method", ["chi2", "ss"])
def test_raim_excludes_a_faulty_galileo_satellite_and_bounds_the_error(phone_sky, method):
    sv_pos, letters, receiver, (lat, lon, h) = phone_sky
    pr, _ = _phone_ranges(sv_pos, letters, receiver, CLOCK_M)
    rng = np.random.default_rng(7)
    j = int(np.flatnonzero(letters == "E")[1])
    bad = pr + rng.standard_normal(pr.size)
    bad[j] += 80.0
    fix = solve_position_sv(bad, sv_pos, np.zeros(len(letters)), letters, sigma_m=1.0, raim=method, false_alarm=1e-5)
    assert fix.fault_detected and fix.raim == "excluded" and fix.excluded == j and not fix.used[j]
    assert fix.clock_systems == "GEC" and np.isfinite(fix.hpl_m)
    e, n, u = pymap3d.ecef2enu(*fix.position_ecef_m, lat, lon, h)
    assert np.hypot(e, n) < fix.hpl_m and abs(u) < fix.vpl_m
