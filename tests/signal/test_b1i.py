"""BeiDou B1I (BDS-SIS-ICD-B1I 3.0): the codes against the register properties the ICD
states and an independent generator's chips, the two descriptions, and a generated D1
satellite acquired through the generic search.

Truths: G1 and G2 are maximal 11-stage registers (period 2047, sec. 5.1.1); with the
phase assignments of Table 5-1 the untruncated codes are a Gold family, whose periodic
auto- (off-peak) and cross-correlations take only the three values -1, -65 and 63
(2^6 + 1 = 65 for 11 stages), which fails for a wrong feedback, start or stage; the first
and last 32 chips of PRN 1, 6, 37, 38, 58 and 63 as GNSS-DSP-tools (P. Monta, MIT;
``gnsstools/beidou/b1i.py``, its own register code) generates them, logic 1 written 1."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples
from gnssframework.signal.beidou_b1i import B1I_FREQ_HZ, BEIDOU_B1I, BEIDOU_B1I_GEO
from gnssframework.signal.beidou_b1i_codes import (
    B1I_G2_PHASE,
    B1I_NEUMANN_HOFFMAN,
    B1I_START,
    _G1_FEEDBACK,
    _G2_FEEDBACK,
    beidou_b1i_code,
)
from gnssframework.signal.codes import bits_to_chips, register_states
from gnssframework.signal.gps_l5_codes import L5Q_NEUMAN_HOFFMAN

#: GNSS-DSP-tools' B1I chips (logic values): the first and the last 32 of a PRN.
GNSSTOOLS_FIRST_LAST_32 = {
    1: ("01100101101101101100110111010100", "10100011000101000111010000110101"),
    6: ("01101010010001000000100111000101", "11100000100001010000111111000111"),
    37: ("10101010101000110101100010011010", "11010111110101110101111100101111"),
    38: ("11011111101101101010110000100000", "11110010110110011101100100101000"),
    58: ("11110111111100100110011000100101", "11010100010010100001101001010010"),
    63: ("11110001111011010010000110110001", "00001110100110111100111110000010"),
}


def _logic(chips: np.ndarray) -> str:
    return "".join("1" if c < 0 else "0" for c in chips)


def test_g1_and_g2_are_maximal_registers():
    for feedback in (_G1_FEEDBACK, _G2_FEEDBACK):
        states = register_states(feedback, 2 * 2047 + 1, 11, B1I_START)
        back = [i for i in range(1, states.shape[0]) if tuple(states[i]) == B1I_START]
        assert back[0] == 2047 and back[1] == 2 * 2047


def test_the_untruncated_codes_are_a_gold_family():
    g1 = register_states(_G1_FEEDBACK, 2047, 11, B1I_START)
    g2 = register_states(_G2_FEEDBACK, 2047, 11, B1I_START)
    codes = np.array(
        [
            bits_to_chips(g1[:, 10] ^ np.bitwise_xor.reduce(g2[:, [s - 1 for s in B1I_G2_PHASE[p]]], axis=1))
            for p in range(1, 64)
        ],
        float,
    )
    spectra = np.fft.fft(codes, axis=1)
    values: set[int] = set()
    for i in range(63):
        corr = np.rint(np.fft.ifft(spectra[i] * np.conj(spectra), axis=1).real).astype(int)
        assert corr[i, 0] == 2047
        corr[i, 0] = -1  # the peak
        values |= set(np.unique(corr).tolist())
    assert values == {-65, -1, 63}
    for p in range(1, 64):  # the ICD's codes are these, less their last chip
        np.testing.assert_array_equal(beidou_b1i_code(p), codes[p - 1, :2046].astype(np.int8))


@pytest.mark.parametrize("prn", sorted(GNSSTOOLS_FIRST_LAST_32))
def test_the_codes_begin_and_end_as_an_independent_generator(prn):
    code = beidou_b1i_code(prn)
    assert code.shape == (2046,) and code.dtype == np.int8
    assert (_logic(code[:32]), _logic(code[-32:])) == GNSSTOOLS_FIRST_LAST_32[prn]


def test_the_descriptions_hold_the_icds_numbers():
    """1561.098 MHz = 152.6 x 10.23 MHz; 2.046 Mchip/s, 1 ms codes; D1 50 bit/s under NH20
    (the 20-chip code GPS L5 Q5 carries too), GEO 500 bit/s with none; RINEX 2I."""
    assert B1I_FREQ_HZ == pytest.approx(152.6 * 10.23e6)
    assert B1I_NEUMANN_HOFFMAN == tuple(L5Q_NEUMAN_HOFFMAN)
    for spec in (BEIDOU_B1I, BEIDOU_B1I_GEO):
        assert registry.signal_spec(spec.name) is spec
        assert spec.code_period_s == pytest.approx(1e-3) and spec.is_bpsk and spec.rinex_code == "2I"
    assert BEIDOU_B1I.code_periods_per_symbol == 20 and BEIDOU_B1I.overlay_length() == 20
    assert BEIDOU_B1I_GEO.code_periods_per_symbol == 2 and BEIDOU_B1I_GEO.overlay_length() == 0
    assert set(BEIDOU_B1I.prns) | set(BEIDOU_B1I_GEO.prns) == set(range(1, 64))
    assert set(BEIDOU_B1I_GEO.prns) == {1, 2, 3, 4, 5, 59, 60, 61, 62, 63}
    assert BEIDOU_B1I.rinex_satellite(6) == "C06"
    with pytest.raises(ConfigError, match="PRN"):
        BEIDOU_B1I.code(3)  # a GEO satellite: the GEO description's
    with pytest.raises(ConfigError, match="1-63"):
        beidou_b1i_code(64)


def test_a_generated_d1_satellite_is_acquired_at_its_doppler_and_code_phase():
    """45 dB-Hz of PRN 11 with random D1 bits under NH20, complex samples at 8.184 MHz (four
    a chip); the 1 ms search over 4 non-coherent blocks finds it alone among PRN 6-16, its
    code epoch within a sample, and its Doppler (1270 Hz: 230 Hz from the nearest bin)
    within 25 Hz once the overlay's differential detector refines it
    (`fft_search.overlay_doppler`, 41 ms read): a 1 ms block alone resolves hundreds of Hz."""
    fs, prn, doppler_hz, phase_chips = 8.184e6, 11, 1270.0, 1500.3
    sat = SatelliteSignal(
        prn, 45.0, doppler_hz=doppler_hz, code_phase_chips=phase_chips, first_bit_code_period=3, signal=BEIDOU_B1I
    )
    x = synthesize_samples([sat], 0.045, fs, 0.0, np.random.default_rng(4)).astype(np.complex64)
    acq = registry.create("acquisition", "pcps", noncoherent=4, doppler_max_hz=5000.0)
    found = {r.prn: r for r in acq.acquire(x, fs, 0.0, tuple(range(6, 17)), signal=BEIDOU_B1I) if r.detected}
    assert set(found) == {prn}
    expected = (2046 - phase_chips) / BEIDOU_B1I.chip_rate_hz * fs
    assert abs(found[prn].code_phase_samples - expected) <= 1.0
    assert abs(found[prn].doppler_hz - doppler_hz) <= 25.0
    short = acq.acquire(x[: int(0.004 * fs)], fs, 0.0, (prn,), signal=BEIDOU_B1I)[0]  # 4 ms: no refinement
    assert short.detected and abs(short.doppler_hz - doppler_hz) <= 500.0


def test_the_overlay_refinement_reads_the_residual_frequency_within_half_a_khz():
    """`overlay_doppler` from a start 400 Hz off (beyond a two-quadrant loop's 250 Hz) on a
    generated B1I satellite: within 10 Hz of the truth; None with fewer periods than it needs
    (41: two NH20 periods and one), and no refinement of a signal without a 1 kHz-class overlay."""
    from gnssframework.receiver.acquisition.fft_search import overlay_doppler, overlay_refine_periods
    from gnssframework.signal.galileo_e5a import GALILEO_E5AQ
    from gnssframework.signal.gps_l1ca import GPS_L1CA

    fs, prn, doppler_hz = 4.2e6, 30, -2310.0
    sat = SatelliteSignal(prn, 40.0, doppler_hz=doppler_hz, first_bit_code_period=0, signal=BEIDOU_B1I)
    x = synthesize_samples([sat], 0.045, fs, 0.0, np.random.default_rng(9)).astype(np.complex64)
    got = overlay_doppler(x, fs, 0.0, prn, 0, doppler_hz + 400.0, BEIDOU_B1I)
    assert got is not None and abs(got - doppler_hz) < 10.0
    assert overlay_doppler(x[: int(0.03 * fs)], fs, 0.0, prn, 0, doppler_hz, BEIDOU_B1I) is None
    assert overlay_refine_periods(BEIDOU_B1I) == 41
    assert overlay_refine_periods(GPS_L1CA) == 0 and overlay_refine_periods(GALILEO_E5AQ) == 0
