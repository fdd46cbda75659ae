"""IMU scale-factor and misalignment states: the strapdown INS's augmented error model against
its own nonlinear mechanisation, and the compensation a correction sets."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.inertial import ImuGrade, NavState, TrajectoryModel, paper_profile
from gnssframework.inertial.calibration import (
    CALIBRATION_STATE_LABELS,
    calibration_prior_std,
    compensate_calibration,
)
from gnssframework.inertial.error_model import navigation_error
from gnssframework.receiver.deep.strapdown import StrapdownIns

DT_S = 0.005
K0, STEPS = 1600, 3000  # 8-23 s of the paper's flight: the boost and the 30 g pull-up


@pytest.fixture(scope="module")
def pull_up():
    model = TrajectoryModel(paper_profile())
    truth = model.evaluate(DT_S * np.arange(K0, K0 + STEPS + 1))
    dth, dv = model.increments(DT_S, STEPS, start_s=K0 * DT_S)
    rng = np.random.default_rng(42)
    runs = 4
    # scale factors of 1000 ppm on the diagonals, 1 mrad cross-couplings off them
    std = calibration_prior_std(1000.0, 1000.0, 1.0, 1.0)
    m = rng.normal(size=(runs, 18)) * std
    return truth, dth, dv, m


def _ins(truth, dth, dv, m, calibration=True) -> StrapdownIns:
    """The INS from the true start on increments measured through I + M (no other error)."""
    runs = m.shape[0]
    Mg, Ma = m[:, :9].reshape(runs, 3, 3), m[:, 9:].reshape(runs, 3, 3)
    mth = dth[:, None] + np.einsum("rij,kj->kri", Mg, dth)
    mdv = dv[:, None] + np.einsum("rij,kj->kri", Ma, dv)
    return StrapdownIns(truth.nav_state(0).broadcast((runs,)), mth, mdv, DT_S, ImuGrade.perfect(), calibration)


def _error(ins: StrapdownIns, truth) -> np.ndarray:
    s = ins.state
    return navigation_error(NavState(s.q_b_e, s.velocity_ecef_mps, s.position_ecef_m), truth.nav_state(STEPS))


def test_augmented_transition_predicts_the_mechanised_error(pull_up):
    """Through the boost and the pull-up the INS error that scale factors and misalignments
    cause (the error minus that of the same INS on exact increments: the mechanisation's own
    truncation cancels) is the calibration block of the accumulated transition times the
    calibration states, to 1 % of its size; with the coupling's sign flipped it is not."""
    truth, dth, dv, m = pull_up
    ins = _ins(truth, dth, dv, m)
    exact = _ins(truth, dth, dv, np.zeros_like(m))
    t_end = STEPS * DT_S
    ins.advance(t_end)
    exact.advance(t_end)
    caused = _error(ins, truth) - _error(exact, truth)
    Phi, Qd = ins.take_error_model()
    assert Phi.shape == (4, 33, 33) and Qd.shape == (4, 33, 33)
    np.testing.assert_array_equal(Phi[:, 15:, 15:], np.broadcast_to(np.eye(18), (4, 18, 18)))
    np.testing.assert_array_equal(Phi[:, 15:, :15], 0.0)
    predicted = np.einsum("rij,rj->ri", Phi[:, :9, 15:], m)
    for block in (slice(0, 3), slice(3, 6), slice(6, 9)):
        size = np.abs(caused[:, block]).max()
        assert size > 0
        assert np.abs(caused[:, block] - predicted[:, block]).max() < 0.01 * size, block
    flipped = np.einsum("rij,rj->ri", Phi[:, :9, 15:], -m)
    assert np.abs(caused[:, 3:6] - flipped[:, 3:6]).max() > 1.0 * np.abs(caused[:, 3:6]).max()
    # the scale factors alone and the misalignments alone each matter in the pull-up
    diag = np.array([label[-2] == label[-1] for label in CALIBRATION_STATE_LABELS])
    for part in (diag, ~diag):
        alone = np.einsum("rij,rj->ri", Phi[:, 3:6, 15:], np.where(part, m, 0.0))
        assert np.abs(alone).max() > 0.05 * np.abs(caused[:, 3:6]).max()


def test_a_correction_compensates_the_increments(pull_up):
    """Corrected with the true M at the start, the INS on measured increments runs as the INS
    on exact ones (to the second order of M, 1e-6 relative)."""
    truth, dth, dv, m = pull_up
    ins = _ins(truth, dth, dv, m)
    exact = _ins(truth, dth, dv, np.zeros_like(m))
    ins.correct(np.concatenate([np.zeros((4, 15)), m], axis=-1))
    np.testing.assert_allclose(ins.gyro_cal.reshape(4, 9), m[:, :9])
    t_end = STEPS * DT_S
    ins.advance(t_end)
    exact.advance(t_end)
    left = _error(ins, truth) - _error(exact, truth)
    uncorrected = _ins(truth, dth, dv, m)
    uncorrected.advance(t_end)
    caused = _error(uncorrected, truth) - _error(exact, truth)
    assert np.abs(left[:, 6:9]).max() < 1e-3 * np.abs(caused[:, 6:9]).max()


def test_compensation_inverts_the_measurement_model():
    rng = np.random.default_rng(3)
    M = rng.normal(size=(5, 3, 3)) * 1e-3
    u = rng.normal(size=(5, 3))
    measured = u + np.einsum("rij,rj->ri", M, u)
    np.testing.assert_allclose(compensate_calibration(measured, M), u, rtol=1e-12, atol=1e-15)


def test_prior_puts_scale_factors_on_the_diagonals():
    std = calibration_prior_std(300.0, 100.0, 0.5, 2.0)
    labels = dict(zip(CALIBRATION_STATE_LABELS, std))
    assert labels["mg_xx"] == pytest.approx(3e-4) and labels["ma_zz"] == pytest.approx(1e-4)
    assert labels["mg_xy"] == pytest.approx(5e-4) and labels["ma_zx"] == pytest.approx(2e-3)


def test_a_correction_of_the_wrong_size_is_refused(pull_up):
    truth, dth, dv, m = pull_up
    ins = _ins(truth, dth, dv, m)
    with pytest.raises(ConfigError, match="33 error states, got 15"):
        ins.correct(np.zeros((4, 15)))
    plain = _ins(truth, dth, dv, m, calibration=False)
    assert plain.error_states == 15 and len(plain.take_error_model()) == 2
    with pytest.raises(ConfigError, match="15 error states, got 33"):
        plain.correct(np.zeros((4, 33)))
