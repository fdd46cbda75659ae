"""Protection levels and integrity outcomes as comparison metrics (issue 43).

- `integrity_outcome` on a hand-built series covering every region of the Stanford-ESA
  diagram, whose MI, HMI and availability counts are written down by hand;
- Gaussian errors against the covariance protection levels at a stated integrity risk
  ``I``: the vertical PL ``Q^-1(I/2) σ_U`` is exceeded with probability exactly ``I``,
  the horizontal PL of a circular error ``sqrt(-2 ln I) σ`` too (the Rayleigh tail), so
  the misleading fraction must fall inside the binomial interval of ``I``;
- a short vector-tracking run with a 60 m code step on one channel: the fault-free PLs
  (a few metres) are exceeded at most epochs after the step without the channel monitor
  and at none with it; the PLs scale with the integrity risk as the two formulas say;
- on the same runs, the nav filter's innovation (NIS) test alarms at the step, keeps
  alarming without the monitor and stops once the monitor has left the channel out.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom, norm

from gnssframework import random_streams as draw
from gnssframework.errors import ConfigError
from gnssframework.experiments import get_scenario
from gnssframework.experiments.metric_components import IntegrityOutcome, integrity_outcome
from gnssframework.experiments.metrics import check_metric
from gnssframework.navigation.integrity import covariance_protection_levels

CONF = 1e-4  # probability of a correct implementation failing one interval check

#: One epoch per region of the Stanford-ESA diagram at an alert limit of 10 m, and what
#: each region is (by the definitions: MI |e| > PL; HMI PL < AL < |e|; available PL < AL).
REGIONS = [  # (error, PL, MI, HMI, available)
    (1.0, 5.0, 0, 0, 1),  # nominal: e < PL < AL
    (7.0, 5.0, 1, 0, 1),  # MI: PL < e < AL
    (12.0, 5.0, 1, 1, 1),  # HMI: PL < AL < e
    (4.0, 15.0, 0, 0, 0),  # unavailable: e < AL < PL
    (12.0, 15.0, 0, 0, 0),  # unavailable: AL < e < PL
    (20.0, 15.0, 1, 0, 0),  # MI while unavailable: AL < PL < e (not HMI: the system said so)
    (-12.0, 5.0, 1, 1, 1),  # a signed error counts by its magnitude
    (3.0, np.nan, 0, 0, 0),  # no PL: neither available nor MI
]


def test_outcomes_of_every_region_of_the_integrity_diagram():
    err, pl, mi, hmi, avail = (np.array(c, float) for c in zip(*REGIONS))
    for outcome, expected in (("misleading", mi), ("hazardous", hmi), ("available", avail)):
        np.testing.assert_array_equal(integrity_outcome(err, pl, 10.0, outcome), expected.astype(bool))


def test_the_metric_is_the_fraction_of_settled_epochs_per_run():
    err, pl, mi, hmi, avail = (np.array(c, float) for c in zip(*REGIONS))
    # Two runs: the regions in order and reversed; the first two epochs before settling (t < 2 s).
    series = {"e": np.stack([err, err[::-1]], 1), "pl": np.stack([pl, pl[::-1]], 1)}
    time_s = np.arange(len(err), dtype=float)
    for outcome, flags in (("misleading", mi), ("hazardous", hmi), ("available", avail)):
        m = IntegrityOutcome(outcome, of="e", level="pl", outcome=outcome, alert_limit=10.0, settle=2.0)
        value = m.compute(series, time_s, None)
        # Hand counts: epochs 2..7 of each run's order.
        np.testing.assert_allclose(value.value, [flags[2:].mean(), flags[::-1][2:].mean()])
        np.testing.assert_array_equal(value.series[:, 0], flags)


@pytest.mark.parametrize("risk", [0.01, 0.1])
def test_gaussian_errors_exceed_the_covariance_levels_at_the_stated_risk(risk):
    rng = np.random.default_rng(4301)
    K, runs = 4000, 10  # 40 000 epochs
    # Vertical: any covariance; horizontal: circular (where the HPL bound is an equality).
    sigma_h, sigma_u = 1.7, 3.1
    C = np.diag([sigma_h**2, sigma_h**2, sigma_u**2])
    C[0, 2] = C[2, 0] = C[1, 2] = C[2, 1] = 0.5
    hpl, vpl = covariance_protection_levels(np.broadcast_to(C, (K, runs, 3, 3)), risk)
    e = rng.standard_normal((K, runs, 3)) @ np.linalg.cholesky(C).T
    series = {"h": np.hypot(e[..., 0], e[..., 1]), "v": e[..., 2], "hpl": hpl, "vpl": vpl}
    n = K * runs
    lo, hi = (x / n for x in binom.interval(1 - CONF, n, risk))
    for of, level in (("h", "hpl"), ("v", "vpl")):
        m = IntegrityOutcome("mi", of=of, level=level, outcome="misleading", alert_limit=1e9)
        rate = m.compute(series, None, None).value.mean()
        assert lo <= rate <= hi, (of, rate, risk, lo, hi)


def test_the_vector_scenario_declares_the_integrity_metrics_and_its_limits():
    scen = get_scenario({"kind": "vector-tracking", "duration_s": 3.0})
    for name in (
        "hpl_mean",
        "vpl_mean",
        "horizontal_misleading_fraction",
        "vertical_hazardous_fraction",
        "horizontal_available_fraction",
    ):
        assert check_metric(name, scen, "metrics[0]") in ("m", "-")
    with pytest.raises(ConfigError, match="metrics\\[0\\]: unknown 'hpl_max'"):
        check_metric("hpl_max", scen, "metrics[0]")
    with pytest.raises(Exception, match="integrity_risk"):
        get_scenario({"kind": "vector-tracking", "integrity_risk": 1.5})


@pytest.fixture(scope="module")
def step_runs():
    base = {
        "kind": "vector-tracking",
        "duration_s": 3.0,
        "channels": 8,
        "settle_s": 0.5,
        "steady_state_s": 2.0,
        "pcrb": False,
        "innovation_false_alarm": 1e-3,
    }
    case = {"cn0_dbhz": 45.0, "fault_channel": 0, "fault_start_s": 1.0, "fault_step_m": 60.0}
    components = {
        "channel_filter": {"name": "discriminator", "params": {"code_discriminator": "eml-envelope"}},
        "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo", "accel_psd": 1e-5}},
    }
    out = {}
    for name, risk, options in (
        ("none", 1e-7, None),
        ("monitor", 1e-7, {"channel_monitor": {"false_alarm": 1e-3, "consecutive": 3}}),
        ("monitor-1e-3", 1e-3, {"channel_monitor": {"false_alarm": 1e-3, "consecutive": 3}}),
    ):
        scen = get_scenario({**base, "integrity_risk": risk})
        scen.check_case(case, "cases[0]")
        out[name] = scen.run_batch(case, scen.build(components, options), 2, draw.run_streams(43, (0,), range(2)))
    return out


def test_a_fault_the_monitor_misses_is_misleading_and_one_it_excludes_is_not(step_runs):
    none, monitor = step_runs["none"], step_runs["monitor"]
    for r in (none, monitor):  # east-north-up is a rotation of the ECEF error
        np.testing.assert_allclose(
            np.hypot(r.series["horizontal_error_m"], r.series["vertical_error_m"]),
            r.series["position_error_m"],
            rtol=1e-12,
            atol=1e-9,
        )
        assert np.all(r.metrics["hpl_mean"] < 10.0) and np.all(r.metrics["vpl_mean"] < 15.0)  # not vacuous
        np.testing.assert_array_equal(r.metrics["horizontal_available_fraction"], 1.0)
    # The step pulls the unmonitored solution by ~30 m from about 1 s on: with a fault-free
    # PL of a few metres, at least a third of the window from 0.5 s is misleading (the pull
    # builds over the filter's time constant), in both axes' union; never with the monitor.
    mi = np.maximum(none.metrics["horizontal_misleading_fraction"], none.metrics["vertical_misleading_fraction"])
    assert np.all(mi > 1 / 3)
    for axis in ("horizontal", "vertical"):
        np.testing.assert_array_equal(monitor.metrics[f"{axis}_misleading_fraction"], 0.0)
        np.testing.assert_array_equal(monitor.metrics[f"{axis}_hazardous_fraction"], 0.0)


def test_the_nav_filters_innovation_test_alarms_at_the_step_and_stops_once_it_is_excluded(step_runs):
    # The nav filter's NIS test (innovation_false_alarm 1e-3): a 60 m step on a code of a few
    # metres' sigma is far past the 16-row test's threshold at the first interval after it.
    none, monitor = step_runs["none"], step_runs["monitor"]
    K = none.series["innovation_alarm"].shape[0]
    onset = K // 3  # fault_start_s 1.0 of a 3 s run: the first interval after the step
    for r in (none, monitor):
        alarm = r.series["innovation_alarm"]
        np.testing.assert_array_equal(alarm[onset], 1.0)
        assert alarm[:onset].mean() < 0.05  # fault-free: rare (no alarm in these runs)
        assert np.all(np.isfinite(r.series["nav_nis_per_dof"]))
    # Unmonitored, the step stays in the update and keeps the test alarming; once the monitor
    # leaves the channel out (three intervals), the remaining 14 rows pass again (at 1e-3 a
    # fault-free interval alarms rarely: 0.05 is 50 times that).
    assert np.all(none.metrics["innovation_alarm_fraction"] > 0.5)
    assert np.all(monitor.metrics["innovation_alarm_fraction"] < 0.05)


def test_the_levels_scale_with_the_integrity_risk_as_their_formulas_say(step_runs):
    # Same runs, same covariances: HPL ∝ sqrt(-2 ln I), VPL ∝ Q^-1(I/2).
    a, b = step_runs["monitor"].series, step_runs["monitor-1e-3"].series
    np.testing.assert_allclose(b["hpl_m"] / a["hpl_m"], np.sqrt(np.log(1e-3) / np.log(1e-7)), rtol=1e-9)
    np.testing.assert_allclose(b["vpl_m"] / a["vpl_m"], norm.isf(5e-4) / norm.isf(5e-8), rtol=1e-9)


# --- receive --tracking vector --raim: the vector rows' protection levels ---------------------


def test_vector_rows_carry_the_covariance_levels_and_the_monitor_verdict():
    import pymap3d

    from gnssframework.receiver.navigation.fixes import INTEGRITY_COLUMNS, POSITION_COLUMNS
    from gnssframework.receiver.navigation.receive import concatenate_tables
    from gnssframework.receiver.navigation.vector_solution import VectorSolution

    lat, lon, h = 45.5, -73.6, 50.0
    r = np.array(pymap3d.geodetic2ecef(lat, lon, h))
    # East, north, up unit vectors in ECEF (pymap3d, not the module's rotation), as columns.
    enu_to_ecef = np.stack(pymap3d.enu2uvw(*np.eye(3), lat, lon), axis=0)
    C_enu = [
        np.array([[4.0, 1.0, 0.3], [1.0, 2.0, -0.2], [0.3, -0.2, 9.0]]),
        np.diag([1.0, 1.0, 4.0]),
        np.diag([0.25, 1.0, 1.0]),
    ]
    sol = VectorSolution(prns=(3, 7, 9), handover_s=10.0, week=2300)
    for i, C in enumerate(C_enu):
        P = np.eye(8)
        P[:3, :3] = enu_to_ecef @ C @ enu_to_ecef.T
        sol.sample_time_s.append(10.0 + i)
        sol.state.append(np.concatenate([r, np.zeros(5)]))
        sol.cov.append(P)
        sol.used.append(np.isin(sol.slot_prns, (3, 7, 9)))
        sol.used_sat_pos_m.append(np.zeros((0, 3)))
        sol.monitor_excluded.append(np.isin(sol.slot_prns, (7, 9) if i == 1 else ()))
    risk = 1e-5
    table = sol.table(1.0, integrity_risk=risk)
    for i, C in enumerate(C_enu):
        lam_max = np.linalg.eigvalsh(C[:2, :2])[-1]
        assert table.columns["hpl_m"][i] == pytest.approx(np.sqrt(-2 * np.log(risk) * lam_max), rel=1e-9)
        assert table.columns["vpl_m"][i] == pytest.approx(norm.isf(risk / 2) * np.sqrt(C[2, 2]), rel=1e-9)
    assert list(table.columns["raim"]) == ["ok", "excluded", "ok"]
    assert list(table.excluded_prn) == [0, 7, 0]
    assert set(INTEGRITY_COLUMNS) <= set(table.columns) and "hpl_m" not in sol.table(1.0).columns
    # After scalar rows without levels (no --raim there), those rows say unavailable.
    before = sol.table(1.0)
    shifted = type(before)(
        before.columns, before.ecef_m, before.sample_time_s - 5.0, before.used_prns, before.excluded_prn
    )
    joined = concatenate_tables(shifted, table, 10.0)
    assert set(POSITION_COLUMNS + INTEGRITY_COLUMNS) <= set(joined.columns)
    assert list(joined.columns["raim"]) == ["unavailable"] * 3 + ["ok", "excluded", "ok"]
    assert np.all(np.isinf(joined.columns["hpl_m"][:3])) and np.all(np.isfinite(joined.columns["hpl_m"][3:]))


def test_the_loop_rotation_to_east_north_up_is_pymap3ds():
    import pymap3d

    from gnssframework.receiver.tracking.vector import enu_rotation

    rng = np.random.default_rng(7)
    lat, lon, h = rng.uniform(-89, 89, 6), rng.uniform(-180, 180, 6), rng.uniform(-100, 9000, 6)
    r = np.stack(pymap3d.geodetic2ecef(lat, lon, h), axis=-1)
    d = rng.standard_normal((6, 3))
    expected = np.stack(pymap3d.ecef2enuv(d[:, 0], d[:, 1], d[:, 2], lat, lon), axis=-1)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", enu_rotation(r), d), expected, atol=1e-12)
