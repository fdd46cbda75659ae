"""Galileo E1 OS (E1-B, E1-C): the ICD's memory codes, the descriptions, and the real sky.

Truths the code tables do not contain: the ICD's stated structure (4092 chips, CS25_1 in
binary), the memory codes' design properties (balance, low cross-correlation), and above
all the Galileo satellites of two real PocketSDR recordings (tests/data/README.md), which
PocketSDR's own acquisition lists (../shared/data/README.md: E1-B 3 8 13 15 25 in the
12 MHz file, 7 15 27 30 in the 4 MHz file), found here with the codes of
`gnssframework.signal.galileo_codes` and, independently, with E1-C's different codes at
the same Doppler and code phase.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition import search_grid
from gnssframework.receiver.frontend.recording import open_recording
from gnssframework.signal.galileo_codes import (
    GALILEO_E1C_SECONDARY_CS25,
    galileo_e1b_code,
    galileo_e1c_code,
    hex_to_chips,
)
from gnssframework.signal.galileo_e1 import GALILEO_E1B, GALILEO_E1B_BOC11, GALILEO_E1C, GALILEO_E1C_BOC11
from pilot_tracking import pilot_sync_and_track

DATA = Path(__file__).parents[1] / "data"


def test_the_codes_have_the_icds_length_and_are_distinct_balanced_and_nearly_orthogonal():
    codes = np.array([f(p) for f in (galileo_e1b_code, galileo_e1c_code) for p in range(1, 51)], float)
    assert codes.shape == (100, 4092) and set(np.unique(codes)) == {-1.0, 1.0}
    assert len({c.tobytes() for c in codes}) == 100
    # Memory codes: 2046 ones and 2046 zeros each (measured: every one of the 100).
    assert np.all(codes.sum(axis=1) == 0)
    spectra = np.fft.fft(codes, axis=1).astype(np.complex64)
    worst_cross = worst_side = 0.0
    for i in range(100):
        xc = np.abs(np.fft.ifft(spectra[i] * spectra.conj(), axis=1).real)
        worst_side = max(worst_side, xc[i, 1:].max())
        worst_cross = max(worst_cross, np.delete(xc, i, axis=0).max())
    # Every circular cross-correlation and every off-peak autocorrelation below -24 dB of
    # the 4092 peak (random +-1 codes of this length: about 4.5 sigma = 290 over 4092 lags).
    assert worst_cross < 4092 * 10 ** (-24 / 20) and worst_side < 4092 * 10 ** (-24 / 20)


def test_the_secondary_code_is_the_icds_cs25_and_hex_reads_msb_first():
    # CS25_1 in binary as the ICD gives it (hex 380AD90, first 25 bits); logic 1 -> -1.
    assert GALILEO_E1C_SECONDARY_CS25 == tuple(1 - 2 * int(b) for b in "0011100000001010110110010")
    assert hex_to_chips("A1", 8).tolist() == [-1, 1, -1, 1, 1, 1, 1, -1]
    with pytest.raises(ConfigError, match="hexadecimal digits"):
        hex_to_chips("A1", 9)
    with pytest.raises(ConfigError, match="1-50"):
        galileo_e1b_code(51)


def test_the_descriptions_are_registered_and_say_cboc_or_boc11():
    for spec in (GALILEO_E1B, GALILEO_E1C, GALILEO_E1B_BOC11, GALILEO_E1C_BOC11):
        assert registry.signal_spec(spec.name) is spec
        assert spec.code_period_s == pytest.approx(4e-3) and spec.carrier_freq_hz == 1575.42e6
    assert GALILEO_E1B.symbol_period_s == 4e-3 and GALILEO_E1B.longest_coherent_s == pytest.approx(4e-3)
    assert GALILEO_E1C.tracked.symbol_period_s is None and GALILEO_E1C.longest_coherent_s == pytest.approx(0.1)
    # CBOC(6,1,1/11) chip pulse, ICD sec. 2.3.3: sqrt(10/11) sc_a +- sqrt(1/11) sc_b on 12 sub-chips.
    a, b = math.sqrt(10 / 11), math.sqrt(1 / 11)
    sc_b = np.array([1, -1] * 6)
    sc_a = np.array([1] * 6 + [-1] * 6)
    tab_b = GALILEO_E1B.spreading_table(1)[:12]
    tab_c = GALILEO_E1C.spreading_table(1)[:12]
    assert np.allclose(tab_b, galileo_e1b_code(1)[0] * (a * sc_a + b * sc_b))
    assert np.allclose(tab_c, galileo_e1c_code(1)[0] * (a * sc_a - b * sc_b))
    assert np.array_equal(
        GALILEO_E1C_BOC11.spreading_table(1)[:4], np.repeat(galileo_e1c_code(1)[:2], 2) * np.array([1, -1, 1, -1])
    )
    # BOC(1,1) autocorrelation: 1 - 3|tau| to half a chip (zero at 1/3), -0.5 at 1/2 (Betz 2016).
    tau = np.array([0.0, 1 / 6, 1 / 3, 0.5, 0.75, 1.0])
    assert np.allclose(GALILEO_E1C_BOC11.autocorrelation(tau), [1, 0.5, 0, -0.5, -0.25, 0], atol=1e-12)


def _acquire(
    path: str, fs: float, if_hz: float, q_sign: int, prns: tuple[int, ...], spec, k: int, doppler_max_hz: float = 3500.0
):
    rec = open_recording(
        DATA / path,
        format="ri8" if q_sign == 0 else "ci8",
        sample_rate_hz=fs,
        if_hz=if_hz,
        **({} if q_sign == 0 else {"q_sign": q_sign}),
    )
    acq = registry.create("acquisition", "pcps", noncoherent=k, doppler_max_hz=doppler_max_hz, xcorr_margin_db=None)
    x = rec.read(0, acq.samples_needed(fs, spec))
    return x, {r.prn: r for r in acq.acquire(x, fs, if_hz, prns=prns, signal=spec)}


# A few PRNs PocketSDR does not list and which no weaker satellite of the file holds
# (measured here: the full 50-PRN search of the 12 MHz file also finds E1-B and E1-C
# 2, 5 and 7 at 33-36 dB-Hz, below PocketSDR's 38 dB-Hz list, at one code phase on both
# components: real satellites, docs/receiver/galileo-e1.md).
ABSENT_12MHZ = (1, 4, 9)


@pytest.mark.slow
def test_the_12mhz_recording_shows_pocketsdrs_galileo_satellites_on_e1b_and_e1c():
    """E1-B with 4 ms coherent blocks (one symbol) x 2 non-coherent; E1-C, a different code
    family, must put each satellite at the same Doppler and code phase (one sample); PRNs
    PocketSDR does not list stay below the 1e-3 false-alarm threshold. The Doppler tolerance
    is 1/T = 250 Hz, two bins: a block that straddles a symbol (E1-B) or secondary-chip
    (E1-C) edge has its frequency response skewed by the sign flip (up to 150 Hz apart,
    measured, when the fine search took its blocks from the first sample; from the code
    epoch, as now, 38 Hz over the full search of validation/galileo_e1_acquire.py), and two
    blocks leave the fine search one."""
    listed = (3, 8, 13, 15, 25)
    prns = listed + ABSENT_12MHZ
    x, b = _acquire("pocketsdr_L1_12MHz_I_30ms.bin", 12e6, 3e6, 0, prns, GALILEO_E1B_BOC11, 2, 2500.0)
    _, c = _acquire("pocketsdr_L1_12MHz_I_30ms.bin", 12e6, 3e6, 0, listed, GALILEO_E1C_BOC11, 2, 2500.0)
    assert {p for p, r in b.items() if r.detected} == set(listed)
    for p in listed:
        assert c[p].detected and abs(c[p].doppler_hz - b[p].doppler_hz) <= 250.0
        assert abs(c[p].code_phase_samples - b[p].code_phase_samples) <= 1
        assert b[p].cn0_dbhz > 36.0
    # The BOC(1,1) signature at the peak (side-peak check): the power half a chip either
    # side is R(1/2)^2 = 0.25 of the peak's, a third of a chip off it is near R(1/3) = 0.
    # Bounds: the grid's peak is up to half a sample (0.043 chip) off the true one, which
    # moves the side peaks' ratios within about 0.12-0.45 (R slope 3 on the main peak, 1 on
    # the side peaks), plus the noise of two 4 ms blocks; a side peak taken for the main
    # one would instead show a neighbour 4 times stronger.
    fs, half = 12e6, 12e6 / 1.023e6 / 2
    for p in listed:
        r = b[p]
        g = search_grid(x, fs, 3e6, (p,), 4e-3, 2, np.array([r.doppler_hz]), signal=GALILEO_E1B_BOC11)[0, 0]
        lags = r.code_phase_samples + np.array([-half, -2 * half / 3, 2 * half / 3, half])
        side = np.interp(lags, np.arange(-g.size, 2 * g.size), np.tile(g, 3)) / g[r.code_phase_samples]
        assert np.all((side[[0, 3]] > 0.08) & (side[[0, 3]] < 0.5)), (p, side)
        assert abs(side[[0, 3]].mean() - 0.25) < 0.08 and np.all(side[[1, 2]] < 0.12), (p, side)


def test_the_4mhz_recording_shows_pocketsdrs_galileo_satellites():
    """The complex 4 MHz file (I - jQ): PocketSDR's E1-B list 7 15 27 30 is found, each the
    same on E1-C, and they are the four strongest of the PRNs searched."""
    listed = (7, 15, 27, 30)
    prns = listed + (1, 4, 9, 11, 12)
    _, b = _acquire("pocketsdr_L1_4MHz_IQ_100ms.bin", 4e6, 0.0, -1, prns, GALILEO_E1B_BOC11, 4)
    _, c = _acquire("pocketsdr_L1_4MHz_IQ_100ms.bin", 4e6, 0.0, -1, listed, GALILEO_E1C_BOC11, 4)
    assert all(b[p].detected and b[p].cn0_dbhz > 36.0 for p in listed)
    strongest = sorted(b, key=lambda p: -b[p].test_statistic)[:4]
    assert set(strongest) == set(listed)
    weakest_listed = min(b[p].test_statistic for p in listed)
    assert max(b[p].test_statistic for p in prns if p not in listed) < weakest_listed / 3
    for p in listed:
        assert c[p].detected and abs(c[p].doppler_hz - b[p].doppler_hz) <= 250.0
        assert abs(c[p].code_phase_samples - b[p].code_phase_samples) <= 1


def test_a_boc11_pilot_loop_holds_the_main_peak_at_45_dbhz_with_the_thermal_code_error():
    """The engine's scalar loop (registry defaults: eml-envelope DLL, B_L = 1 Hz, first order)
    on the analytic correlators of E1-C with a BOC(1,1) replica, 4 ms, d = 0.2 chip, started
    0.1 and -0.15 chip off (inside the main peak, whose zeros are at +-1/3 chip).

    Bound: on BOC(1,1)'s main peak R = 1 - 3|tau|, the normalised envelope discriminator
    ``(1 - d/2)(L - E)/(L + E)`` has the slope k = 3(2 - d)/(2 - 3d) (1 for BPSK), so the
    loop's bandwidth is k B_L, and the coherent early-minus-late thermal variance is
    k B_L d / (6 C/N0) (1 + 1/(T C/N0 (2 - 3d))): BPSK's B_L d/(2 C/N0) with the noise of
    L - E (2(1 - R(d)) = 6d) over the squared slope (6^2), Betz 2016 ch. 20 with R of BOC.
    64 runs of 1.2 s give the standard deviation to about 4 % (about 400 independent
    loop samples), hence the 15 % band."""
    from gnssframework.receiver.engine.channel import Channel
    from gnssframework.receiver.engine.closers import ScalarCloser
    from gnssframework.receiver.engine.loops import run_scalar
    from gnssframework.receiver.engine.sources import AnalyticSource
    from gnssframework.receiver.engine.truth import LoopTruth
    from gnssframework.signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0

    T, d, runs, cn0_dbhz, settle = 4e-3, 0.2, 64, 45.0, 100
    truth = LoopTruth.from_dynamics(
        1.2, T, cn0_dbhz, doppler_hz=np.full(runs, 1200.0), code_phase0_chips=100.3, carrier_phase0_rad=0.7
    )
    c = 10 ** (cn0_dbhz / 10)
    k = 3 * (2 - d) / (2 - 3 * d)
    bound = math.sqrt(k * 1.0 * d / (6 * c) * (1 + 1 / (T * c * (2 - 3 * d))))
    for seed, start_error_chips in ((1, 0.1), (2, -0.15)):
        channel = Channel.start(
            (runs,), truth.code_phase_chips[0] + start_error_chips, 1203.0, signal=GALILEO_E1C_BOC11
        )
        closer = ScalarCloser(registry.create("channel_filter", "scalar"))
        closer.reset(channel, T, early_late_spacing_chips=d, cn0_dbhz=cn0_dbhz)
        sim = CorrelatorSimulator(T, early_late_spacing_chips=d, signal=GALILEO_E1C_BOC11)
        rec = run_scalar(
            closer, AnalyticSource(sim, amplitude_from_cn0(cn0_dbhz, T), np.random.default_rng(seed)), channel, truth
        )
        e = rec.code_error_chips[settle:]
        assert np.abs(e).max() < 1 / 6  # every run on the main peak, never near a side peak (+-1/2)
        assert abs(e.mean()) < 0.1 * bound
        assert 0.85 * bound < e.std() < 1.15 * bound, (e.std(), bound)


def test_the_generators_secondary_code_is_found_where_it_was_put():
    """The project's IF generator writes E1-C with CS25_1 (overlay chip 6 over the first
    primary period): the synchronisation used on the real recording finds chip 6."""
    from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples

    fs = 4e6
    sat = SatelliteSignal(
        11, 42.0, doppler_hz=512.0, code_phase_chips=6 * 4092 + 4092 - 1000.0, signal=GALILEO_E1C_BOC11
    )
    x = synthesize_samples([sat], 0.104, fs, 0.0, np.random.default_rng(5)).astype(np.complex64)
    start = int(round(1000.0 / 1.023e6 * fs))  # chip 0 of the next period: overlay chip 7
    shift, margin, prompts = pilot_sync_and_track(x, fs, GALILEO_E1C_BOC11, 11, 512.0, start, 24, sync_prompts=24)
    assert shift == 7 and margin > 2
    assert np.all(prompts[8:].real * np.sign(prompts[8].real) > 0)


def test_the_real_pilot_is_tracked_after_secondary_code_sync_on_the_4mhz_slice():
    """E1-C of PRN 27 (the 4 MHz slice's strongest) on the compiled correlators with a
    BOC(1,1) sub-chip table (`SampleSource(subchips_per_chip=2)`): the secondary-code
    phase is found at one shift only (the ICD's CS25_1 is the truth here), and with it wiped
    off the engine's scalar loop holds phase lock: every prompt after the pull-in has one
    sign and |I| >> |Q|. validation/galileo_e1_track.py runs the same over the whole 0.5 s."""
    fs, prn = 4e6, 27
    rec = open_recording(DATA / "pocketsdr_L1_4MHz_IQ_100ms.bin", format="ci8", sample_rate_hz=fs, if_hz=0.0, q_sign=-1)
    x = np.asarray(rec.read(0, rec.n_samples), np.complex64)
    acq = registry.create("acquisition", "pcps", noncoherent=4, doppler_max_hz=3500.0, xcorr_margin_db=None)
    r = acq.acquire(x[: acq.samples_needed(fs, GALILEO_E1C_BOC11)], fs, 0.0, prns=(prn,), signal=GALILEO_E1C_BOC11)[0]
    shift, margin, prompts = pilot_sync_and_track(
        x, fs, GALILEO_E1C_BOC11, prn, r.doppler_hz, r.code_phase_samples, 24, sync_prompts=24
    )
    assert margin > 2
    after = prompts[8:]
    assert np.all(np.sign(after.real) == np.sign(after.real[0]))
    assert np.mean(np.abs(after.real)) > 4 * np.mean(np.abs(after.imag))
