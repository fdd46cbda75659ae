"""Reference 002's error sources a reviewer expects: oscillator g-sensitivity in the truth's
clock, IMU cross-axis misalignment; each against its closed form."""

import numpy as np
import pytest

from gnssframework import random_streams as draw
from gnssframework.experiments import get_scenario

G0_M_S2, C_M_S, F_L1_HZ = 9.80665, 299_792_458.0, 1575.42e6
PULSE = {
    "profile": "jerk-pulse",
    "duration_s": 5.0,
    "settle_s": 1.0,
    "pulse_accel_g": 30.0,
    "pulse_jerk_g_s": 50.0,
    "pulse_start_s": 1.0,
    "pulse_hold_s": 1.5,
    "pulse_direction_enu": (0.0, 0.0, 1.0),
}


def _scen(**params):
    return get_scenario({"kind": "deep-integration", **PULSE, **params})


def test_g_sensitivity_gives_the_closed_form_common_doppler_at_30_g():
    # 1e-9/g along the specific force at 30 g of upward acceleration: the oscillator's
    # fractional frequency error is 1e-9 |f| / g0 with |f| = 30 g0 + local gravity
    # (9.797 m/s^2 at 34.2 deg, 590 m), i.e. 47.3 Hz (30 g) + 1.6 Hz (gravity) at L1.
    # Coriolis and transport terms change |f| by < 2e-4 of it.
    base = _scen()
    flight = base.flight()
    t_hold = 1.0 + 1.875 * 30.0 / 50.0 + 0.75  # middle of the hold
    f_b = flight.truth(np.array([t_hold])).specific_force_b_mps2[0]
    gamma = 1e-9 * f_b / np.linalg.norm(f_b)
    scen = _scen(oscillator_g_sensitivity_per_g=tuple(gamma))
    truth0 = base._truth(flight, 45.0, 2, draw.run_streams(7, (), range(2)))
    truth = scen._truth(flight, 45.0, 2, draw.run_streams(7, (), range(2)))
    d_clock = truth.clock_m - truth0.clock_m  # the oscillator noise is the same draw
    k = int(round(t_hold / base.params.coherent_time_s))
    doppler_hz = d_clock[k, :, 1] / (C_M_S / F_L1_HZ)
    expected = F_L1_HZ * 1e-9 * (30.0 * G0_M_S2 + 9.797) / G0_M_S2
    assert expected == pytest.approx(48.8, abs=0.1) and F_L1_HZ * 30e-9 == pytest.approx(47.26, abs=0.01)
    np.testing.assert_allclose(doppler_hz, expected, rtol=5e-4)
    # The bias is the drift's integral: Gamma . (velocity increment in body axes) / g0, from
    # the trajectory's exact (Gauss-Legendre) IMU increments, an independent integration.
    _, dv = flight.model.increments(0.005, 1000)
    np.testing.assert_allclose(d_clock[-1, :, 0], C_M_S * (dv.sum(axis=0) @ gamma) / G0_M_S2, rtol=1e-5)


def test_no_g_sensitivity_by_default():
    scen = _scen()
    assert scen.g_sensitivity_frequency_error(scen.flight(), np.array([2.0])) is None


# --- IMU cross-axis misalignment -----------------------------------------------------------

from gnssframework.inertial.imu import ImuGrade, simulate_imu  # noqa: E402

MISALIGNED = ImuGrade.perfect().model_copy(update={"gyro_misalignment_mrad": 1.0, "accel_misalignment_mrad": 0.5})


def test_misaligned_triad_measures_a_known_rotation_as_the_closed_form():
    # A rotation of theta about body x (and a specific force along z): a triad with
    # cross-coupling M measures (I + M) times it, i.e. theta (1, M_yx, M_zx) and
    # f (M_xz, M_yz, 1) (Groves 2nd ed. eq. 4.18 with no scale-factor error).
    theta, f = 0.02, 9.8 * 0.005
    dth_true = np.tile([[theta, 0.0, 0.0]], (4, 1))
    dv_true = np.tile([[0.0, 0.0, f]], (4, 1))
    dth, dv, e = simulate_imu(dth_true, dv_true, 0.005, MISALIGNED, draw.run_streams(3, (), range(5)), (5,))
    m, a = e.gyro_misalignment, e.accel_misalignment
    np.testing.assert_allclose(dth[2], theta * np.stack([np.ones(5), m[:, 1, 0], m[:, 2, 0]], -1), rtol=1e-12)
    np.testing.assert_allclose(dv[2], f * np.stack([a[:, 0, 2], a[:, 1, 2], np.ones(5)], -1), rtol=1e-12)
    assert np.all(np.abs(dth[2, :, 1:]) > 0)  # the coupling is there


def test_misalignment_elements_have_the_grades_deviation_and_a_zero_diagonal():
    runs = 4000
    _, _, e = simulate_imu(np.zeros((2, 3)), np.zeros((2, 3)), 0.005, MISALIGNED, np.random.default_rng(1), (runs,))
    off = ~np.eye(3, dtype=bool)
    assert np.all(e.gyro_misalignment[:, ~off] == 0)
    g = e.gyro_misalignment[:, off]  # 6 independent N(0, 1 mrad^2) per run
    assert abs(g.std() / 1e-3 - 1) < 4 / np.sqrt(2 * g.size)
    assert abs(g.mean()) < 4 * 1e-3 / np.sqrt(g.size)
    assert abs(e.accel_misalignment[:, off].std() / 0.5e-3 - 1) < 4 / np.sqrt(2 * g.size)
    assert abs(np.corrcoef(g[:, 0], g[:, 1])[0, 1]) < 4 / np.sqrt(runs)


def test_misalignment_is_drawn_per_run_and_leaves_the_other_errors_unchanged():
    dth_true = np.tile([[0.01, -0.02, 0.03]], (3, 1))
    dv_true = np.tile([[0.05, 0.0, -0.04]], (3, 1))
    grade = ImuGrade()  # Cai and Guo's biases and noise
    tilted = grade.model_copy(update={"gyro_misalignment_mrad": 2.0, "accel_misalignment_mrad": 2.0})
    three = simulate_imu(dth_true, dv_true, 0.005, tilted, draw.run_streams(9, (), range(3)), (3,))
    one = simulate_imu(dth_true, dv_true, 0.005, tilted, draw.run_streams(9, (), [1]), (1,))
    np.testing.assert_allclose(three[2].gyro_misalignment[1], one[2].gyro_misalignment[0], rtol=0, atol=0)
    np.testing.assert_allclose(three[0][:, 1], one[0][:, 0], rtol=1e-12, atol=1e-18)
    # Off: nothing drawn, no matrix, every other error the same draw as with it on.
    plain = simulate_imu(dth_true, dv_true, 0.005, grade, draw.run_streams(9, (), range(3)), (3,))
    assert plain[2].gyro_misalignment is None
    np.testing.assert_allclose(
        three[0] - plain[0], np.einsum("rij,tj->tri", three[2].gyro_misalignment, dth_true), rtol=1e-9, atol=1e-18
    )


def test_deep_scenario_takes_the_misalignment_in_its_imu_grade():
    scen = _scen(imu={"gyro_misalignment_mrad": 1.0, "accel_misalignment_mrad": 0.3})
    assert scen.params.imu.gyro_misalignment_mrad == 1.0
    with pytest.raises(Exception, match="gyro_misalignment_mrad"):
        _scen(imu={"gyro_misalignment_mrad": -1.0})


def test_misalignment_switched_on_shifts_no_later_draw_of_the_run():
    # From its own child stream: the run's next draws are the same with it on or off, so a
    # case with misalignment and one without share their correlator noise (common random numbers).
    dth_true, dv_true = np.zeros((3, 3)), np.zeros((3, 3))
    tilted = ImuGrade(gyro_misalignment_mrad=1.0, accel_misalignment_mrad=1.0)
    after = []
    for grade in (ImuGrade(), tilted):
        rng = draw.run_streams(9, (), range(3))
        simulate_imu(dth_true, dv_true, 0.005, grade, rng, (3,))
        after.append(draw.standard_normal(rng, (3, 4), 0))
    np.testing.assert_array_equal(after[0], after[1])


def test_a_case_adds_the_error_sources_to_the_scenarios_truth():
    from gnssframework.experiments.scenarios.deep_integration import DeepIntegrationCase

    base = _scen()
    case = DeepIntegrationCase.model_validate(
        {
            "name": "e",
            "cn0_dbhz": 45.0,
            "gyro_misalignment_mrad": 1.0,
            "oscillator_g_sensitivity_per_g": (0.0, 0.0, 1e-9),
        }
    )
    update = case.scenario_update(base.params)
    assert update["oscillator_g_sensitivity_per_g"] == (0.0, 0.0, 1e-9)
    imu = update["imu"]  # the scenario's grade with the case's misalignment, every other level kept
    assert imu.gyro_misalignment_mrad == 1.0 and imu.accel_misalignment_mrad == base.params.imu.accel_misalignment_mrad
    assert imu.model_dump(exclude={"gyro_misalignment_mrad"}) == base.params.imu.model_dump(
        exclude={"gyro_misalignment_mrad"}
    )
    assert DeepIntegrationCase.model_validate({"cn0_dbhz": 45.0}).scenario_update(base.params) == {}
    # The case's g-sensitivity gives the same truth as the scenario parameter.
    flight = base.flight()
    by_case = type(base)(base.params.model_copy(update=update))._truth(
        flight, 45.0, 2, draw.run_streams(7, (), range(2))
    )
    by_scen = _scen(oscillator_g_sensitivity_per_g=(0.0, 0.0, 1e-9))._truth(
        flight, 45.0, 2, draw.run_streams(7, (), range(2))
    )
    np.testing.assert_array_equal(by_case.clock_m, by_scen.clock_m)
    with pytest.raises(Exception, match="gyro_misalignment_mrad"):
        DeepIntegrationCase.model_validate({"cn0_dbhz": 45.0, "gyro_misalignment_mrad": -1.0})


def test_a_gnss_only_candidate_has_no_imu_to_misalign_but_its_clock_sees_the_oscillator():
    # examples/deep_integration_error_sources.toml claims vector-pva's misalignment case is its
    # nominal case (ratio 1): a GNSS-only navigator reads no IMU, so the case changes nothing,
    # bit for bit, on the same streams. The control: the g-sensitivity case on the same streams
    # changes its numbers (the oscillator's 1 g of gravity alone is 1.6 Hz of common Doppler).
    import gnssframework as gf

    scen = _scen(duration_s=0.6, settle_s=0.2)
    cases = {
        "nominal": {"cn0_dbhz": 45.0},
        "misalignment": {"cn0_dbhz": 45.0, "gyro_misalignment_mrad": 1.0, "accel_misalignment_mrad": 1.0},
        "g-sensitivity": {"cn0_dbhz": 45.0, "oscillator_g_sensitivity_per_g": (0.0, 0.0, 1e-9)},
    }
    res = {}
    for name, case in cases.items():
        plugins = {
            "channel_filter": gf.registry.create("channel_filter", "iq-filter", output="equivalent"),
            "nav_filter": gf.registry.create("nav_filter", "ekf-pva", clock="ocxo"),
        }
        res[name] = scen.run_batch(case, plugins, 2, draw.run_streams(4, (0,), range(2))).metrics
    for metric in ("horizontal_position_error_rmse", "vertical_velocity_error_rmse", "freq_tracking_error_rmse"):
        np.testing.assert_array_equal(res["misalignment"][metric], res["nominal"][metric])
    assert np.all(res["g-sensitivity"]["freq_tracking_error_rmse"] != res["nominal"]["freq_tracking_error_rmse"])


# --- the IMU error model the INS filter assumes (filter_imu) -------------------------------


def test_filter_imu_changes_what_the_filter_assumes_and_not_the_measured_increments():
    from gnssframework.experiments.scenarios.deep_integration_runs import _setup_ins

    truth_grade = ImuGrade().model_copy(update={"accel_bias_mg": 2.0, "gyro_scale_factor_ppm": 300.0})
    datasheet = ImuGrade().model_copy(update={"accel_bias_mg": 0.5, "gyro_bias_deg_per_h": 1.0})
    handed = _scen(imu=truth_grade.model_dump())
    assumed = _scen(imu=truth_grade.model_dump(), filter_imu=datasheet.model_dump())
    assert handed.params.filter_imu is None  # default: the filter is handed the truth's IMU
    ins_t, P0_t = _setup_ins(handed, handed.flight(), 3, draw.run_streams(11, (), range(3)))
    ins_a, P0_a = _setup_ins(assumed, assumed.flight(), 3, draw.run_streams(11, (), range(3)))
    # the truth (increments with the truth's biases, scale factor and noise) and the initial errors are the same draw
    np.testing.assert_array_equal(ins_a.dtheta, ins_t.dtheta)
    np.testing.assert_array_equal(ins_a.dv, ins_t.dv)
    np.testing.assert_array_equal(P0_a[:9, :9], P0_t[:9, :9])
    assert ins_t.grade == truth_grade and ins_a.grade == datasheet
    # the bias block: random constant and Gauss-Markov deviation of the assumed grade (1 deg/h = 4.848e-6 rad/s,
    # 1 mg = 9.80665e-3 m/s^2)
    np.testing.assert_allclose(np.diag(P0_a)[9:12], (4.8481368e-6**2 + (0.1 * 4.8481368e-6) ** 2), rtol=1e-6)
    np.testing.assert_allclose(np.diag(P0_a)[12:15], (0.5e-3 * 9.80665) ** 2 + (0.1e-3 * 9.80665) ** 2, rtol=1e-6)
    np.testing.assert_allclose(np.diag(P0_t)[12:15], (2.0e-3 * 9.80665) ** 2 + (0.1e-3 * 9.80665) ** 2, rtol=1e-6)


@pytest.mark.slow
def test_a_filter_assuming_a_far_better_imu_than_the_truth_is_overconfident():
    # The truth's biases 10 mg and 10 deg/h (100 times the defaults); one filter is handed them, the
    # other assumes 0.01 mg and 0.01 deg/h: it cannot move its bias estimates, so the bias goes into its
    # velocity while its covariance says otherwise. Its NEES is the larger on the same runs (common
    # random numbers): measured 2.3 times as large in geometric mean over 6 runs; asserted above 1.5.
    from gnssframework.registry import create

    truth_grade = ImuGrade().model_copy(update={"accel_bias_mg": 10.0, "gyro_bias_deg_per_h": 10.0})
    tiny = {"accel_bias_mg": 0.01, "accel_markov_sigma_mg": 0.01}
    datasheet = ImuGrade().model_copy(update={**tiny, "gyro_bias_deg_per_h": 0.01, "gyro_markov_sigma_deg_per_h": 0.01})
    nees = {}
    for name, extra in (("handed", {}), ("assumed", {"filter_imu": datasheet.model_dump()})):
        scen = get_scenario(
            {
                "kind": "deep-integration",
                "profile": "pull-up",
                "clock": "ocxo",
                "duration_s": 4.0,
                "settle_s": 1.0,
                "imu": truth_grade.model_dump(),
                **extra,
            }
        )
        plugins = {
            "channel_filter": create("channel_filter", "scalar", pll_bandwidth_hz=20.7, dll_bandwidth_hz=0.21),
            "nav_filter": create("nav_filter", "ins-ekf"),
        }
        res = scen.run_batch({"name": "c", "cn0_dbhz": 45.0}, plugins, 6, np.random.default_rng(5))
        nees[name] = np.asarray(res.metrics["nees"])
    assert np.all(np.isfinite(nees["assumed"])) and np.all(nees["handed"] > 0)
    assert np.exp(np.mean(np.log(nees["assumed"] / nees["handed"]))) > 1.5
