"""Reference 003's carrier loops declare their assumptions in common units (issue 22).

Every value is checked against a computation that does not use the plugin's code: the
discrete Riccati steady state of the Kalman loop and the noise bandwidth of the loop it
makes, the Kalman-Bucy closed form of a 2nd-order loop, Kaplan & Hegarty's 2nd-order PLL
design, the arctangent's thermal variance, and the unit conversions written out.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl

import gnssframework as gf
from gnssframework.experiments import get_scenario

DEG = np.pi / 180
LAMBDA_L1 = 299_792_458.0 / 1575.42e6  # m

#: The paper's three tunings (examples/scintillation.toml): Q diagonal and R, in deg.
TUNINGS = {"kf-1": ([0.01, 0.1], 10.0), "kf-2": ([0.01, 0.1], 5.0), "kf-3": ([0.01, 0.01], 5.0)}


def _steady_loop(q_rad: np.ndarray, r_rad: float, T: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Kalman loop at its steady gain as a linear loop ``s+ = A s + B u``, ``y = C s``.

    State s = (NCO phase at the interval's start, NCO frequency), input u the true
    mid-interval phase, output y the NCO's mid-interval phase. The prior covariance P
    solves the discrete Riccati equation P = F (P - P H' (H P H' + R)^-1 H P) F' + Q for
    F = [[1, T], [0, 1]], H = [1, T/2]; K = P H' / (H P H' + R). The NCO moves by the
    estimate propagated to the next start: phase + K0 z + T K1 z, frequency + K1 z.
    """
    F = np.array([[1.0, T], [0.0, 1.0]])
    H = np.array([[1.0, T / 2]])
    P = sl.solve_discrete_are(F.T, H.T, np.diag(q_rad), np.array([[r_rad]]))
    K = (P @ H.T / (H @ P @ H.T + r_rad)).ravel()
    B = np.array([K[0] + T * K[1], K[1]])
    return F - np.outer(B, H), B, H


def _noise_bandwidth_hz(q_rad: np.ndarray, r_rad: float, T: float) -> float:
    """One-sided noise bandwidth of the steady loop for white noise at the discriminator:
    B_L = sum h_n^2 / (2 T (sum h_n)^2), sum h_n^2 = C X C' with X the discrete Lyapunov
    solution X = A X A' + B B' (h_n = C A^(n-1) B)."""
    A, B, C = _steady_loop(q_rad, r_rad, T)
    X = sl.solve_discrete_lyapunov(A, np.outer(B, B))
    dc = (C @ np.linalg.solve(np.eye(2) - A, B)).item()
    return (C @ X @ C.T).item() / (2 * T * dc**2)


def _probe_bandwidth_hz(q_rad: np.ndarray, r_rad: float, T: float, n: int = 20000) -> float:
    """The same loop probed as `equivalent_bandwidth_hz` probes it: a phase step at an
    interval boundary whose mid-interval phase is the average of the boundary phases, so
    the response is h convolved with (1/2, 1/2)."""
    A, B, C = _steady_loop(q_rad, r_rad, T)
    h, s = [0.0], B.copy()
    for _ in range(n):
        h.append((C @ s).item())
        s = A @ s
    g = np.convolve(h, [0.5, 0.5])
    return float(np.sum(g**2) / (2 * T * np.sum(g) ** 2))


def _kalman_bucy_bandwidth_hz(q_rad: np.ndarray, r_rad: float, T: float) -> float:
    """Continuous closed form: white phase and frequency noise of densities q0/T and q1/T,
    white phase measurement noise of density r T. The steady gains are k2 = sqrt(q1'/r')
    and k1 = sqrt(q0'/r' + 2 sqrt(q1'/r')), a 2nd-order loop with wn^2 = k2 and
    2 zeta wn = k1, whose noise bandwidth is B_L = (wn/2)(zeta + 1/(4 zeta))."""
    qt, qw, rc = q_rad[0] / T, q_rad[1] / T, r_rad * T
    k2 = np.sqrt(qw / rc)
    k1 = np.sqrt(qt / rc + 2 * np.sqrt(qw / rc))
    wn = np.sqrt(k2)
    zeta = k1 / (2 * wn)
    return float(wn / 2 * (zeta + 1 / (4 * zeta)))


def _thermal_variance(cn0_dbhz: float, T: float) -> float:
    """Costas arctangent, rad^2 per interval: 1/(2 c T) (1 + 1/(2 c T)) (Kaplan & Hegarty)."""
    cT = 10 ** (cn0_dbhz / 10) * T
    return 1 / (2 * cT) * (1 + 1 / (2 * cT))


def _kf(q, r):
    return gf.registry.create("channel_filter", "kf-carrier-loop", q=q, r=r, angle_unit="deg", dll_bandwidth_hz=0.5)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TUNINGS))
@pytest.mark.parametrize("T", [0.01, 0.001])
def test_kalman_loop_bandwidth_is_its_riccati_steady_state_loops(name, T):
    q, r = TUNINGS[name]
    q_rad, r_rad = np.array(q) * DEG**2, r * DEG**2
    # The loop is declared at T = 10 ms; the 1 ms context re-creates it (same Q, R per interval).
    out = _kf(q, r).assumptions({"coherent_time_s": T, "cn0_dbhz": 45.0})
    b, unit = out["carrier loop noise bandwidth"]
    assert unit == "Hz"
    exact = _noise_bandwidth_hz(q_rad, r_rad, T)
    # The probe's step response sees the step's half-interval average: 1-2.5 % below the
    # noise bandwidth; that probe model reproduces the measurement to 0.5 %.
    assert b == pytest.approx(exact, rel=0.03) and b < exact
    assert b == pytest.approx(_probe_bandwidth_hz(q_rad, r_rad, T), rel=0.005)
    # And the continuous 2nd-order closed form, within the discretisation (B_L T <= 0.013).
    assert exact == pytest.approx(_kalman_bucy_bandwidth_hz(q_rad, r_rad, T), rel=0.03)


def test_the_unit_reading_sets_r_against_the_thermal_noise_not_the_bandwidth():
    # Read in rad the same numbers scale Q and R together by (180/pi)^2: the Riccati gain
    # K = P H' / (H P H' + R) is unchanged by a common scale, so the loop (and its bandwidth)
    # is the same, while R against the discriminator's thermal variance is (180/pi)^2 larger.
    q, r = TUNINGS["kf-1"]
    ctx = {"coherent_time_s": 0.01, "cn0_dbhz": 45.0}
    in_rad = gf.registry.create("channel_filter", "kf-carrier-loop", q=q, r=r, dll_bandwidth_hz=0.5).assumptions(ctx)
    in_deg = _kf(q, r).assumptions(ctx)
    assert in_deg["Q and R read in"][0] == "deg" and in_rad["Q and R read in"][0] == "rad"
    assert _noise_bandwidth_hz(np.array(q, float), r, 0.01) == pytest.approx(
        _noise_bandwidth_hz(np.array(q) * DEG**2, r * DEG**2, 0.01), rel=1e-9
    )
    assert in_rad["carrier loop noise bandwidth"][0] == pytest.approx(
        in_deg["carrier loop noise bandwidth"][0], rel=1e-6
    )
    assert in_deg["phase R / thermal variance"][0] == pytest.approx(r * DEG**2 / _thermal_variance(45.0, 0.01))
    assert in_rad["phase R / thermal variance"][0] == pytest.approx(in_deg["phase R / thermal variance"][0] / DEG**2)


def test_kalman_loop_q_r_psd_and_thermal_ratio_in_common_units():
    T, cn0 = 0.01, 35.0
    out = _kf([0.01, 0.1], 5.0).assumptions({"coherent_time_s": T, "cn0_dbhz": cn0})
    # 0.01 deg^2 = (0.1 deg)^2; 0.1 (deg/s)^2; 5 deg^2, each per interval.
    assert out["phase Q"] == (pytest.approx(np.radians(0.1) ** 2), "rad² per interval")
    assert out["frequency Q"] == (pytest.approx(np.radians(np.sqrt(0.1)) ** 2), "(rad/s)² per interval")
    assert out["phase R"] == (pytest.approx(np.radians(np.sqrt(5.0)) ** 2), "rad² per interval")
    # The frequency random walk as a line-of-sight acceleration a = (lambda / 2 pi) d(omega)/dt:
    # PSD = Q_f / T (lambda / 2 pi)^2.
    assert out["line-of-sight acceleration PSD"] == (
        pytest.approx(np.radians(np.sqrt(0.1)) ** 2 / T * (LAMBDA_L1 / (2 * np.pi)) ** 2),
        "m²/s³",
    )
    assert out["phase R / thermal variance"][0] == pytest.approx(
        np.radians(np.sqrt(5.0)) ** 2 / _thermal_variance(cn0, T)
    )


def test_pll_declares_order_and_a_bandwidth_of_its_design():
    # Kaplan & Hegarty's 2nd-order design: wn = B_L / 0.53, zeta = 0.707, so
    # B_L = (wn/2)(zeta + 1/(4 zeta)); at B_L T = 0.0018 the discrete loop is that bandwidth.
    pll = gf.registry.create(
        "channel_filter", "scalar", pll_bandwidth_hz=1.8, pll_order=2, fll_bandwidth_hz=0.0, dll_bandwidth_hz=0.5
    )
    out = pll.assumptions({"coherent_time_s": 0.001, "cn0_dbhz": 45.0})
    wn, zeta = 1.8 / 0.53, 1 / np.sqrt(2)
    assert out["carrier loop"][0] == "PLL, order 2"
    assert out["carrier loop design bandwidth"] == (1.8, "Hz")
    assert out["carrier loop noise bandwidth"][0] == pytest.approx(wn / 2 * (zeta + 1 / (4 * zeta)), rel=0.02)
    # At B_L T = 0.1 the discretised 10 Hz loop is wider than designed (the page's 12.5 Hz).
    wide = gf.registry.create(
        "channel_filter", "scalar", pll_bandwidth_hz=10.0, pll_order=2, fll_bandwidth_hz=0.0, dll_bandwidth_hz=0.5
    )
    assert wide.assumptions({"coherent_time_s": 0.01})["carrier loop noise bandwidth"][0] > 11.0
    # Without the scenario's T nothing is measured (a loop may run at another T there).
    assert "carrier loop noise bandwidth" not in wide.assumptions({})
    # A loop the probe cannot settle declares no number rather than failing the report.
    slow = gf.registry.create("channel_filter", "scalar", pll_bandwidth_hz=0.05, pll_order=2, fll_bandwidth_hz=0.0)
    assert slow.assumptions({"coherent_time_s": 0.01})["carrier loop noise bandwidth"][0].startswith("undefined")


def test_pll_acceleration_psd_makes_a_kalman_loop_of_the_pll_bandwidth():
    # The declared PSD is the white acceleration whose steady Kalman filter (with R the
    # thermal variance at the case's C/N0) is the PLL: a Kalman loop built from it, with no
    # phase noise, must come out at the PLL's bandwidth (measured independently of the PLL).
    T, cn0, B = 0.002, 40.0, 3.0
    pll = gf.registry.create("channel_filter", "scalar", pll_bandwidth_hz=B, pll_order=2, fll_bandwidth_hz=0.0)
    psd = pll.assumptions({"coherent_time_s": T, "cn0_dbhz": cn0})["line-of-sight acceleration PSD"][0]
    q_f = psd * (2 * np.pi / LAMBDA_L1) ** 2 * T  # (rad/s)^2 per interval
    r = _thermal_variance(cn0, T)
    assert _kalman_bucy_bandwidth_hz(np.array([0.0, q_f]), r, T) == pytest.approx(B, rel=0.01)
    assert _noise_bandwidth_hz(np.array([0.0, q_f]), r, T) == pytest.approx(B, rel=0.03)
    third = gf.registry.create("channel_filter", "scalar", pll_bandwidth_hz=B, pll_order=3, fll_bandwidth_hz=0.0)
    assert "line-of-sight acceleration PSD" not in third.assumptions({"coherent_time_s": T, "cn0_dbhz": cn0})


def test_the_scenario_gives_each_case_its_interval_and_cn0():
    scen = get_scenario({"kind": "scintillation", "coherent_time_s": 0.01, "cn0_dbhz": 45.0})
    base = scen.assumption_context({"name": "a", "model": "aj-stanford", "s4": 0.9})
    assert base["coherent_time_s"] == 0.01 and base["cn0_dbhz"] == 45.0
    assert base["wavelength_m"] == pytest.approx(LAMBDA_L1)
    own = scen.assumption_context(
        {"name": "b", "model": "aj-stanford", "s4": 0.9, "coherent_time_s": 0.001, "cn0_dbhz": 30.0}
    )
    assert own["coherent_time_s"] == 0.001 and own["cn0_dbhz"] == 30.0
