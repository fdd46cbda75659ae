"""The tracker's batched and compiled per-interval helpers give what the per-channel code
gives: the narrow-wide power ratio of many windows with different bit phases in one pass
(`lock.cn0_nwpr_bits`) against `signal.cn0.cn0_nwpr` of each window from its bit phase,
and against the C/N0 the prompts were drawn with; a block's power
(`correlator.sum_of_squares`) against the float sum of its squares."""

from __future__ import annotations

import numpy as np

from gnssframework.receiver.channels.lock import cn0_nwpr_bits
from gnssframework.signal.cn0 import cn0_nwpr


def _prompts(rng, cn0_dbhz, n, bit_phase):
    """1 ms prompts at ``cn0_dbhz`` with unit-variance I and Q noise (A^2 = 2 c T) and a
    data bit that may change every 20 ms from ``bit_phase`` on."""
    amp = np.sqrt(2 * 10 ** (cn0_dbhz / 10) * 1e-3)
    bits = rng.choice([-1.0, 1.0], n // 20 + 2)[(np.arange(n) - bit_phase) // 20 + 1]
    return amp * bits * np.exp(0.3j) + rng.standard_normal(n) + 1j * rng.standard_normal(n)


def test_batched_nwpr_is_each_windows_own_estimate():
    rng = np.random.default_rng(11)
    n = 400
    phases = np.array([0, 7, 19, 3, 0, 12])  # 20 or 19 whole bits
    windows = np.stack([_prompts(rng, cn0, n, bp) for cn0, bp in zip([35, 40, 45, 50, 30, 42], phases)])
    got = cn0_nwpr_bits(windows, phases)
    want = np.array([cn0_nwpr(w[bp:], 1e-3, m=20) for w, bp in zip(windows, phases)])
    np.testing.assert_allclose(got, want, rtol=1e-12)  # the same sums: rounding only
    # A window's blocks must start at its bit edges: one shifted off them reads lower.
    assert cn0_nwpr_bits(windows[3:4], phases[3:4] + 10)[0] < want[3] - 1.0


def test_batched_nwpr_recovers_the_drawn_cn0():
    rng = np.random.default_rng(5)
    cn0 = 42.0
    phases = rng.integers(0, 20, 200)
    windows = np.stack([_prompts(rng, cn0, 400, bp) for bp in phases])
    est = cn0_nwpr_bits(windows, phases)
    # 19-20 blocks of 20 per window: the mean over 200 windows has a spread of a few
    # hundredths of a dB; NWPR's own bias at 42 dB-Hz and 20 ms blocks is well under 0.3 dB.
    assert abs(np.mean(est) - cn0) < 0.3


def test_block_power_is_the_float_sum_of_squares_for_every_stored_type():
    from gnssframework.receiver.channels.correlator import sum_of_squares

    rng = np.random.default_rng(2)
    for dtype, hi in ((np.int8, 127), (np.int16, 32767)):
        x = rng.integers(-hi - 1, hi + 1, 300_001).astype(dtype)
        x[:3] = (-hi - 1, hi, 0)  # the extremes of the type
        # Integer squares summed in float64 are exact here (below 2**53): equal, not close.
        assert sum_of_squares(x) == float(np.sum(x.astype(np.float64) ** 2))
    f = rng.standard_normal(1001).astype(np.float32)
    np.testing.assert_allclose(sum_of_squares(f), np.sum(f.astype(np.float64) ** 2), rtol=1e-6)
