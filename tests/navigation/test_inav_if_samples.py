"""I/NAV through the project's IF generator: E1-B samples carrying `inav_symbols`, one
prompt per 4 ms code period (a matched open-loop correlation: the Doppler and code phase
are the generator's), decoded by `decode_inav`. Checks that the generator's symbol
convention, the symbol timing `inav_symbols` returns and the decoder agree, and that the
GST the decoder reads dates the right symbol."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.special import erfc

from gnssframework.navigation import inav
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.if_samples import generate_if_samples

NAV = Path(__file__).parents[1] / "data" / "galileo_inav_20feb2022_05h.rnx"


@pytest.mark.slow
def test_generated_e1b_samples_decode_to_the_ephemeris_and_the_gst():
    rec = read_rinex_nav(NAV, systems="E").subset(np.array([0]))
    fs, cn0_dbhz, prn = 4.092e6, 28.0, 11
    tow0 = 18020.5  # GST of the first sample: mid-way through a page's odd part
    n_sym = 7 * inav.PAGE_SYMBOLS + inav.PART_SYMBOLS  # the page ends, then words 1, 3, 5, 0, 0, 2, 4
    symbols, lead_s = inav.inav_symbols(rec, 1174, tow0, n_sym)
    assert lead_s == 0.0  # 18020.5 s is a symbol edge (4 ms grid from the page start at 18019 s)
    rng = np.random.default_rng(3)
    replica = generate_if_samples(
        prn, 0.004, fs, 0.0, 50.0, rng, complex_samples=True, noise=False, signal=GALILEO_E1B_BOC11
    ).samples
    prompts = []
    for k in range(0, n_sym, 250):  # 1 s at a time: 250 whole code periods, code and carrier phase 0
        x = generate_if_samples(
            prn,
            1.0,
            fs,
            0.0,
            cn0_dbhz,
            rng,
            complex_samples=True,
            data_bits=symbols[k : k + 250].astype(float),
            signal=GALILEO_E1B_BOC11,
        ).samples
        prompts.append((x.reshape(250, -1) @ replica.conj()).real)
    p = np.concatenate(prompts)
    # Es/N0 = C/N0 T = 4 dB: the uncoded symbol error rate Q(sqrt(2 Es/N0)) = 1.25 %; within
    # 4 binomial standard deviations of the 3750 symbols.
    ser = float(np.mean(np.sign(p) != symbols))
    expected = 0.5 * erfc(np.sqrt(10 ** ((cn0_dbhz - 10 * np.log10(250)) / 10)))
    assert abs(ser - expected) < 4 * np.sqrt(expected * (1 - expected) / n_sym)
    msg = inav.decode_inav(p)
    assert [pg.word_type for pg in msg.pages] == [1, 3, 5, 0, 0, 2, 4] and msg.failures == []
    assert msg.ephemeris is not None
    for name, value in rec.elements.items():
        assert msg.ephemeris.elements[name][0] == pytest.approx(value[0], rel=1e-9, abs=1e-20), name
    # The GST (word 0 at 18029 s) dates the even part's first symbol: that symbol's time,
    # counted from the first sample, is 18029 s.
    index, wn, tow = msg.gst
    assert wn == 1174 and tow == 18029.0
    assert tow0 - lead_s + index / inav.SYMBOL_RATE_HZ == pytest.approx(18029.0, abs=1e-9)
