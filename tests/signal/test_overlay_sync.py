"""`signal.overlay.overlay_sync` against prompts built with a known overlay shift and
frequency error (the truth is the construction)."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.signal.galileo_codes import GALILEO_E1C_SECONDARY_CS25
from gnssframework.signal.overlay import overlay_sync


@pytest.mark.parametrize("shift", [0, 6, 24])
def test_finds_the_shift_and_frequency_it_was_given(shift):
    T, df, n = 4e-3, 7.5, 40
    o = np.array(GALILEO_E1C_SECONDARY_CS25, float)
    k = np.arange(n)
    rng = np.random.default_rng(shift)
    noise = 0.05 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    prompts = o[(k + shift) % o.size] * np.exp(1j * (0.7 + 2 * np.pi * df * k * T)) + noise
    sync = overlay_sync(prompts, o, T)
    assert sync.shift == shift
    # the phase noise of one neighbour product is ~0.07 rad; averaged over 39 products the
    # angle's error is ~0.011 rad, i.e. 0.45 Hz at T = 4 ms: 2 Hz is over 4 of those
    assert abs(sync.freq_error_hz - df) < 2.0
    assert sync.margin > 2.0


def test_too_few_prompts_is_one_line():
    with pytest.raises(ConfigError, match="prompts"):
        overlay_sync(np.ones(2, complex), GALILEO_E1C_SECONDARY_CS25, 4e-3)
