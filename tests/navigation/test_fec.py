"""The channel codes of Galileo I/NAV (gnssframework.navigation.fec): the convolutional
encoder against the Galileo ICD's own encoded sequences, the Viterbi decoder against an
exhaustive maximum-likelihood search and against coding theory in AWGN, the interleaver
against its definition, and CRC-24Q against pyrtcm and a published RTCM 3 frame."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pyrtcm import calc_crc24q
from scipy.special import erfc
from scipy.stats import beta

from gnssframework.errors import ConfigError
from gnssframework.navigation import fec


def _bits(text: str) -> np.ndarray:
    return np.array([int(c) for c in text], dtype=np.uint8)


@pytest.mark.parametrize(
    "plain, encoded",
    [("00000100", "1110100100100101"), ("00101011", "0110110001001110"), ("00101111", "1101000000111110")],
)
def test_encoder_gives_the_icd_encoded_ssp_configurations(plain, encoded):
    # Galileo OS SIS ICD 2.0/2.1, 5.1.9.5 (Table of SSP configurations): "the last 16 symbols
    # of the I/NAV E1 pages, after FEC encoding of the 8 plain SSP bits + 6 tail bits". They
    # depend on the SSP and tail bits alone (the register holds 6 bits), so any bits before.
    rng = np.random.default_rng(1)
    for _ in range(5):
        before = rng.integers(0, 2, 106)
        symbols = fec.conv_encode(np.concatenate([before, _bits(plain), np.zeros(6, np.uint8)]))
        assert "".join(map(str, symbols[-16:])) == encoded


def test_encoder_is_the_generator_polynomials_product_modulo_two():
    rng = np.random.default_rng(2)
    u = rng.integers(0, 2, 50)
    taps = [np.array([(g >> (6 - d)) & 1 for d in range(7)]) for g in (0o171, 0o133)]
    c1 = np.convolve(u, taps[0])[:50] % 2
    c2 = 1 - np.convolve(u, taps[1])[:50] % 2  # G2 inverted (ICD 4.1.4.1)
    out = fec.conv_encode(u)
    assert np.array_equal(out[0::2], c1) and np.array_equal(out[1::2], c2)


def test_viterbi_equals_an_exhaustive_maximum_likelihood_search():
    # 8 information bits + 6 tail bits: 256 codewords; the ML decision is the codeword of
    # largest correlation with the received values (AWGN log-likelihood).
    messages = np.array(list(itertools.product((0, 1), repeat=8)), dtype=np.uint8)
    messages = np.concatenate([messages, np.zeros((256, 6), np.uint8)], axis=1)
    codewords = 1.0 - 2.0 * fec.conv_encode(messages)
    rng = np.random.default_rng(3)
    sent = rng.integers(0, 256, 400)
    received = codewords[sent] + rng.normal(0, 1.0, (400, 28))
    ml = np.argmax(received @ codewords.T, axis=1)
    decoded = fec.viterbi_decode(received)
    assert np.array_equal(decoded, messages[ml])
    assert (ml != sent).sum() > 10  # the noise was strong enough for ML to err: the comparison covers errors


def test_viterbi_corrects_any_four_symbol_errors_in_a_page_part():
    # The terminated code's minimum distance is d_free = 10 (Proakis Table 8.2-1, K = 7,
    # rate 1/2), so ML decoding corrects every pattern of up to 4 hard symbol errors.
    rng = np.random.default_rng(4)
    u = rng.integers(0, 2, (500, 120)).astype(np.uint8)
    u[:, 114:] = 0
    symbols = 1.0 - 2.0 * fec.conv_encode(u)
    for row in symbols:
        row[rng.choice(240, 4, replace=False)] *= -1
    assert np.array_equal(fec.viterbi_decode(symbols), u)


def _q(x):
    return 0.5 * erfc(x / np.sqrt(2))


def test_soft_viterbi_bit_error_rate_in_awgn_is_below_the_union_bound_and_far_below_uncoded():
    # Eb/N0 = 3 dB per information bit, rate 1/2: Es/N0 = Eb/N0 / 2, noise sigma^2 = N0/2 with Es = 1.
    ebn0 = 10 ** (3.0 / 10)
    n_blocks, n_info = 2000, 114
    rng = np.random.default_rng(5)
    u = rng.integers(0, 2, (n_blocks, 120)).astype(np.uint8)
    u[:, n_info:] = 0
    y = 1.0 - 2.0 * fec.conv_encode(u) + rng.normal(0, np.sqrt(1 / (2 * 0.5 * ebn0)), (n_blocks, 240))
    errors = int((fec.viterbi_decode(y)[:, :n_info] != u[:, :n_info]).sum())
    n = n_blocks * n_info
    upper = beta.ppf(1 - 1e-6, errors + 1, n - errors)  # Clopper-Pearson, one-sided 1 - 1e-6
    # Union bound Pb <= sum_d beta_d Q(sqrt(2 d R Eb/N0)) with the information-error weights
    # of the (171, 133) code (d = 10, 12, ..., 20: 36, 211, 1404, 11633, 77433, 502690).
    weights = {10: 36, 12: 211, 14: 1404, 16: 11633, 18: 77433, 20: 502690}
    union = sum(w * _q(np.sqrt(2 * d * 0.5 * ebn0)) for d, w in weights.items())
    uncoded = _q(np.sqrt(2 * ebn0))  # hard-decision BPSK at the same Eb/N0
    assert upper < union
    assert upper < uncoded / 20
    assert errors > 0  # noise was there (a decoder that saw none would prove nothing)


def test_interleaver_writes_columns_and_reads_rows():
    x = np.arange(240)
    out = fec.interleave(x)
    # Column c holds coded symbols 8c..8c+7; row r is read first: symbols r, 8 + r, 16 + r, ...
    assert np.array_equal(out[:30], np.arange(0, 240, 8))
    assert np.array_equal(out[30:60], np.arange(1, 240, 8))
    assert np.array_equal(fec.deinterleave(out), x)
    with pytest.raises(ConfigError, match="240 symbols"):
        fec.interleave(np.arange(239))


def test_crc24q_agrees_with_pyrtcm_on_196_bit_messages():
    rng = np.random.default_rng(6)
    bits = rng.integers(0, 2, (50, 196)).astype(np.uint8)
    ours = fec.crc24q_bits(bits)
    for row, crc in zip(bits, ours):
        data = np.packbits(np.concatenate([np.zeros(4, np.uint8), row])).tobytes()  # leading zeros: same CRC
        assert crc == calc_crc24q(data)


def test_crc24q_of_published_frames():
    # RTCM 3 message 1005 of RTCM 10403 (station 2003), as circulated in decoder test suites: CRC 0x360B98.
    frame = bytes.fromhex("D300133ED7D30202980EDEEF34B4BD62AC0941986F33360B98")
    assert fec.crc24q_bits(np.unpackbits(np.frombuffer(frame[:-3], np.uint8))) == 0x360B98
    # The catalogue check value of CRC-24/LTE-A (= CRC-24Q: 0x864CFB, init 0) over "123456789".
    assert fec.crc24q_bits(np.unpackbits(np.frombuffer(b"123456789", np.uint8))) == 0xCDE703


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ConfigError, match="even, non-zero number of symbols"):
        fec.viterbi_decode(np.ones(7))
    with pytest.raises(ConfigError, match="must be finite"):
        fec.viterbi_decode(np.array([1.0, np.nan]))
    with pytest.raises(ConfigError, match="0 or 1"):
        fec.conv_encode(np.array([0, 2]))
