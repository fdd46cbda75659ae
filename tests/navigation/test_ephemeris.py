"""Satellite states from broadcast ephemerides (IS-GPS-200) against a real observation file.

Truth: RTKLIB's RINEX 2 pair 07590920.05o/.05n (tests/data): pseudoranges of a geodetic
receiver whose position the header states. After the satellite clock, the Sagnac rotation
and a nominal troposphere, the ionosphere-free code residuals of all satellites must agree
to the level of code noise, multipath and broadcast orbit error (metres); the receiver
clock is the common part removed per epoch.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pymap3d
import pytest

import gnssframework as gf
from gnssframework.io.observations import SPEED_OF_LIGHT_MPS as C
from gnssframework.io.observations import read_observations
from gnssframework.navigation.ephemeris import (
    OMEGA_EARTH_RAD_S,
    Ephemerides,
    gps_seconds_of_week,
    read_rinex_nav,
    satellite_state,
)

DATA = Path(__file__).resolve().parents[1] / "data"
OBS, NAV = DATA / "07590920.05o", DATA / "07590920.05n"
F1, F2 = 1575.42e6, 1227.60e6


@pytest.fixture(scope="module")
def pair():
    import georinex

    obs = read_observations(OBS, "G")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        p2 = georinex.load(OBS, meas=["P2"])["P2"].sel(sv=list(obs.sv)).values  # second code, for iono-free
    return obs, p2, read_rinex_nav(NAV)


def _residuals(obs, code_m, eph, clock: str, relativistic: bool = True):
    """Code minus (range - c clock + troposphere), per epoch minus its median; elevations > 15 deg."""
    t_rx = gps_seconds_of_week(obs.epoch)
    lat, lon, h = pymap3d.ecef2geodetic(*obs.position_m)
    out = []
    for k in range(obs.epoch.size):
        ok = np.isfinite(code_m[k])
        records = eph.select(obs.sv[ok], t_rx[k])
        pr = code_m[k, ok]
        t_tx = t_rx[k] - pr / C
        for _ in range(2):  # the ICD's t is the SV time corrected by the SV clock
            state = satellite_state(records, t_tx)
            sv_clock = getattr(state, clock) - (0.0 if relativistic else state.relativistic_s)
            t_tx = t_rx[k] - pr / C - sv_clock
        theta = OMEGA_EARTH_RAD_S * (t_rx[k] - t_tx)  # Earth rotation during the flight (Sagnac)
        x, y, z = state.position_m.T
        pos = np.stack([x * np.cos(theta) + y * np.sin(theta), -x * np.sin(theta) + y * np.cos(theta), z], -1)
        _, el, _ = pymap3d.ecef2aer(*pos.T, lat, lon, h)
        tropo = 2.3 / np.sin(np.radians(el))  # zenith delay about 2.3 m, 1/sin(el) mapping
        r = pr - (np.linalg.norm(pos - obs.position_m, axis=-1) - C * sv_clock + tropo)
        keep = el > 15
        out.append(r[keep] - np.median(r[keep]))
    return np.concatenate(out)


def test_ionosphere_free_residuals_are_metres_and_need_the_relativistic_term(pair):
    obs, p2, eph = pair
    iono_free = (F1**2 * obs.pseudorange_m - F2**2 * p2) / (F1**2 - F2**2)  # IS-GPS-200 20.3.3.3.3.3
    res = _residuals(obs, iono_free, eph, "clock_s")
    assert res.size > 500 and np.std(res) < 2.0, np.std(res)
    without = _residuals(obs, iono_free, eph, "clock_s", relativistic=False)
    assert np.std(without) > 1.5 * np.std(res), (np.std(without), np.std(res))


def test_l1_single_frequency_residuals_with_tgd(pair):
    obs, _, eph = pair
    res = _residuals(obs, obs.pseudorange_m, eph, "clock_l1_s")  # ionosphere left in: a few metres more
    assert np.std(res) < 4.0, np.std(res)


def test_clock_terms_and_tgd_are_the_records_fields():
    # G03's record of 2005-04-02 00:00 (Toe 518400 s), read at the columns of RINEX 2.11 table A4.
    eph = read_rinex_nav(NAV)
    text = NAV.read_text().splitlines()
    head = next(i for i, line in enumerate(text) if line.startswith(" 3 05  4  2  0  0  0.0"))
    af0, af1, af2 = (float(text[head][22 + 19 * j : 41 + 19 * j].replace("D", "E")) for j in range(3))
    tgd = float(text[head + 6][41:60].replace("D", "E"))  # BROADCAST ORBIT - 6, third field
    rec = eph.select(["G03"], 518400.0)
    assert rec.elements["SVclockBias"][0] == af0 and rec.elements["SVclockDrift"][0] == af1
    assert rec.elements["SVclockDriftRate"][0] == af2 and rec.elements["TGD"][0] == tgd
    state = satellite_state(rec, 518500.0)
    assert state.clock_s[0] - state.clock_l1_s[0] == pytest.approx(tgd, abs=1e-18)  # 1e-4 s values: ulp 1e-20
    assert state.clock_s[0] == pytest.approx(af0 + af1 * 100.0 + af2 * 1e4 + state.relativistic_s[0], abs=1e-18)


def test_velocity_is_the_derivative_of_position():
    eph = read_rinex_nav(NAV)
    rec = eph.select(np.unique(eph.sv), 3600.0)
    t = 3600.0 + np.array([-1800.0, 0.0, 2000.0])[:, None]
    h = 0.5
    state = satellite_state(rec, t)
    numeric = (satellite_state(rec, t + h).position_m - satellite_state(rec, t - h).position_m) / (2 * h)
    # Central difference error h^2/6 |d3r/dt3|: jerk ~ n^2 v = (1.46e-4)^2 3900 = 8e-5 m/s^3, so 4e-6 m/s;
    # rounding 2.7e7 m * 2e-16 / 1 s = 5e-9 m/s. A wrong derivative term is off by mm/s to m/s.
    np.testing.assert_allclose(state.velocity_mps, numeric, atol=1e-4)
    drift = (satellite_state(rec, t + h).clock_s - satellite_state(rec, t - h).clock_s) / (2 * h)
    np.testing.assert_allclose(state.clock_drift_s_s, drift, atol=1e-16)


def test_gps_seconds_of_week():
    # 2005-04-02 is a Saturday: 6 days into GPS week 1316.
    assert gps_seconds_of_week(np.datetime64("2005-04-02T00:21:30.002"))[()] == 6 * 86400 + 21 * 60 + 30.002


def test_an_observation_file_is_refused_as_navigation():
    with pytest.raises(gf.DataFileError, match=r"07590920.05o:1: not a navigation file"):
        read_rinex_nav(OBS)


def test_rinex3_navigation_records_keep_health_and_clock_fields():
    # The project's own RINEX 3.04 file: written with clock terms, TGD and health of zero.
    nav = Path(__file__).resolve().parents[2] / "examples" / "data" / "nominal_brdc.nav"
    eph = read_rinex_nav(nav)
    n_records = sum(line[:1] == "G" for line in nav.read_text().splitlines())
    assert eph.sv.size == n_records and np.all(eph.health == 0)
    for f in ("SVclockBias", "SVclockDrift", "SVclockDriftRate", "TGD"):
        assert np.all(eph.elements[f] == 0.0)


def test_an_unhealthy_record_is_not_selected():
    eph = read_rinex_nav(NAV)
    sick = Ephemerides(eph.sv, eph.toc_s, eph.elements, np.where(eph.sv == "G03", 1.0, eph.health), eph.iode)
    with pytest.raises(KeyError, match="no healthy ephemeris of G03"):
        sick.select(["G03"], 518400.0)
    assert sick.select(["G03"], 518400.0, healthy_only=False).sv.tolist() == ["G03"]
