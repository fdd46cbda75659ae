"""The one receiver-satellite geometry (`navigation.geometry`) and the one NEES (`estimation.consistency`)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from gnssframework.estimation.consistency import nees
from gnssframework.navigation.ephemeris import OMEGA_EARTH_RAD_S
from gnssframework.navigation.geometry import (
    geometric_range,
    line_of_sight,
    range_acceleration,
    range_rate,
    ranges_from_receivers,
    sagnac_m,
)
from gnssframework.signal.constants import SPEED_OF_LIGHT_M_S

SAT = np.array([15_600e3, 7_540e3, 20_140e3])
SAT_VEL = np.array([-1_200.0, 2_900.0, 300.0])
RX = np.array([4_510e3, 1_090e3, 4_390e3])
RX_VEL = np.array([50.0, -20.0, 10.0])


def test_range_rate_is_the_derivative_of_the_range():
    _, e = line_of_sight(SAT, RX)
    h = 1e-3
    ahead = geometric_range(SAT + h * SAT_VEL, RX + h * RX_VEL)
    behind = geometric_range(SAT - h * SAT_VEL, RX - h * RX_VEL)
    assert range_rate(SAT_VEL, RX_VEL, e) == pytest.approx((ahead - behind) / (2 * h), abs=1e-5)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-3e7, 3e7), min_size=3, max_size=3), st.lists(st.floats(-7e6, 7e6), min_size=3, max_size=3))
def test_line_of_sight_is_a_unit_vector_that_rebuilds_the_satellite(sat, rx):
    sat, rx = np.array(sat), np.array(rx)
    assume(np.linalg.norm(sat - rx) > 1.0)  # coincident points have no direction
    rho, e = line_of_sight(sat, rx)
    assert np.linalg.norm(e) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(rx + rho * e, sat, atol=1e-6)


def test_range_acceleration_of_a_straight_pass_is_the_closed_form():
    # A satellite passing a receiver in a straight line at miss distance a and relative speed
    # u: rho(t) = sqrt(a^2 + u^2 t^2), so rho'' = a^2 u^2 / (a^2 + u^2 t^2)^(3/2). Both move
    # (only the relative motion counts); a batch of instants along the pass.
    a, u = 2.0e7, 3.9e3
    t = np.array([-600.0, -10.0, 0.0, 250.0, 3000.0])
    rx_vel = np.array([30.0, -12.0, 4.0])
    rx = RX + np.outer(t, rx_vel)
    sat_vel = rx_vel + np.array([0.0, u, 0.0])
    sat = RX + np.array([a, 0.0, 0.0]) + np.outer(t, sat_vel)
    rho, e = line_of_sight(sat, rx)
    got = range_acceleration(np.zeros(3), np.zeros(3), sat_vel, rx_vel, e, rho)
    np.testing.assert_allclose(got, a**2 * u**2 / (a**2 + u**2 * t**2) ** 1.5, rtol=1e-9)


@pytest.mark.parametrize("radius_m, speed_m_s", [(2.0e7, 3.9e3), (1.0e3, 250.0)])
def test_range_acceleration_of_a_circling_satellite_is_zero(radius_m, speed_m_s):
    # Uniform circular motion about the receiver keeps the range: the centripetal
    # acceleration -u^2/R along the line of sight cancels the turning term +u^2/R.
    angle = np.linspace(0.0, 2 * np.pi, 7)
    radial = np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], axis=-1)
    tangential = np.stack([-np.sin(angle), np.cos(angle), np.zeros_like(angle)], axis=-1)
    rho, e = line_of_sight(RX + radius_m * radial, RX)
    got = range_acceleration(
        -(speed_m_s**2) / radius_m * radial, np.zeros(3), speed_m_s * tangential, np.zeros(3), e, rho
    )
    np.testing.assert_allclose(got, 0.0, atol=1e-9 * speed_m_s**2 / radius_m)


def test_range_acceleration_along_the_line_of_sight_is_the_relative_acceleration():
    # Motion along the line of sight does not turn it: rho'' = e . (a_s - a_r).
    e_true = (SAT - RX) / np.linalg.norm(SAT - RX)
    rho, e = line_of_sight(SAT, RX)
    got = range_acceleration(0.7 * e_true, -0.2 * e_true, 900.0 * e_true, 15.0 * e_true, e, rho)
    assert got == pytest.approx(0.9, rel=1e-9)


def test_the_sagnac_term_is_the_earths_rotation_during_transit():
    # Independent form: rotate the satellite's ECEF position by -omega * tau about z (the frame
    # of reception has turned by omega * tau since transmission) and measure the range again.
    rho = geometric_range(SAT, RX)
    for _ in range(3):  # fixed point of the transit time tau = rho / c
        theta = -OMEGA_EARTH_RAD_S * rho / SPEED_OF_LIGHT_M_S
        c, s = np.cos(theta), np.sin(theta)
        rotated = np.array([c * SAT[0] - s * SAT[1], s * SAT[0] + c * SAT[1], SAT[2]])
        rho = geometric_range(rotated, RX)
    correction = sagnac_m(SAT, RX)
    assert abs(correction) > 1.0  # large enough that the comparison means something
    assert rho - geometric_range(SAT, RX) == pytest.approx(correction, abs=1e-3)


def test_shared_and_per_run_satellites_give_the_same_ranges():
    rng = np.random.default_rng(0)
    sats = SAT + rng.normal(0, 1e6, (4, 3))  # (ch, 3), shared by the runs
    receivers = RX + rng.normal(0, 100.0, (2, 5, 3))  # (K, runs, 3)
    shared = ranges_from_receivers(sats, receivers)
    per_run = ranges_from_receivers(np.broadcast_to(sats, (2, 5, 4, 3)), receivers)
    assert shared.shape == (2, 5, 4)
    np.testing.assert_array_equal(shared, per_run)
    assert shared[1, 3, 2] == geometric_range(sats[2], receivers[1, 3])


def test_nees_against_the_inverse_and_its_mean_for_a_consistent_error():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(3, 3))
    P = A @ A.T + 0.1 * np.eye(3)
    e = rng.normal(size=3)
    assert nees(e, P) == pytest.approx(e @ np.linalg.inv(P) @ e, rel=1e-12)
    draws = rng.multivariate_normal(np.zeros(3), P, size=20_000)
    values = nees(draws, np.broadcast_to(P, (20_000, 3, 3)))
    assert values.shape == (20_000,)
    assert np.mean(values) == pytest.approx(3.0, abs=4 * np.sqrt(2 * 3 / 20_000))  # chi-square(3): mean 3, var 6
