"""Constellation geometry against orbital mechanics and finite differences."""

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.simulation.constellation import GM_EARTH, OMEGA_EARTH, load_almanac, nominal_constellation


def test_orbits_have_the_gps_radius_and_a_half_sidereal_day_period():
    c = nominal_constellation()
    assert c.prn.shape == (24,)
    pos, vel, acc = c.state(np.array([0.0, 1234.5]))
    np.testing.assert_allclose(np.linalg.norm(pos, axis=-1), 26_559_700.0, rtol=1e-12)
    period_s = 2 * np.pi / c.mean_motion_rad_s
    assert period_s == pytest.approx(86164.09 / 2, rel=2e-4)  # half a sidereal day
    # In the inertial frame the acceleration is -GM r / |r|^3; in ECEF add the centrifugal
    # and Coriolis terms: a_ecef = a_i - 2 w x v - w x (w x r).
    w = np.array([0.0, 0.0, OMEGA_EARTH])
    r, v, a = pos[1], vel[1], acc[1]
    gravity = -GM_EARTH * r / np.linalg.norm(r, axis=-1, keepdims=True) ** 3
    expected = gravity - 2 * np.cross(w, v) - np.cross(w, np.cross(w, r))
    np.testing.assert_allclose(a, expected, rtol=1e-9, atol=1e-9)


def test_velocity_and_acceleration_are_the_derivatives_of_position():
    c = nominal_constellation()
    h = 1e-3
    p1, v1, _ = c.state(500.0 + h)
    p0, v0, _ = c.state(500.0 - h)
    _, v, a = c.state(500.0)
    np.testing.assert_allclose((p1 - p0) / (2 * h), v, atol=1e-4)
    np.testing.assert_allclose((v1 - v0) / (2 * h), a, atol=1e-6)


def test_visible_picks_the_highest_satellites_and_refuses_too_many_channels():
    c = nominal_constellation()
    idx = c.visible(37800.0, 34.23, 108.3576, 590.6, 10.0, 8)
    el = c.elevation_deg(37800.0, 34.23, 108.3576, 590.6)
    assert np.all(el[idx] > 10) and np.all(np.diff(el[idx]) <= 0)
    with pytest.raises(gf.ConfigError, match="scenario.channels.*at most"):
        c.visible(0.0, 34.23, 108.3576, 590.6, 10.0, 12)


def test_almanac_errors_name_the_file_and_line(tmp_path):
    f = tmp_path / "alm.csv"
    f.write_text("# comment\nprn,raan_deg,arg_lat_deg\n1,10.0,20.0\n2,abc,30.0\n")
    with pytest.raises(gf.DataFileError, match=r"alm.csv:4: bad almanac row"):
        load_almanac(f)
    f.write_text("prn,raan\n1,2\n")
    with pytest.raises(gf.DataFileError, match=r"alm.csv:1: header lacks arg_lat_deg, raan_deg"):
        load_almanac(f)


NAV = __import__("pathlib").Path(__file__).resolve().parents[2] / "examples" / "data" / "nominal_brdc.nav"


def test_broadcast_ephemeris_of_the_nominal_orbits_reproduces_the_analytic_model():
    # Two independent computations: IS-GPS-200's Keplerian user algorithm on ephemerides
    # written with e = 0, and the closed-form rotating circular orbit.
    from gnssframework.simulation.ephemeris import load_rinex_nav

    eph = load_rinex_nav(NAV, t_s=37800.0)
    nominal = nominal_constellation()
    order = np.argsort(eph.prn)
    np.testing.assert_array_equal(eph.prn[order], nominal.prn)
    t = np.array([37800.0, 41000.5])
    pe, ve, ae = eph.state(t)
    pn, vn, an = nominal.state(t)
    np.testing.assert_allclose(pe[:, order], pn, atol=1e-3)
    np.testing.assert_allclose(ve[:, order], vn, atol=1e-4)
    np.testing.assert_allclose(ae[:, order], an, atol=1e-5)


def test_vector_tracking_runs_on_broadcast_ephemeris():
    from gnssframework.experiments import get_scenario

    common = {"kind": "vector-tracking", "duration_s": 0.3, "channels": 6, "settle_s": 0.0}
    plugins = {
        "channel_filter": {"name": "discriminator", "params": {}},
        "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}},
    }
    results = []
    for extra in ({}, {"ephemeris_file": str(NAV)}):
        scen = get_scenario({**common, **extra})
        results.append(scen.run_batch({"cn0_dbhz": 45.0}, scen.build(plugins), 2, np.random.default_rng(0)).metrics)
    for m in results[0]:
        np.testing.assert_allclose(results[1][m], results[0][m], rtol=1e-4)


def test_missing_navigation_file_is_a_data_file_error(tmp_path):
    from gnssframework.simulation.ephemeris import load_rinex_nav

    with pytest.raises(gf.DataFileError, match="nope.nav: no such file"):
        load_rinex_nav(tmp_path / "nope.nav")


def _circle_csv(path, geodetic=False):
    import pymap3d

    t = np.arange(0.0, 20.5, 0.5)
    east, north = 50 * np.sin(0.2 * t), 50 * np.cos(0.2 * t)  # 10 m/s on a 50 m circle
    lat, lon, h = pymap3d.enu2geodetic(east, north, 0.0, 34.23, 108.3576, 590.6)
    rows = ["t_s,lat_deg,lon_deg,height_m" if geodetic else "t_s,x_m,y_m,z_m"]
    if geodetic:
        rows += [f"{a},{b:.10f},{c:.10f},{d:.4f}" for a, b, c, d in zip(t, lat, lon, h)]
    else:
        x, y, z = pymap3d.geodetic2ecef(lat, lon, h)
        rows += [f"{a},{b:.4f},{c:.4f},{d:.4f}" for a, b, c, d in zip(t, x, y, z)]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("geodetic", [False, True])
def test_tabulated_trajectory_interpolates_position_and_velocity(tmp_path, geodetic):
    from gnssframework.simulation.trajectory import load_trajectory

    traj = load_trajectory(_circle_csv(tmp_path / "traj.csv", geodetic))
    pos, vel = traj.state(np.array([3.25, 7.1]))
    assert np.allclose(np.linalg.norm(vel, axis=-1), 10.0, rtol=0.01)  # 0.2 rad/s x 50 m
    p0, _ = traj.state(np.array([0.0]))
    assert abs(np.linalg.norm(pos[0] - p0[0]) - 2 * 50 * np.sin(0.2 * 3.25 / 2)) < 0.05  # chord length


def test_trajectory_errors_name_the_file_and_line(tmp_path):
    from gnssframework.simulation.trajectory import load_trajectory

    f = tmp_path / "t.csv"
    f.write_text("t_s,x_m,y_m,z_m\n0,1,2,3\n1,1,2,oops\n")
    with pytest.raises(gf.DataFileError, match="t.csv:3: bad row"):
        load_trajectory(f)
    f.write_text("t_s,x_m,y_m,z_m\n0,1,2,3\n0,1,2,3\n")
    with pytest.raises(gf.DataFileError, match="t.csv:3: time 0.0 does not increase"):
        load_trajectory(f)


def test_vector_loop_tracks_a_moving_receiver(tmp_path):
    from gnssframework.experiments import get_scenario

    scen = get_scenario(
        {
            "kind": "vector-tracking",
            "duration_s": 3.0,
            "channels": 8,
            "settle_s": 0.5,
            "trajectory_file": str(_circle_csv(tmp_path / "traj.csv")),
        }
    )
    plugins = scen.build(
        {
            "channel_filter": {"name": "discriminator", "params": {}},
            "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 10.0}},
        }
    )
    m = scen.run_batch({"cn0_dbhz": 45.0}, plugins, 2, np.random.default_rng(0)).metrics
    assert np.all(m["position_error_rmse"] < 3.0) and np.all(m["velocity_error_rmse"] < 0.5)
