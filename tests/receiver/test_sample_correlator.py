"""The compiled multi-channel correlator against its NumPy reference (exact carrier) and
against `correlate_if`, with tolerances from the kernel's stated approximations."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.receiver.channels.correlator import correlate_channels, correlate_numpy, correlation_error_bound
from gnssframework.signal.codes import ca_code
from gnssframework.signal.if_samples import correlate_if, generate_if_samples


def _bound(x, starts, counts):
    """The kernel's stated error (`correlation_error_bound`: float32 rounding of the carrier
    and of a chunk's sums, the 2^-32 rounding of the NCO words) over each range."""
    return np.array([correlation_error_bound(x, s, n) for s, n in zip(starts, counts)])


@pytest.mark.parametrize("cplx", [True, False])
@pytest.mark.parametrize("taps", [(-0.5, 0.0, 0.5), (-1.0, -0.25, 0.0, 0.25, 1.0)])
@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_kernel_matches_the_reference_within_its_rounding(cplx, taps, seed):
    rng = np.random.default_rng(seed)
    fs = float(rng.choice([2.6e6, 4e6, 16.3676e6]))
    n = int(fs * 2e-3)
    x = rng.standard_normal(n) + (1j * rng.standard_normal(n) if cplx else 0)
    x = x.astype(np.complex64 if cplx else np.float32)
    n_ch = 5
    prns = rng.choice(np.arange(1, 33), n_ch, replace=False)
    codes = np.stack([ca_code(int(p)) for p in prns]).astype(np.float32)
    counts = rng.integers(int(0.5e-3 * fs), int(1.2e-3 * fs), n_ch)
    starts = rng.integers(0, n - counts.max(), n_ch)
    args = (
        starts,
        counts,
        rng.uniform(-2, 1025, n_ch),
        1.023e6 / fs * (1 + rng.uniform(-1e-5, 1e-5, n_ch)),
        rng.uniform(-3, 3, n_ch),
        rng.uniform(-0.3, 0.3, n_ch),
        codes,
        np.array(taps),
    )
    got = correlate_channels(x, *args, backend="numba")
    ref = correlate_numpy(x.astype(np.complex128) if cplx else x.astype(float), *args)
    assert got.shape == (n_ch, len(taps))
    assert np.all(np.abs(got - ref) <= _bound(x, starts, counts)[:, None])


def test_compiled_kernel_agrees_with_correlate_if_on_generated_samples():
    rng = np.random.default_rng(3)
    fs, T = 4e6, 1e-3
    sig = generate_if_samples(
        7, 0.003, fs, 0.0, 45.0, rng, doppler_hz=1500.0, code_phase_chips=100.0, complex_samples=True
    )
    cr = 1.023e6 * (1 + 1500 / 1575.42e6)
    cp, f, ph = 100.0 + cr * 1000 / fs - 0.2, 1480.0, 0.3  # 0.2 chips behind the signal at sample 1000
    ref = correlate_if(sig, 7, np.array(cp), np.array(cr), np.array(f), np.array(ph), T, start_sample=1000)
    n = int(T * fs)
    raw = correlate_channels(
        sig.samples.astype(np.complex64),
        np.array([1000]),
        np.array([n]),
        np.array([cp]),
        np.array([cr / fs]),
        np.array([ph / (2 * np.pi)]),
        np.array([f / fs]),
        ca_code(7)[None].astype(np.float32),
        np.array([-0.5, 0.0, 0.5]),
    )[0]
    norm = np.sqrt(n * sig.noise_std**2)
    # Beyond the rounding bound, the two may floor a code index differently on a sample
    # that sits on a chip boundary to rounding; each such sample moves a tap by 2|x|.
    tol = (_bound(sig.samples, [1000], [n])[0] + 4 * np.abs(sig.samples).max()) / norm
    for got, want in zip(raw / norm, (ref.early, ref.prompt, ref.late)):
        assert abs(got - complex(want)) <= tol
    assert abs(ref.prompt) > 10 * tol  # the comparison is on a strong signal, not on noise alone


@pytest.mark.parametrize("cplx", [True, False])
def test_whole_code_periods_kernel_matches_the_reference_period_by_period(cplx):
    """Periods end at the replica's own code epochs: the kernel finds the same sample
    counts as the reference's ceil((1023 - phase) / step), and the same sums within the
    kernel's rounding bound, with the carrier running on across periods."""
    from gnssframework.receiver.channels.correlator import correlate_periods, correlate_periods_numpy

    rng = np.random.default_rng(8)
    fs = 4e6
    n = int(fs * 12e-3)
    x = rng.standard_normal(n) + (1j * rng.standard_normal(n) if cplx else 0)
    x = x.astype(np.complex64 if cplx else np.float32)
    n_ch = 4
    codes = np.stack([ca_code(p) for p in (3, 9, 17, 30)]).astype(np.float32)
    periods = np.array([1, 10, 4, 7])
    args = (
        rng.integers(0, 100, n_ch),
        periods,
        rng.uniform(-0.2, 0.2, n_ch),
        1.023e6 / fs * (1 + rng.uniform(-3e-6, 3e-6, n_ch)),
        rng.uniform(-2, 2, n_ch),
        rng.uniform(-2e-3, 2e-3, n_ch),
        codes,
        np.array([-0.5, 0.0, 0.5]),
    )
    sums, counts = correlate_periods(x, *args, backend="numba")
    ref, ref_counts = correlate_periods_numpy(x.astype(complex) if cplx else x.astype(float), *args)
    np.testing.assert_array_equal(counts, ref_counts)
    for c in range(n_ch):
        start = first = args[0][c]
        for k in range(periods[c]):
            bound = correlation_error_bound(x, start, ref_counts[c, k], run_before=start - first)
            assert np.all(np.abs(sums[c, k] - ref[c, k]) <= bound)
            start += ref_counts[c, k]
        assert np.all(counts[c, periods[c] :] == 0)


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.float32])
@pytest.mark.parametrize("q_sign", [1, -1])
def test_kernels_read_recorded_components_as_the_reference_reads_the_complex_samples(dtype, q_sign):
    """Interleaved I/Q components as recorded (no float copy), with an inverted Q branch
    read as I - jQ: the same sums as the reference on the complex samples they stand for."""
    from gnssframework.receiver.channels.correlator import correlate_periods, correlate_periods_numpy

    rng = np.random.default_rng(11)
    fs = 2.6e6
    n = int(fs * 6e-3)
    comps = rng.integers(-100, 100, 2 * n).astype(dtype)
    z = comps[0::2].astype(float) + 1j * q_sign * comps[1::2].astype(float)
    codes = np.stack([ca_code(p) for p in (4, 21)]).astype(np.float32)
    offsets = np.array([-0.5, 0.0, 0.5])
    args = (
        np.array([3, 50]),
        np.array([2, 5]),
        np.array([0.1, -0.3]),
        np.full(2, 1.023e6 / fs),
        np.array([0.25, 0.7]),
        np.array([1.2e-3, -0.9e-3]),
        codes,
        offsets,
    )
    sums, counts = correlate_periods(comps, *args, iq=True, q_sign=q_sign, backend="numba")
    ref, ref_counts = correlate_periods_numpy(z, *args)
    np.testing.assert_array_equal(counts, ref_counts)
    for c, (start, first) in enumerate(zip(*[args[0]] * 2)):
        for k in range(args[1][c]):
            bound = correlation_error_bound(z, start, ref_counts[c, k], run_before=start - first)
            assert np.all(np.abs(sums[c, k] - ref[c, k]) <= bound)
            start += ref_counts[c, k]
    # The same call on a window of whole samples gives the same sums: the start indexes samples.
    got = correlate_channels(
        comps,
        np.array([10]),
        np.array([2600]),
        np.array([5.0]),
        np.array([1.023e6 / fs]),
        np.array([0.1]),
        np.array([1e-3]),
        codes[:1],
        offsets,
        iq=True,
        q_sign=q_sign,
    )
    want = correlate_numpy(
        z,
        np.array([10]),
        np.array([2600]),
        np.array([5.0]),
        np.array([1.023e6 / fs]),
        np.array([0.1]),
        np.array([1e-3]),
        codes[:1],
        offsets,
    )
    assert np.all(np.abs(got - want) <= correlation_error_bound(z, 10, 2600))


def test_code_tables_give_every_taps_chip_from_the_prompts_word():
    """The pattern of a word is the taps' code signs at floor(u + D_t): checked by direct
    indexing at random words for irregular taps (thresholds at several fractions)."""
    from gnssframework.receiver.channels.correlator import code_tables

    rng = np.random.default_rng(5)
    offsets = np.array([-1.0, -0.3, -0.25, 0.0, 0.1, 0.25, 1.7])
    codes = np.stack([ca_code(p) for p in (1, 32)]).astype(np.float32)
    t = code_tables(codes, offsets)
    # -1.0 and 0.0 cross no threshold within a chip; -0.3 and 1.7 share one (fraction 0.7).
    assert t.thresholds.size == 4
    words = rng.integers(1023 * 2**32, 2 * 1023 * 2**32, 2000)
    tap_words = np.rint(offsets * 2.0**32).astype(np.int64)
    for c in range(2):
        k = (words >> 32) * (t.thresholds.size + 1) + np.sum((words & (2**32 - 1))[:, None] >= t.thresholds, axis=1)
        bits = (t.patterns[c, k][:, None] >> np.arange(offsets.size)) & 1
        want = codes[c, ((words[:, None] + tap_words) >> 32) % 1023] < 0
        np.testing.assert_array_equal(bits.astype(bool), want)


def test_more_taps_than_a_pattern_holds_is_a_clear_error():
    from gnssframework.errors import ConfigError
    from gnssframework.receiver.channels.correlator import MAX_TAPS, code_tables

    with pytest.raises(ConfigError, match="at most"):
        code_tables(ca_code(1)[None].astype(np.float32), np.linspace(-1, 1, MAX_TAPS + 2))


def test_channels_in_parallel_give_bit_identical_sums_whatever_the_thread_count():
    """The parallel kernels run each channel's arithmetic whole on one thread: 1 or 2
    threads give the same bits, and the serial kernels agree within the stated rounding."""
    import numba

    from gnssframework.receiver.channels.correlator import correlate_periods

    rng = np.random.default_rng(21)
    fs = 4e6
    comps = rng.integers(-60, 60, 2 * int(fs * 6e-3)).astype(np.int8)
    codes = np.stack([ca_code(p) for p in (2, 7, 11, 19, 25)]).astype(np.float32)
    args = (
        rng.integers(0, 200, 5),
        np.array([5, 3, 4, 5, 1]),
        rng.uniform(-0.5, 0.5, 5),
        1.023e6 / fs * (1 + rng.uniform(-3e-6, 3e-6, 5)),
        rng.uniform(0, 1, 5),
        rng.uniform(-1e-3, 1e-3, 5),
        codes,
        np.array([-0.5, 0.0, 0.5]),
    )
    before = numba.get_num_threads()
    try:
        runs = []
        for threads in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
            numba.set_num_threads(threads)
            runs.append(correlate_periods(comps, *args, iq=True, parallel=True))
    finally:
        numba.set_num_threads(before)
    for sums, counts in runs[1:]:
        np.testing.assert_array_equal(counts, runs[0][1])
        np.testing.assert_array_equal(sums, runs[0][0])
    serial, counts = correlate_periods(comps, *args, iq=True, parallel=False)
    np.testing.assert_array_equal(counts, runs[0][1])
    z = comps[0::2] + 1j * comps[1::2].astype(float)
    bound = 2 * correlation_error_bound(z, 0, z.size)  # each side within its bound of the exact sums
    assert np.abs(serial - runs[0][0]).max() <= bound


@pytest.mark.parametrize("recorded", ["int8 iq", "float32 real"])
def test_the_fused_epl_loop_agrees_with_the_per_tap_loops(recorded):
    """Three taps take the kernel's fused E/P/L loop (the baseband in registers, issue 41),
    any other count the per-tap loops over the stored baseband. The same three taps with a
    fourth beside them go the second way: each of the three sums is then the same float32
    products summed in another order within each chunk, so the two differ by at most twice
    a chunk's float32 summation error, 2 `ROUNDING` per unit of sum |x| over each period (a
    tap's bit read from the wrong place in the pattern would differ by order sqrt(N)|x|)."""
    from gnssframework.receiver.channels.correlator import ROUNDING, correlate_periods

    rng = np.random.default_rng(41)
    fs = 2.6e6 if recorded == "int8 iq" else 16.3676e6
    n = int(fs * 8e-3)
    iq = recorded == "int8 iq"
    x = rng.integers(-40, 40, 2 * n).astype(np.int8) if iq else rng.standard_normal(n).astype(np.float32)
    mag = np.abs(x[0::2] + 1j * x[1::2].astype(float)) if iq else np.abs(x.astype(float))
    codes = np.stack([ca_code(p) for p in (5, 12, 28)]).astype(np.float32)
    epl = np.array([-0.5, 0.0, 0.5])
    head = (
        rng.integers(0, 300, 3),
        np.array([6, 1, 4]),
        rng.uniform(-0.5, 0.5, 3),
        1.023e6 / fs * (1 + rng.uniform(-3e-6, 3e-6, 3)),
        rng.uniform(0, 1, 3),
        rng.uniform(-3e-3, 3e-3, 3),
        codes,
    )
    fused, counts = correlate_periods(x, *head, epl, iq=iq, backend="numba")
    per_tap, counts4 = correlate_periods(x, *head, np.append(epl, 0.25), iq=iq, backend="numba")
    np.testing.assert_array_equal(counts, counts4)
    for c in range(3):
        start = head[0][c]
        for k in range(head[1][c]):
            bound = 2 * ROUNDING * mag[start : start + counts[c, k]].sum()
            assert np.abs(fused[c, k] - per_tap[c, k, :3]).max() <= bound
            start += counts[c, k]
    # correlate_channels' driver too (one range per channel, two chunks and more)
    args = (head[0], np.array([3000, 1100, 5000]), head[2], head[3], head[4], head[5], codes)
    got3 = correlate_channels(x, *args, epl, iq=iq, backend="numba")
    got4 = correlate_channels(x, *args, np.append(epl, 0.25), iq=iq, backend="numba")
    for c in range(3):
        bound = 2 * ROUNDING * mag[args[0][c] : args[0][c] + args[1][c]].sum()
        assert np.abs(got3[c] - got4[c, :3]).max() <= bound
