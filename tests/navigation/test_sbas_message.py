"""SBAS L1 messages (`sbas_message`): the project's CRC-24Q, preamble and type reading
against real messages, and encoding then Viterbi decoding with noise, a symbol-pair
misalignment and an inverted carrier phase.

Independent truth: 24 messages of MSAS (PRN 129 and 137, 2011-01-21) logged by a Furuno
GW-10 receiver, from RTKLIB's test data (tomojitakasu/RTKLIB, BSD 2-clause,
``test/data/rcvraw/gw10_20110121.sbas``; `tests/data/README.md`). The receiver decoded and
checked them itself; nothing of this project made them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssframework.errors import ConfigError
from gnssframework.navigation import fec
from gnssframework.navigation import sbas_message as sm

DATA = Path(__file__).parents[1] / "data" / "sbas_msas_gw10_20110121.txt"


def _log() -> list[tuple[int, int, str]]:
    rows = []
    for line in DATA.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            tow, prn, text = line.split()
            rows.append((int(tow), int(prn), text))
    return rows


def _prn(prn: int) -> tuple[np.ndarray, list[str]]:
    texts = [t for _, p, t in _log() if p == prn]
    return sm.messages_from_hex(texts), texts


def test_the_logged_messages_pass_the_crc_and_read_their_preambles_and_types():
    rows = _log()
    assert len(rows) == 24
    for prn in (129, 137):
        msgs, texts = _prn(prn)
        parsed = [sm.parse_message(m) for m in msgs]
        assert all(ok for _, _, ok in parsed)
        # one message a second, the preamble parts in turn (the log starts on 0xC6)
        assert [p for p, _, _ in parsed] == [0xC6, 0x53, 0x9A] * 4
        # the types as the log's bytes read them: byte 1's top six bits
        assert [t for _, t, _ in parsed] == [int(x[2:4], 16) >> 2 for x in texts]
        assert [t for _, t, _ in parsed] == [4, 2, 3, 63, 25, 63, 4, 2, 3, 63, 25, 63]
        # the hex form round-trips (six zero bits appended, as the log has them)
        assert [sm.SbasMessage(0, False, 0, 0, True, m).hex for m in msgs] == texts
    tows = [t for t, p, _ in rows if p == 129]
    assert np.all(np.diff(tows) == 1000)  # one message a second


def test_a_flipped_bit_fails_the_crc():
    msgs, _ = _prn(129)
    for k in (0, 9, 100, 225, 249):
        bad = msgs[1].copy()
        bad[k] ^= 1
        assert not sm.parse_message(bad)[2], k


def test_message_bits_rebuilds_the_logged_messages_crc_included():
    msgs, _ = _prn(137)
    for m in msgs:
        preamble, mtype, _ = sm.parse_message(m)
        rebuilt = sm.message_bits(sm.PREAMBLES.index(preamble), mtype, m[14:226])
        np.testing.assert_array_equal(rebuilt, m)


def test_the_code_is_not_inverted_and_g1_comes_first():
    """All-zero bits give all +1 symbols (no inverted generator, unlike I/NAV); a single 1
    gives the generators' taps, G1's symbol first: 171 = 1111001, 133 = 1011011 (octal)."""
    zeros = np.zeros((1, sm.MESSAGE_BITS), np.uint8)
    assert np.all(sm.encode_messages(zeros) == 1)
    impulse = zeros.copy()
    impulse[0, 0] = 1
    c = (1 - sm.encode_messages(impulse)[:14]) // 2
    assert c[0::2].tolist() == [1, 1, 1, 1, 0, 0, 1] and c[1::2].tolist() == [1, 0, 1, 1, 0, 1, 1]


def _noisy(symbols: np.ndarray, es_n0_db: float, rng: np.random.Generator) -> np.ndarray:
    amplitude = np.sqrt(2 * 10 ** (es_n0_db / 10))  # unit noise: Es/N0 = A^2 / 2
    return amplitude * symbols + rng.standard_normal(symbols.size)


@pytest.mark.parametrize("inverted", [False, True])
@pytest.mark.parametrize("skip", [0, 1, 301])
def test_logged_messages_encoded_then_decoded_with_noise_come_back(inverted, skip):
    """Twelve real messages in a row, encoded, cut ``skip`` symbols into the first (an odd
    skip: the stream starts on a G2 symbol), inverted or not, at Eb/N0 = 4 dB (Es/N0 1 dB,
    an uncoded symbol error rate of 8 %): the eleven whole messages after the cut come back
    bit for bit, each at its first symbol, with its polarity."""
    msgs, _ = _prn(129)
    symbols = sm.encode_messages(msgs).astype(float)[skip:] * (-1 if inverted else 1)
    rng = np.random.default_rng(39 + skip)
    found, failures = sm.find_messages(_noisy(symbols, 1.0, rng))
    assert failures == []
    first = 1 if skip else 0
    assert len(found) == 12 - first
    for k, m in enumerate(found):
        np.testing.assert_array_equal(m.bits, msgs[first + k])
        assert m.crc_ok and m.inverted == inverted
        assert m.start == (first + k) * sm.MESSAGE_SYMBOLS - skip
        assert m.preamble == [0xC6, 0x53, 0x9A][(first + k) % 3]


def test_a_corrupted_message_on_the_grid_is_reported_not_used():
    msgs, _ = _prn(137)
    symbols = sm.encode_messages(msgs[:6]).astype(float) * 4.0
    symbols[3 * sm.MESSAGE_SYMBOLS + 200 : 3 * sm.MESSAGE_SYMBOLS + 260] *= -1  # 60 symbols of message 3
    found, failures = sm.find_messages(symbols)
    assert [m.crc_ok for m in found] == [True, True, True, False, True, True]
    assert len(failures) == 1 and f"symbol {3 * sm.MESSAGE_SYMBOLS}" in failures[0] and "CRC-24Q" in failures[0]


def test_noise_alone_gives_no_message():
    found, failures = sm.find_messages(np.random.default_rng(5).standard_normal(3000))
    assert found == [] and failures == []


def test_too_few_symbols_are_refused_in_one_line():
    with pytest.raises(ConfigError) as exc:
        sm.find_messages(np.ones(499))
    assert "500 symbols" in str(exc.value) and "got 499" in str(exc.value)
    assert len(str(exc.value).splitlines()) == 1
    with pytest.raises(ConfigError, match="symbols"):
        sm.find_messages(np.ones((2, 600)))
    with pytest.raises(ConfigError, match="data"):
        sm.message_bits(0, 1, np.zeros(211, int))
    with pytest.raises(ConfigError, match="preamble_index"):
        sm.message_bits(3, 1, np.zeros(212, int))


def test_viterbi_from_an_unknown_state_decodes_a_window_of_a_stream():
    """`fec.viterbi_decode(start_known=False)`: a window cut after 100 bits of a random
    stream decodes whole; started at state 0 its first bits may not."""
    rng = np.random.default_rng(8)
    bits = rng.integers(0, 2, 400).astype(np.uint8)
    coded = 1.0 - 2.0 * fec.conv_encode(bits, sm.GENERATORS, sm.INVERTED)
    window = coded[200:]
    out = fec.viterbi_decode(window, sm.GENERATORS, sm.INVERTED, terminated=False, start_known=False)
    np.testing.assert_array_equal(out, bits[100:])


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    first_preamble=st.integers(0, 2),
    skip=st.integers(0, sm.MESSAGE_SYMBOLS - 1),
    inverted=st.booleans(),
)
def test_random_payloads_round_trip(seed, first_preamble, skip, inverted):
    """Three messages of random types and 212-bit payloads (the preambles in turn), cut
    ``skip`` symbols in and maybe inverted, noise-free: the whole messages after the cut
    come back exactly."""
    rng = np.random.default_rng(seed)
    msgs = np.array(
        [
            sm.message_bits((first_preamble + k) % 3, int(rng.integers(0, 64)), rng.integers(0, 2, sm.DATA_BITS))
            for k in range(3)
        ]
    )
    stream = sm.sbas_symbols(msgs, skip, 3 * sm.MESSAGE_SYMBOLS - skip).astype(float) * (-1 if inverted else 1)
    found, failures = sm.find_messages(stream)
    first = 1 if skip else 0
    assert failures == [] and len(found) == 3 - first
    for k, m in enumerate(found):
        np.testing.assert_array_equal(m.bits, msgs[first + k])
        assert m.crc_ok and m.inverted == inverted and m.start == (first + k) * sm.MESSAGE_SYMBOLS - skip


@pytest.mark.parametrize("window_bits", [1, 50, 700])
def test_decoding_window_by_window_gives_the_whole_streams_decoding(window_bits):
    """`decode_stream` with small windows (96-bit margins) against one Viterbi decoding of
    the whole noisy stream (Es/N0 1 dB): the same bits, and those are the bits sent but
    for the decoder's own errors, which are rare at this level."""
    rng = np.random.default_rng(window_bits)
    bits = rng.integers(0, 2, 3000).astype(np.uint8)
    coded = 1.0 - 2.0 * fec.conv_encode(bits, sm.GENERATORS, sm.INVERTED)
    y = _noisy(coded, 1.0, rng)[40:]  # a stream cut 20 bits in
    whole = fec.viterbi_decode(y, sm.GENERATORS, sm.INVERTED, terminated=False, start_known=False)
    windowed = sm.decode_stream(y, window_bits=window_bits)
    np.testing.assert_array_equal(windowed, whole)
    assert np.mean(whole != bits[20:]) < 0.01
    with pytest.raises(ConfigError, match="even"):
        sm.decode_stream(y[1:])


def test_a_stream_longer_than_a_window_decodes_every_message():
    """All 24 logged messages in one stream (PRN 129's twelve, then 137's: the preambles run
    on in turn), 12000 symbols, decoded in windows of 4096 bits: all come back."""
    msgs = np.concatenate([_prn(129)[0], _prn(137)[0]])
    y = _noisy(sm.encode_messages(msgs).astype(float), 1.0, np.random.default_rng(24))
    assert y.size // 2 > sm.WINDOW_BITS + 2 * sm.MARGIN_BITS
    found, failures = sm.find_messages(y)
    assert failures == [] and len(found) == 24
    np.testing.assert_array_equal(np.array([m.bits for m in found]), msgs)
