"""The compiled multi-channel correlator against its NumPy reference (exact carrier) and
against `correlate_if`, with tolerances from the kernel's stated approximations."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.receiver.channels.correlator import TABLE_BITS, correlate_channels, correlate_numpy
from gnssframework.signal.codes import ca_code
from gnssframework.signal.if_samples import correlate_if, generate_if_samples


def _bound(x, starts, counts):
    """Carrier table error pi/2^bits per sample, plus the 2^-32 cycle rounding of the NCO
    words accumulated over the interval, times each sample's magnitude."""
    out = []
    for s, n in zip(starts, counts):
        mag = np.abs(x[s:s + n])
        phase_err = np.pi / 2**TABLE_BITS + 2 * np.pi * 2.0**-32 * (1 + np.arange(n))
        out.append(np.sum(mag * phase_err) + 1e-9 * np.sum(mag))
    return np.array(out)


@pytest.mark.parametrize("cplx", [True, False])
@pytest.mark.parametrize("taps", [(-0.5, 0.0, 0.5), (-1.0, -0.25, 0.0, 0.25, 1.0)])
@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_kernel_matches_the_reference_within_its_carrier_table_error(cplx, taps, seed):
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
    args = (starts, counts, rng.uniform(-2, 1025, n_ch), 1.023e6 / fs * (1 + rng.uniform(-1e-5, 1e-5, n_ch)),
            rng.uniform(-3, 3, n_ch), rng.uniform(-0.3, 0.3, n_ch), codes, np.array(taps))
    got = correlate_channels(x, *args, backend="numba")
    ref = correlate_numpy(x.astype(np.complex128) if cplx else x.astype(float), *args)
    assert got.shape == (n_ch, len(taps))
    assert np.all(np.abs(got - ref) <= _bound(x, starts, counts)[:, None])


def test_compiled_kernel_agrees_with_correlate_if_on_generated_samples():
    rng = np.random.default_rng(3)
    fs, T = 4e6, 1e-3
    sig = generate_if_samples(7, 0.003, fs, 0.0, 45.0, rng, doppler_hz=1500.0, code_phase_chips=100.0,
                              complex_samples=True)
    cr = 1.023e6 * (1 + 1500 / 1575.42e6)
    cp, f, ph = 100.0 + cr * 1000 / fs - 0.2, 1480.0, 0.3  # 0.2 chips behind the signal at sample 1000
    ref = correlate_if(sig, 7, np.array(cp), np.array(cr), np.array(f), np.array(ph), T, start_sample=1000)
    n = int(T * fs)
    raw = correlate_channels(sig.samples.astype(np.complex64), np.array([1000]), np.array([n]), np.array([cp]),
                             np.array([cr / fs]), np.array([ph / (2 * np.pi)]), np.array([f / fs]),
                             ca_code(7)[None].astype(np.float32), np.array([-0.5, 0.0, 0.5]))[0]
    norm = np.sqrt(n * sig.noise_std**2)
    # Beyond the table error, the two may floor a code index differently on a sample
    # that sits on a chip boundary to rounding; each such sample moves a tap by 2|x|.
    tol = (_bound(sig.samples, [1000], [n])[0] + 4 * np.abs(sig.samples).max()) / norm
    for got, want in zip(raw / norm, (ref.early, ref.prompt, ref.late)):
        assert abs(got - complex(want)) <= tol
    assert abs(ref.prompt) > 10 * tol  # the comparison is on a strong signal, not on noise alone


@pytest.mark.parametrize("cplx", [True, False])
def test_whole_code_periods_kernel_matches_the_reference_period_by_period(cplx):
    """Periods end at the replica's own code epochs: the kernel finds the same sample
    counts as the reference's ceil((1023 - phase) / step), and the same sums within the
    carrier table's bound, with the carrier running on across periods."""
    from gnssframework.receiver.channels.correlator import correlate_periods, correlate_periods_numpy

    rng = np.random.default_rng(8)
    fs = 4e6
    n = int(fs * 12e-3)
    x = rng.standard_normal(n) + (1j * rng.standard_normal(n) if cplx else 0)
    x = x.astype(np.complex64 if cplx else np.float32)
    n_ch = 4
    codes = np.stack([ca_code(p) for p in (3, 9, 17, 30)]).astype(np.float32)
    periods = np.array([1, 10, 4, 7])
    args = (rng.integers(0, 100, n_ch), periods, rng.uniform(-0.2, 0.2, n_ch),
            1.023e6 / fs * (1 + rng.uniform(-3e-6, 3e-6, n_ch)), rng.uniform(-2, 2, n_ch),
            rng.uniform(-2e-3, 2e-3, n_ch), codes, np.array([-0.5, 0.0, 0.5]))
    sums, counts = correlate_periods(x, *args, backend="numba")
    ref, ref_counts = correlate_periods_numpy(x.astype(complex) if cplx else x.astype(float), *args)
    np.testing.assert_array_equal(counts, ref_counts)
    for c in range(n_ch):
        start = first = args[0][c]
        for k in range(periods[c]):
            # The kernel's carrier runs on in fixed point: after the earlier periods its phase
            # is off by at most half a 2^-32 step per sample already run.
            drift = 2 * np.pi * 2.0**-33 * (start - first) * np.abs(x[start:start + ref_counts[c, k]]).sum()
            bound = _bound(x, [start], [ref_counts[c, k]])[0] + drift
            assert np.all(np.abs(sums[c, k] - ref[c, k]) <= bound)
            start += ref_counts[c, k]
        assert np.all(counts[c, periods[c]:] == 0)
