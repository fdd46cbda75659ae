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


def _arrays(rng, slots=6, window=50):
    from gnssframework.receiver.channels.intervals import ChannelArrays

    return ChannelArrays(
        rng.uniform(0, 1, slots),
        rng.uniform(0, 1, slots),
        rng.uniform(0, 9, slots),
        rng.integers(0, 1000, slots),
        rng.uniform(-1, 1, slots),
        rng.uniform(0, 99, slots),
        rng.standard_normal((slots, window)) + 1j * rng.standard_normal((slots, window)),
        rng.integers(0, 500, slots),
        rng.integers(0, 500, slots),
        rng.standard_normal(slots) + 1j * rng.standard_normal(slots),
        rng.random(slots) < 0.7,
        rng.integers(0, 5, (slots, 20)),
    )


def test_compiled_interval_closing_is_bit_identical_to_the_numpy_reference():
    from gnssframework.receiver.channels.intervals import close_periods, close_periods_numpy

    rng = np.random.default_rng(8)
    for trial in range(20):
        idx = np.sort(rng.choice(6, rng.integers(1, 7), replace=False))
        periods = rng.choice([1, 10, 20], idx.size)
        counts = np.zeros((idx.size, periods.max()), np.int64)
        for j, p in enumerate(periods):
            counts[j, :p] = rng.integers(2590, 2610, p)
        sums = (rng.standard_normal(counts.shape + (3,)) + 1j * rng.standard_normal(counts.shape + (3,))) * 900
        sums[counts == 0] = 0
        args = (
            idx,
            counts,
            rng.integers(0, 10**6, idx.size),
            rng.uniform(-0.5, 0.5, idx.size),
            rng.uniform(0.39, 0.4, idx.size),
            periods,
            rng.uniform(-5e3, 5e3, idx.size),
            rng.uniform(1, 9, idx.size),
            2.6e6,
            1023,
        )
        a, b = _arrays(np.random.default_rng(trial)), _arrays(np.random.default_rng(trial))
        s_ref, s_new = sums.copy(), sums.copy()
        want = close_periods_numpy(a, args[0], s_ref, *args[1:])
        got = close_periods(b, args[0], s_new, *args[1:], backend="numba")
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(s_new, s_ref)
        for name in vars(a):
            np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)
        # and they did something: the slots' NCO bookkeeping moved, each period's sums were
        # scaled to unit noise (by sqrt(N P / 2)), untouched slots did not move
        fresh = _arrays(np.random.default_rng(trial))
        assert np.all(b.start_sample[idx] == args[2] + counts.sum(axis=1))
        np.testing.assert_allclose(s_new[0, 0], sums[0, 0] / np.sqrt(counts[0, 0] * args[7][0] / 2), rtol=1e-15)
        others = np.setdiff1d(np.arange(6), idx)
        np.testing.assert_array_equal(b.code_phase[others], fresh.code_phase[others])
