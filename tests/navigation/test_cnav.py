"""GPS CNAV on L2C (`gnssframework.navigation.cnav`).

Truth: five real CNAV messages of PRN 1 and the values GNSSTk decodes from them
(tests/data/gnsstk_cnav_gps_l2_prn1.hex, copied from the GNSSTk test data, SGL-UT/gnsstk,
LGPL 3.0; see its comments): their CRC-24Q, header and ephemeris. The LNAV user algorithm
(`ephemeris.satellite_state`) of a broadcast GPS record for the ephemeris of messages 10
and 11 that carry it. The encoder-decoder round trip for the FEC, the pairing and the
polarity.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssframework.errors import ConfigError
from gnssframework.navigation import cnav
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnsstk_cnav import gnsstk_messages

DATA = Path(__file__).parents[1] / "data"


def test_gnsstks_real_messages_pass_the_crc_and_parse_as_gnsstk_says():
    msgs = gnsstk_messages()
    assert [k for k, _, _ in msgs] == [10, 11, 30, 32, 33]
    for kind, ct, bits in msgs:
        m = cnav.message_from_bits(bits)
        assert m.crc_ok and (bits[:8] == cnav.PREAMBLE).all()
        assert (m.prn, m.msg_type, m.alert) == (1, kind, False)
        assert m.hex == "".join(f"{int(''.join(map(str, q)), 2):X}" for q in bits.reshape(-1, 4))
        if kind != 33:  # GNSSTk dates message 33 as message 30 (see the data file's comments)
            assert m.tow_s == ct  # the TOW count dates the next message: 12 s after this one's start
    assert cnav.message_from_bits(msgs[-1][2]).tow_s == 86484.0


def test_a_flipped_bit_fails_the_crc():
    bits = gnsstk_messages()[0][2]
    for k in (0, 40, 150, 299):
        b = bits.copy()
        b[k] ^= 1
        assert not cnav.message_from_bits(b).crc_ok


def test_messages_10_and_11_give_gnsstks_ephemeris():
    msgs = {k: cnav.message_from_bits(b) for k, _, b in gnsstk_messages()}
    e = cnav.parse_ephemeris(msgs[10], msgs[11])
    pi = np.pi
    assert (e.prn, e.wn, e.toe_s, e.top_s) == (1, 2060, 91800.0, 21600.0)
    assert e.health_l1_l2_l5 == 0b001  # L5 flagged, L1 and L2 healthy (GNSSTk's health objects)
    expected = {
        cnav.A_REF_M + e.delta_a_m: 26560186.60546875,
        e.a_dot_m_s: -0.0058078765869140625,
        e.m0_sc * pi: -0.99809220403226028839,
        e.delta_n0_sc_s * pi: 3.93284239e-09,
        e.delta_n0_dot_sc_s2 * pi: 3.99142951e-14,
        e.e: 0.0090113340411335229874,
        e.omega0_sc * pi: 2.6792122624362644245,
        e.i0_sc * pi: 0.97640098663170327153,
        e.omega_sc * pi: 0.72637343022039169149,
        (cnav.OMEGA_DOT_REF_SC_S + e.delta_omega_dot_sc_s) * pi: -7.71776500e-09,
        e.i0_dot_sc_s * pi: 1.73221501e-10,
        e.delta_omega_dot_sc_s * pi: 4.5037590282126179865e-10,
        e.cuc_rad: -6.6496431827545166016e-06,
        e.cus_rad: 1.1029653251171112061e-05,
        e.crc_m: 175.46484375,
        e.crs_m: -126.9296875,
        e.cic_rad: 1.62050128e-07,
        e.cis_rad: 1.1455267667770385742e-07,
    }
    for got, want in expected.items():
        assert got == pytest.approx(want, rel=1e-8)  # GNSSTk prints some to 9 digits


def test_the_clock_of_messages_30_to_37_and_the_utc_of_33_are_gnsstks():
    msgs = {k: cnav.message_from_bits(b) for k, _, b in gnsstk_messages()}
    for kind in (30, 32, 33):  # GNSSTk reads the clock from 30; 32 and 33 send the same one
        c = cnav.parse_clock(msgs[kind])
        assert (c.prn, c.msg_type, c.top_s, c.toc_s) == (1, kind, 21600.0, 91800.0)
        assert (c.ura_ned0_index, c.ura_ned1_index, c.ura_ned2_index) == (-5, 1, 7)
        assert c.af0_s == pytest.approx(-5.5062846513465046883e-05, rel=1e-12)
        assert c.af1_s_s == pytest.approx(-1.01287867e-11, rel=1e-8) and c.af2_s_s2 == 0.0
    u = cnav.parse_utc(msgs[33])
    assert u.a0_s == pytest.approx(1.9790604711e-09, rel=1e-10) and u.a1_s_s == pytest.approx(
        7.5495165675e-15, rel=1e-10
    )
    assert (u.a2_s_s2, u.delta_t_ls_s, u.tot_s, u.wn_ot, u.wn_lsf, u.dn, u.delta_t_lsf_s) == (
        0.0,
        18,
        21600.0,
        2060,
        1929,
        7,
        18,
    )
    with pytest.raises(ConfigError, match=r"msg: PRN 1: message type 10 carries none \(types 30-37 do\)"):
        cnav.parse_clock(msgs[10])
    with pytest.raises(ConfigError, match=r"msg: PRN 1: message type 30 carries none \(type 33 does\)"):
        cnav.parse_utc(msgs[30])


def test_parse_ephemeris_refuses_the_wrong_messages_in_one_line():
    msgs = {k: cnav.message_from_bits(b) for k, _, b in gnsstk_messages()}
    with pytest.raises(ConfigError, match=r"msg11.*PRN 1: expected message type 11, got 30"):
        cnav.parse_ephemeris(msgs[10], msgs[30])
    bad = msgs[11].bits.copy()
    bad[100] ^= 1
    with pytest.raises(ConfigError, match="PRN 1: message type 11 failed its CRC-24Q"):
        cnav.parse_ephemeris(msgs[10], cnav.message_from_bits(bad))


def test_the_stream_decodes_from_any_symbol_and_either_polarity():
    rows = np.array([b for _, _, b in gnsstk_messages()])
    symbols = cnav.encode_cnav(rows).astype(float)
    assert symbols.size == 3000
    for cut in (0, 1, 2, 37, 600):
        for sign in (1.0, -1.0):
            d = cnav.decode_cnav(sign * symbols[cut:])
            assert d.pair_offset == cut % 2 and d.inverted == (sign < 0)
            first = -(-cut // 600)  # the first message whose symbols all arrived
            assert [m.msg_type for m in d.messages] == [10, 11, 30, 32, 33][first:]
            assert [m.start for m in d.messages] == [600 * k - cut for k in range(first, 5)]
            assert all(m.crc_ok for m in d.messages) and not d.failures
            assert all((m.bits == rows[first + j]).all() for j, m in enumerate(d.messages))


def test_a_stream_without_a_message_finds_none():
    rng = np.random.default_rng(3)
    d = cnav.decode_cnav(rng.standard_normal(1500))
    assert d.messages == [] and d.pair_offset is None
    assert cnav.decode_cnav(np.ones(100)).messages == []  # shorter than a message


def test_soft_symbols_in_noise_decode_where_hard_ones_would_fail():
    # Symbols of amplitude 1 in noise of sigma 0.7: Es/N0 = 1 / (2 sigma^2), about 0 dB (Eb/N0
    # about 3 dB at rate 1/2), a symbol in fifteen or so comes wrong, which the Viterbi decoder
    # corrects (coding gain of the K = 7 code: about 5 dB at a bit error rate of 1e-5).
    rng = np.random.default_rng(4)
    rows = np.array([cnav.message_bits(5, t, 100 + k, rng.integers(0, 2, 238)) for k, t in enumerate((10, 11, 0, 30))])
    clean = cnav.encode_cnav(rows).astype(float)
    noisy = clean + rng.standard_normal(clean.size) * 0.7
    assert np.mean(np.sign(noisy) != clean) > 0.05
    d = cnav.decode_cnav(noisy)
    assert [m.msg_type for m in d.messages] == [10, 11, 0, 30] and all(m.crc_ok for m in d.messages)


@settings(max_examples=25, deadline=None)
@given(
    prn=st.integers(1, 63),
    types=st.lists(st.integers(0, 63), min_size=2, max_size=3),
    tow=st.integers(0, 100_700),
    seed=st.integers(0, 2**32 - 1),
    cut=st.integers(0, 599),
    sign=st.sampled_from((1.0, -1.0)),
    scale=st.floats(0.01, 1e4),
)
def test_round_trip_of_random_messages(prn, types, tow, seed, cut, sign, scale):
    rng = np.random.default_rng(seed)
    payloads = rng.integers(0, 2, (len(types), 238))
    alerts = rng.integers(0, 2, len(types)).astype(bool)
    rows = np.array(
        [cnav.message_bits(prn, t, tow + k, p, a) for k, (t, p, a) in enumerate(zip(types, payloads, alerts))]
    )
    symbols = sign * scale * cnav.encode_cnav(rows)
    d = cnav.decode_cnav(symbols[cut:])
    first = 1 if cut else 0
    got = [(m.prn, m.msg_type, m.tow_count, m.alert, m.crc_ok, m.start) for m in d.messages]
    want = [(prn, types[k], tow + k, bool(alerts[k]), True, 600 * k - cut) for k in range(first, len(types))]
    assert got == want
    assert all((m.bits[38:276] == payloads[first + j]).all() for j, m in enumerate(d.messages))


def _on_grid(nav):
    """The records whose toe is on CNAV's 300 s grid (LNAV's is 16 s)."""
    return np.flatnonzero(nav.elements["Toe"] % 300 == 0)


def test_cnav_symbols_cycle_types_10_11_30_and_date_each_message():
    nav = read_rinex_nav(DATA / "07590920.05n")
    rec = nav.subset(_on_grid(nav)[:1])
    prn = int(rec.sv[0][1:])
    tow = float(rec.elements["Toe"][0]) + 7.3
    symbols, into = cnav.cnav_symbols(prn, tow, 2400, rec, wn=1316)
    assert symbols.dtype == np.int8 and symbols.size == 2400
    assert 0 <= into < 0.02
    d = cnav.decode_cnav(symbols)
    first_symbol_tow = tow - into
    for m in d.messages:
        assert m.crc_ok and m.prn == prn
        assert m.tow_s == pytest.approx(first_symbol_tow + m.start / cnav.SYMBOL_RATE_HZ, abs=1e-9)
        assert m.msg_type == (10, 11, 30)[int(round(m.tow_s / 12)) % 3]


def test_the_ephemeris_of_messages_10_and_11_places_the_satellite_where_lnav_does():
    # The CNAV scale factors are finer than or equal to LNAV's except the 300 s toe grid
    # (the record's toe is on it): the positions differ by the rounding of M0, omega, Omega0
    # and i0 at 2^-32 semicircles (26,560 km x 7.3e-10 rad: 2 cm each) and of the rest.
    nav = read_rinex_nav(DATA / "07590920.05n")
    grid = _on_grid(nav)
    assert grid.size >= 6
    for k in grid[:6]:
        rec = nav.subset(np.array([k]))
        prn = int(rec.sv[0][1:])
        p10, p11 = cnav.ephemeris_payloads(rec, 1316)
        toe = float(rec.elements["Toe"][0])
        count = int(toe / 6) + 2
        m10 = cnav.message_from_bits(cnav.message_bits(prn, 10, count, p10))
        m11 = cnav.message_from_bits(cnav.message_bits(prn, 11, count + 2, p11))
        eph = cnav.parse_ephemeris(m10, m11)
        t = toe + np.linspace(-7200, 7200, 13)
        lnav = satellite_state(rec, t[:, None]).position_m[:, 0]
        assert np.max(np.linalg.norm(cnav.cnav_position(eph, t) - lnav, axis=-1)) < 0.05


def test_a_non_zero_adot_moves_the_radius_by_adot_times_tk():
    msgs = {k: cnav.message_from_bits(b) for k, _, b in gnsstk_messages()}
    e = cnav.parse_ephemeris(msgs[10], msgs[11])
    t = e.toe_s + 3600.0
    from dataclasses import replace

    r1 = np.linalg.norm(cnav.cnav_position(e, t))
    r0 = np.linalg.norm(cnav.cnav_position(replace(e, a_dot_m_s=0.0), t))
    # r = A_k (1 - e cos E) + ...: the radius moves by Adot tk (1 - e cos E), within e of Adot tk
    assert r1 - r0 == pytest.approx(e.a_dot_m_s * 3600.0, rel=0.02)


@pytest.mark.parametrize(
    "call, why",
    [
        (lambda: cnav.decode_cnav(np.ones((2, 700)), prn=7), r"symbols.*PRN 7's CM stream is 1-D"),
        (lambda: cnav.decode_cnav(np.array([1.0, np.nan] * 400), prn=9), "symbols.*finite real"),
        (lambda: cnav.message_bits(64, 10, 0), "prn.*1-63, got 64"),
        (lambda: cnav.message_bits(1, 10, 100_800), "tow_count"),
        (lambda: cnav.message_bits(1, 10, 0, np.zeros(10)), "payload.*238 bits"),
        (lambda: cnav.encode_cnav(np.zeros((1, 299))), r"messages.*\(n, 300\)"),
    ],
)
def test_bad_input_is_refused_in_one_line(call, why):
    with pytest.raises(ConfigError, match=why) as err:
        call()
    assert "\n" not in str(err.value)
