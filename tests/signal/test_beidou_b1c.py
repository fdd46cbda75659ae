"""BeiDou B1C (BDS-SIS-ICD-B1C-1.0): the Weil codes' construction and correlation
properties, the description and registration, and PocketSDR's 4 MHz L1 recording, where
the peer finds B1C PRN 21 22 27 29 30 36 39 40 45 46 (../shared/data/README.md)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition.assisted import SearchWindow, window_search
from gnssframework.receiver.frontend import open_recording
from gnssframework.signal.beidou_b1c import BEIDOU_B1C
from gnssframework.signal.beidou_b1c_codes import (
    b1c_data_code,
    b1c_pilot_code,
    b1c_pilot_secondary_code,
    legendre_sequence,
)

DATA = Path(__file__).parents[1] / "data"


def test_the_legendre_sequence_is_the_quadratic_residue_indicator():
    """Euler's criterion, independent of the squaring that builds it: k is a non-zero
    residue mod the prime N iff k^((N-1)/2) = 1 mod N; (N-1)/2 of them."""
    for n in (10243, 3607):
        seq = legendre_sequence(n)
        euler = np.array([pow(k, (n - 1) // 2, n) == 1 for k in range(n)], np.uint8)
        euler[0] = 0
        np.testing.assert_array_equal(seq, euler)
        assert seq.sum() == (n - 1) // 2


def test_weil_codes_are_balanced_and_nearly_orthogonal():
    """Weil codes of length N = 10243 have even periodic correlations bounded near 2 sqrt(N);
    truncated to 10230 chips the codes of PRN 1-63 (data and pilot) stay far below the peak:
    every cross-correlation and off-peak autocorrelation of 16 codes under 0.045 of it."""
    codes = np.array([f(p) for f in (b1c_data_code, b1c_pilot_code) for p in (1, 9, 19, 21, 30, 36, 45, 63)], float)
    spectra = np.fft.fft(codes, n=2 * 10230, axis=1)  # aperiodic (truncated codes)
    peak = 10230.0
    for i in range(len(codes)):
        cc = np.fft.ifft(spectra[i] * spectra.conj(), axis=1).real
        assert abs(cc[i, 0] - peak) < 1e-6
        cc[i, 0] = 0.0
        assert np.abs(cc).max() < 0.045 * peak
    assert len(b1c_pilot_secondary_code(30)) == 1800 and set(b1c_pilot_secondary_code(30)) == {-1, 1}


def test_the_description_and_its_registration():
    assert registry.signal_spec("beidou-b1c") is BEIDOU_B1C
    assert BEIDOU_B1C.code_period_s == pytest.approx(0.01) and BEIDOU_B1C.subchips_per_chip == 2
    assert BEIDOU_B1C.tracked.name == "pilot" and BEIDOU_B1C.data.symbol_period_s == 0.01
    assert BEIDOU_B1C.rinex_satellite(30) == "C30"
    with pytest.raises(ConfigError, match="1-63"):
        BEIDOU_B1C.code(64)


def test_pocketsdrs_b1c_satellites_are_found_on_pilot_and_data_at_one_code_epoch():
    """The pilot search finds PocketSDR's satellites (27, one of its two weakest, and three strong ones:
    a subset, to keep the test short) and not PRN 1, which it does not find; the data code
    (its own table of the ICD), searched 40 samples either side of the pilot's code phase,
    peaks on the pilot's very sample: the two components share one code epoch."""
    fs = 4e6
    x = open_recording(
        DATA / "pocketsdr_L1_4MHz_IQ_100ms.bin", format="ci8", sample_rate_hz=fs, if_hz=0.0, q_sign=-1
    ).read(0, 80_000)
    acq = registry.create("acquisition", "pcps", noncoherent=1, doppler_max_hz=4000.0, xcorr_margin_db=None)
    found = {r.prn: r for r in acq.acquire(x, fs, 0.0, (27, 30, 36, 45, 1), signal=BEIDOU_B1C)}
    assert {p for p, r in found.items() if r.detected} == {27, 30, 36, 45}
    data_only = replace(BEIDOU_B1C, name="beidou-b1c-data", components=(BEIDOU_B1C.components[1],))
    for prn in (30, 36, 45):
        r = found[prn]
        d = window_search(
            x,
            fs,
            0.0,
            prn,
            SearchWindow(r.code_phase_samples, r.doppler_hz, 40.0, 50.0),
            coherent_ms=1,
            noncoherent=2,
            alternate=False,
            signal=data_only,
        )
        assert d.detected and d.code_phase_samples == r.code_phase_samples, prn
