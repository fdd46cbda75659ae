"""SBAS L1 messages through the project's IF generator: ``sbas-l1`` samples carrying
`sbas_message.sbas_symbols` (real MSAS messages, `tests/data/README.md`), one prompt per
2 ms symbol by a matched open-loop correlation (the generator's Doppler and code phase),
decoded by `find_messages`. Checks that the generator's symbol timing and convention and
the decoder agree, at a C/N0 where the Viterbi decoder has symbol errors to correct."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.special import erfc

from gnssframework.navigation import sbas_message as sm
from gnssframework.signal.if_samples import generate_if_samples
from gnssframework.signal.sbas_l1 import SBAS_L1

DATA = Path(__file__).parents[1] / "data" / "sbas_msas_gw10_20110121.txt"


@pytest.mark.slow
def test_generated_sbas_samples_decode_to_the_messages_sent():
    lines = [line.split() for line in DATA.read_text().splitlines() if line and not line.startswith("#")]
    msgs = sm.messages_from_hex([text for _, prn, text in lines if prn == "137"])
    fs, cn0_dbhz, skip = 2.5e6, 31.0, 123
    n_sym = 4 * sm.MESSAGE_SYMBOLS  # 4 s: messages 1-3 whole after the cut
    symbols = sm.sbas_symbols(msgs, skip, n_sym)
    rng = np.random.default_rng(17)
    replica = generate_if_samples(
        137, 0.002, fs, 0.0, 50.0, rng, complex_samples=True, noise=False, signal=SBAS_L1
    ).samples
    prompts = []
    for k in range(0, n_sym, 500):  # 1 s at a time: 500 whole symbols, code and carrier phase 0
        x = generate_if_samples(
            137,
            1.0,
            fs,
            0.0,
            cn0_dbhz,
            rng,
            complex_samples=True,
            data_bits=symbols[k : k + 500].astype(float),
            signal=SBAS_L1,
        ).samples
        prompts.append((x.reshape(500, -1) @ replica.conj()).real)
    p = np.concatenate(prompts)
    # Es/N0 = C/N0 x 2 ms = 4 dB: the uncoded symbol error rate Q(sqrt(2 Es/N0)) = 1.25 %,
    # within 4 binomial standard deviations of the 2000 symbols.
    ser = float(np.mean(np.sign(p) != symbols))
    expected = 0.5 * erfc(np.sqrt(10 ** ((cn0_dbhz - 10 * np.log10(500)) / 10)))
    assert ser > 0 and abs(ser - expected) < 4 * np.sqrt(expected * (1 - expected) / n_sym)
    found, failures = sm.find_messages(p)
    assert failures == [] and len(found) == 3
    for j, m in enumerate(found, start=1):
        np.testing.assert_array_equal(m.bits, msgs[j])
        assert m.start == j * sm.MESSAGE_SYMBOLS - skip and not m.inverted
