"""Acquisition of weak signals: 10 ms coherent blocks summed by parity (``alternate_blocks``),
on the project's generator with random 50 bit/s data, against the detection theory of the
square-law detector (Kaplan & Hegarty, 3rd ed., sec. 8.4).

The signal sits on a grid cell (Doppler 0, a code phase of whole samples at 2 samples per
chip), so the statistic of its cell over the transition-free parity is exactly noncentral
chi-square with ``K`` degrees of freedom (``K/2`` blocks, I and Q each) and noncentrality
``(K/2) 2 (C/N0) T``. The detection probability lies between that cell's exceedance
``P_lo`` and ``1 - (1 - P_lo)^2`` (the other parity, at best as clean, is the only other
cell with a comparable mean: the neighbouring cells hold at most 0.4 of the power).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples

FS = 2.046e6
T = 0.010
K = 10  # blocks of 10 ms: 100 ms of samples
PRN = 7


def _acq():
    return registry.create(
        "acquisition", "pcps", coherent_ms=10, noncoherent=K, doppler_max_hz=250.0, alternate_blocks=True
    )


def _theory(cn0_dbhz: float) -> tuple[float, float]:
    acq = _acq()
    cells = acq.dopplers_hz().size * int(round(T * FS))
    from gnssframework.receiver.acquisition import threshold_from_pfa

    thr = threshold_from_pfa(acq.params.pfa, cells, K // 2, alternate=True)
    p_lo = float(stats.ncx2.sf(thr, K, (K // 2) * 2 * 10 ** (cn0_dbhz / 10) * T))
    return p_lo, 1 - (1 - p_lo) ** 2


def _trial(cn0_dbhz: float, seed: int) -> bool:
    rng = np.random.default_rng(seed)
    phase_chips = float(rng.integers(0, 2046)) / 2
    sat = SatelliteSignal(
        PRN,
        cn0_dbhz,
        0.0,
        phase_chips,
        float(rng.uniform(0, 2 * np.pi)),
        first_bit_code_period=int(rng.integers(0, 20)),
    )
    x = synthesize_samples([sat], K * T + 0.001, FS, 0.0, rng)
    r = _acq().acquire(x, FS, 0.0, (PRN,))[0]
    # A detection at the signal's cell: its code phase within a sample, its Doppler within a bin.
    right = abs((r.code_phase_chips - phase_chips + 511.5) % 1023 - 511.5) <= 0.5 and abs(r.doppler_hz) <= 50
    return r.detected and right


@pytest.mark.parametrize("cn0_dbhz", [35.0, 32.0])
def test_every_seed_detected_where_theory_says_certain(cn0_dbhz):
    p_lo, _ = _theory(cn0_dbhz)
    assert p_lo > 1 - 1e-6  # the theory's claim this test checks
    assert all(_trial(cn0_dbhz, seed) for seed in range(4))


@pytest.mark.slow
def test_detection_rate_matches_theory_near_threshold():
    cn0 = 27.0
    p_lo, p_up = _theory(cn0)
    assert 0.2 < p_lo < 0.8  # a C/N0 where the rate is informative
    n = 16
    hits = sum(_trial(cn0, 100 + seed) for seed in range(n))
    # Three binomial standard deviations outside [P_lo, P_up].
    lo = n * p_lo - 3 * np.sqrt(n * p_lo * (1 - p_lo))
    hi = n * p_up + 3 * np.sqrt(n * p_up * (1 - p_up))
    assert lo <= hits <= hi, (hits, n, p_lo, p_up)


def test_alternate_blocks_need_an_even_count():
    acq = registry.create("acquisition", "pcps", coherent_ms=10, noncoherent=5, alternate_blocks=True)
    with pytest.raises(ConfigError, match="even"):
        acq.acquire(np.zeros(int(0.05 * FS), complex), FS, 0.0, (1,))


def test_a_ten_period_block_reports_the_first_period_start():
    """A 10 ms block holds 10 copies of the C/A peak, equal but for rounding: the search
    reports the first (`AcquisitionResult.code_phase_samples` in one code period), the
    sample chip 0 arrives at, whichever copy the argmax took."""
    rng = np.random.default_rng(5)
    phase_chips = 700.5
    sat = SatelliteSignal(PRN, 45.0, 0.0, phase_chips, 0.3, first_bit_code_period=3)
    x = synthesize_samples([sat], K * T + 0.001, FS, 0.0, rng)
    r = _acq().acquire(x, FS, 0.0, (PRN,))[0]
    per_code = int(round(FS * 1e-3))  # 2046 samples
    # Chip 0 at sample s: the signal had sent (-s / 2) mod 1023 chips at sample 0.
    assert r.detected and r.code_phase_samples == round(-phase_chips * 2) % per_code


@pytest.mark.parametrize("sample_rate_hz", [FS, 16.3676e6])  # 2046 and 16367.6 samples a period
def test_every_copy_of_the_peak_is_one_start(sample_rate_hz):
    from gnssframework.receiver.acquisition import first_period_lag

    per_code = sample_rate_hz * 1e-3
    for start in (0.0, 3.0, per_code - 1.0):
        lags = [int(round(start + k * per_code)) for k in range(10)]
        firsts = {first_period_lag(lag, sample_rate_hz) for lag in lags}
        # A whole period: one start. Otherwise each copy was rounded to a sample on its own
        # (half a sample) and its remainder is rounded again: within a sample, modulo a period.
        tolerance = 0.0 if per_code == round(per_code) else 1.0
        assert all(abs((f - start + per_code / 2) % per_code - per_code / 2) <= tolerance for f in firsts), firsts
        assert all(0 <= f < round(per_code) for f in firsts), firsts
