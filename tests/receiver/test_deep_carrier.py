"""Carrier-phase prefilter of deep integration (reference 002, section 3.2): a Kalman carrier
loop on the phase discriminator that closes only the carrier loop on top of the INS-aided
replica.

Oracle (`docs/deep_integration_carrier.predicted_phase_var`, which the page's table uses): the
steady-state phase error variance of the loop, from its steady-state Kalman gain
(scipy's discrete Riccati solver) and the error recursion
$e^-_{k+1} = F(I - KH)e^-_k - FKv_k$ solved as a discrete Lyapunov equation with the
discriminator's true thermal variance $\\frac{1}{2cT}(1 + \\frac{1}{2cT})$ (Kaplan and
Hegarty 2017, Costas loop), against the simulated mid-interval phase error.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.receiver.deep.aided_tracking import run_aided_tracking
from gnssframework.registry import create
from test_deep_integration import _OffsetNavigator, _aided_setup

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "docs"))
from deep_integration_carrier import predicted_phase_var  # noqa: E402  (the oracle; its own test simulates the recursion)

T = 1e-3
Q_DIAG, R_FILTER = (0.0, 1e-3), 0.05  # the loop's tuning (rad^2 and (rad/s)^2 per interval, rad^2)


def _carrier_run(cn0_dbhz: float, runs: int = 8, seconds: float = 1.0, seed: int = 3):
    truth, rx = _aided_setup(runs, seconds, cn0=cn0_dbhz)
    zero3, zero = np.zeros((runs, 3)), np.zeros(runs)
    nav = _OffsetNavigator(rx, zero3, zero3, zero, zero, (100.0, 0.0))  # a perfect navigator
    channel = create("channel_filter", "iq-filter", adapter=None, estimator="ukf", output="equivalent")
    carrier = create("channel_filter", "kf-carrier-loop", states=2, q=list(Q_DIAG), r=R_FILTER)
    return run_aided_tracking(channel, nav, truth, np.random.default_rng(seed), carrier_filter=carrier)


@pytest.mark.parametrize("cn0_dbhz", [45.0, 35.0])
def test_carrier_prefilter_phase_error_matches_the_loop_jitter(cn0_dbhz):
    rec = _carrier_run(cn0_dbhz)
    phase = rec.extra["phase_error_rad"]
    assert phase.shape == rec.code_error_chips.shape
    # A Costas loop locks at either of two phases half a cycle apart: the error modulo pi.
    e = np.angle(np.exp(2j * phase[300:])) / 2  # after the pull-in (loop time ~ 1/B_L = 0.16 s)
    want = predicted_phase_var(cn0_dbhz, Q_DIAG, R_FILTER)
    # ~48 channels x 700 ms with a ~40 ms correlation time: about 5 % standard error.
    assert 0.85 < np.mean(e**2) / want < 1.15, (np.mean(e**2), want)
    assert np.abs(np.mean(e)) < 4 * np.sqrt(want / 800)  # no bias (800 ~ independent samples)
    # Nothing of the carrier loop reaches the code/frequency side: same draws, same outputs.
    truth_only = _carrier_run(cn0_dbhz, runs=2, seconds=0.2)
    truth, rx = _aided_setup(2, 0.2, cn0=cn0_dbhz)
    zero3, zero = np.zeros((2, 3)), np.zeros(2)
    plain = run_aided_tracking(
        create("channel_filter", "iq-filter", adapter=None, estimator="ukf", output="equivalent"),
        _OffsetNavigator(rx, zero3, zero3, zero, zero, (100.0, 0.0)),
        truth,
        np.random.default_rng(3),
    )
    np.testing.assert_allclose(plain.residual_m, truth_only.residual_m, rtol=0, atol=1e-12)


def test_carrier_prefilter_without_carrier_outputs_is_refused():
    truth, rx = _aided_setup(1, 0.01)
    zero3, zero = np.zeros((1, 3)), np.zeros(1)
    iq = create("channel_filter", "iq-filter", adapter=None, estimator="ukf", output="equivalent")
    with pytest.raises(ConfigError, match="carrier_filter"):
        run_aided_tracking(
            iq,
            _OffsetNavigator(rx, zero3, zero3, zero, zero, (100.0, 0.0)),
            truth,
            np.random.default_rng(0),
            carrier_filter=iq,
        )


def test_ins_ekf_refuses_a_carrier_filter_that_cannot_close_a_carrier_loop():
    with pytest.raises(ConfigError, match=r"ins-ekf'\.carrier_filter.*'iq-filter'.*carrier_freq_hz.*kf-carrier-loop"):
        create("nav_filter", "ins-ekf", carrier_filter="iq-filter")
    assert (
        create("nav_filter", "ins-ekf", carrier_filter="kf-carrier-loop").params.carrier_filter.name
        == "kf-carrier-loop"
    )
