"""The signal description against independent truth: the Gold-code properties of the C/A
codes it hands out, the BOC(1,1) waveform and autocorrelation of its closed form (Betz,
*Engineering Satellite-Based Navigation and Timing*, 2016, ch. 12), CBOC's unit power
(Galileo OS SIS ICD, sec. 2.3.3: weights sqrt(10/11), sqrt(1/11))."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.spec import BPSK, Component, SignalSpec, Subcarrier

BOC11 = Subcarrier("boc", 1.0, 1.0)
CBOC = Subcarrier("cboc", 1.0, 1.0, 6.0, (np.sqrt(10 / 11), np.sqrt(1 / 11)))


def _random_code(seed: int, length: int = 4092) -> np.ndarray:
    return (1 - 2 * np.random.default_rng(seed).integers(0, 2, length)).astype(np.int8)


def _toy(sub: Subcarrier, length: int = 4092, sign: float = 1.0) -> SignalSpec:
    code = _random_code(1, length)
    return SignalSpec(
        "toy",
        "X",
        "1X",
        1575.42e6,
        1.023e6,
        length,
        (1,),
        (Component("pilot", lambda prn: code, subcarrier_sign=sign),),
        sub,
    )


def _acf_by_integration(sub: Subcarrier, tau: np.ndarray, sign: float = 1.0, per_chip: int = 24_000) -> np.ndarray:
    """R(tau) = int p(t) p(t + tau) dt / int p^2 over one chip pulse p (zero outside [0, 1)),
    by a midpoint rule on `per_chip` points of the waveform itself."""
    t = (np.arange(per_chip) + 0.5) / per_chip
    p = sub.waveform(t, sign)
    out = []
    for lag in tau:
        shifted = t + abs(lag)
        inside = shifted < 1.0
        out.append(np.sum(p[inside] * sub.waveform(shifted[inside], sign)) / np.sum(p * p))
    return np.array(out)


def test_ca_codes_through_the_spec_are_balanced_gold_codes():
    codes = np.array([GPS_L1CA.code(p) for p in GPS_L1CA.prns], float)
    assert codes.shape == (32, 1023)
    # A balanced Gold code has 512 ones and 511 zeros: sum -1 with logic 1 -> -1.
    assert set(codes.sum(axis=1)) == {-1.0}
    spectra = np.fft.fft(codes, axis=1)
    auto = np.rint(np.fft.ifft(spectra * spectra.conj(), axis=1).real).astype(int)
    assert (auto[:, 0] == 1023).all() and set(auto[:, 1:].ravel()) == {-65, -1, 63}


def test_bpsk_spreading_table_is_the_code_and_its_acf_the_triangle():
    assert GPS_L1CA.subchips_per_chip == 1 and GPS_L1CA.is_bpsk
    np.testing.assert_array_equal(GPS_L1CA.spreading_table(7), GPS_L1CA.code(7))
    tau = np.linspace(-1.5, 1.5, 61)
    np.testing.assert_allclose(GPS_L1CA.autocorrelation(tau), np.maximum(0, 1 - np.abs(tau)), atol=1e-15)


@pytest.mark.parametrize("sub, sign", [(BOC11, 1.0), (Subcarrier("boc", 10.0, 5.0), 1.0), (CBOC, 1.0), (CBOC, -1.0)])
def test_spreading_table_is_code_times_the_subcarrier_waveform(sub, sign):
    spec = _toy(sub, sign=sign)
    table = spec.spreading_table(1)
    assert table.size == spec.code_length_chips * sub.subchips_per_chip
    x = np.random.default_rng(2).uniform(-3 * 4092, 3 * 4092, 20_000)
    code = spec.code(1).astype(float)
    expected = code[np.floor(x).astype(int) % 4092] * sub.waveform(x, sign)
    np.testing.assert_allclose(spec.spreading_at(table, x), expected, rtol=0, atol=1e-12)


def test_boc11_pulse_and_autocorrelation_against_the_closed_form():
    assert BOC11.subchips_per_chip == 2
    np.testing.assert_array_equal(BOC11.waveform(np.array([0.1, 0.4, 0.6, 0.9, 1.1, 1.6])), [1, 1, -1, -1, 1, -1])
    tau = np.linspace(-1.2, 1.2, 49)
    a = np.abs(tau)
    closed = np.where(a <= 0.5, 1 - 3 * a, np.where(a <= 1, a - 1, 0.0))  # Betz 2016, ch. 12
    np.testing.assert_allclose(BOC11.autocorrelation(tau), closed, atol=1e-12)
    np.testing.assert_allclose(_acf_by_integration(BOC11, tau), closed, atol=1e-4)
    np.testing.assert_allclose(BOC11.autocorrelation([0.0, 0.5, -0.5, 1 / 3]), [1.0, -0.5, -0.5, 0.0], atol=1e-12)


@pytest.mark.parametrize("sub, sign", [(Subcarrier("boc", 10.0, 5.0), 1.0), (CBOC, 1.0), (CBOC, -1.0)])
def test_triangle_train_autocorrelation_equals_the_integral_of_the_waveform(sub, sign):
    tau = np.linspace(0, 1.1, 67)
    np.testing.assert_allclose(sub.autocorrelation(tau, sign), _acf_by_integration(sub, tau, sign), atol=2e-4)


def test_random_code_acf_of_the_sub_chip_table_matches_the_pulse_acf():
    """A long random code's circular autocorrelation, at sub-chip lags, is the pulse's
    (the code's own sidelobes are O(1/sqrt(L)))."""
    spec = _toy(BOC11, length=4092)
    table = spec.spreading_table(1)
    f = np.fft.fft(table)
    acf = np.fft.ifft(f * f.conj()).real / np.dot(table, table)
    lags = np.arange(5) / 2  # 0, 0.5, 1, 1.5, 2 chips
    np.testing.assert_allclose(acf[(lags * 2).astype(int)], BOC11.autocorrelation(lags), atol=5 / np.sqrt(4092))


def test_cboc_weights_give_unit_power_and_12_pieces():
    w1, w2 = CBOC.weights
    assert w1**2 + w2**2 == pytest.approx(1.0, abs=1e-15)
    assert CBOC.subchips_per_chip == 12
    for sign in (1.0, -1.0):
        assert np.mean(CBOC.chip_pulse(sign) ** 2) == pytest.approx(1.0, abs=1e-12)  # the cross term averages to 0


def test_a_subcarrier_that_does_not_divide_a_chip_is_refused():
    with pytest.raises(ConfigError, match="subcarrier"):
        _ = Subcarrier("boc", 0.75, 1.0).subchips_per_chip
    assert BPSK.subchips_per_chip == 1


def test_a_description_that_contradicts_itself_is_refused_naming_the_field():
    code = _random_code(3, 1023)
    with pytest.raises(ConfigError, match="symbol_period_s.*whole number of code periods"):
        SignalSpec(
            "bad",
            "X",
            "1X",
            1575.42e6,
            1.023e6,
            1023,
            (1,),
            (Component("data", lambda prn: code, symbol_period_s=0.0105),),
        )
    short = SignalSpec("short", "X", "1X", 1575.42e6, 1.023e6, 2046, (1,), (Component("data", lambda prn: code),))
    with pytest.raises(ConfigError, match="gave \\(1023,\\) chips for PRN 1, the description says 2046"):
        short.code(1)
    with pytest.raises(ConfigError, match="chip_rate_hz"):
        SignalSpec("bad", "X", "1X", 1575.42e6, -1.0, 1023, (1,), (Component("data", lambda prn: code),))
