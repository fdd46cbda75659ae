"""The window search of assisted acquisition (`receiver.acquisition.assisted`) on the
project's generator: a signal whose code phase and Doppler are known is found in a window
around them, with the threshold of the window's cells (lower than the full search's for
the same false-alarm probability, `threshold.threshold_from_pfa`); noise alone is not."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition import threshold_from_pfa
from gnssframework.receiver.acquisition.assisted import SearchWindow, window_search
from gnssframework.signal.constants import CA_CHIP_RATE_HZ
from gnssframework.signal.if_samples import generate_if_samples

FS = 2.046e6
PRN = 7
DOPPLER_HZ = 1234.0
CODE_CHIPS = 300.25  # chips already sent at the first sample
PER_CODE = FS * 1e-3  # samples per code period


def _samples(cn0_dbhz: float | None, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = int(0.08 * FS)  # 10 ms x 8
    x = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    if cn0_dbhz is not None:
        x += generate_if_samples(
            PRN,
            0.08,
            FS,
            0.0,
            cn0_dbhz,
            rng,
            doppler_hz=DOPPLER_HZ,
            code_phase_chips=CODE_CHIPS,
            complex_samples=True,
            noise=False,
        ).samples
    return x


def _true_start_samples() -> float:
    """First sample at which a code period begins: the rest of the period at the code rate."""
    return (1023 - CODE_CHIPS) / (CA_CHIP_RATE_HZ * (1 + DOPPLER_HZ / 1575.42e6)) * FS


def test_a_signal_is_found_in_its_window_with_the_windows_threshold():
    # Predictions 3 samples and 20 Hz off, windows of +-6 samples and +-60 Hz.
    window = SearchWindow(_true_start_samples() + 3.0, DOPPLER_HZ - 20.0, 6.0, 60.0)
    result = window_search(_samples(30.0, 1), FS, 0.0, PRN, window)
    assert result.detected
    offset = (result.code_phase_samples - _true_start_samples() + PER_CODE / 2) % PER_CODE - PER_CODE / 2
    assert abs(offset) <= 1.0  # one sample: the grid's resolution
    assert abs(result.doppler_hz - DOPPLER_HZ) <= 25.0  # half a 50 Hz bin of 10 ms blocks
    # The window's cells: 13 lags (x 10 code periods in a 10 ms block) x 5 Doppler bins.
    cells = 13 * 10 * 5
    assert result.threshold == pytest.approx(threshold_from_pfa(1e-3, cells, 4, True))
    full = threshold_from_pfa(1e-3, int(10 * PER_CODE) * 201, 4, True)  # +-5 kHz in 50 Hz bins
    assert result.threshold < full


def test_noise_alone_is_not_detected():
    window = SearchWindow(_true_start_samples(), DOPPLER_HZ, 6.0, 60.0)
    assert not window_search(_samples(None, 2), FS, 0.0, PRN, window).detected


def test_bad_windows_name_the_field():
    with pytest.raises(ConfigError, match="window"):
        window_search(_samples(None, 3), FS, 0.0, PRN, SearchWindow(0.0, 0.0, -1.0, 10.0))
    with pytest.raises(ConfigError, match="noncoherent"):
        window_search(_samples(None, 3), FS, 0.0, PRN, SearchWindow(0.0, 0.0, 1.0, 10.0), noncoherent=7)
    with pytest.raises(ConfigError, match="samples"):
        window_search(_samples(None, 3)[:1000], FS, 0.0, PRN, SearchWindow(0.0, 0.0, 1.0, 10.0))
