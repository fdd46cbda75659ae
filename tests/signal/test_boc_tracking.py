"""BOC tracking (issue 39): the analytic BOC correlators against the sampled replica, the
BOC code discriminators (S-curve, thermal noise, side-peak jumps), and the
``boc-tracking`` scenario on a tiny case."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.signal.correlator_model import CorrelatorSimulator, amplitude_from_cn0, correlator_mean
from gnssframework.signal.correlators import Correlators
from gnssframework.signal.galileo_e1 import GALILEO_E1C_BOC11

SPEC = GALILEO_E1C_BOC11
UP = 24  # samples per chip of the numerical correlation


def _sampled_correlation(prn: int, lags_samples: np.ndarray) -> np.ndarray:
    """Circular correlation of the sampled spreading waveform (code times sub-carrier, from
    `SignalSpec.spreading_table`) with itself shifted by ``lags_samples``, normalised by
    its power: the truth the analytic model's R must match (up to the code's own sidelobes,
    about 1/sqrt(4092))."""
    table = SPEC.spreading_table(prn).astype(float)
    x = np.repeat(table, UP // SPEC.subchips_per_chip)
    return np.array([np.dot(x, np.roll(x, int(k))) for k in lags_samples]) / x.size


@pytest.mark.parametrize("prn", [3, 21])
def test_analytic_boc11_correlation_matches_the_sampled_replica_at_any_lag(prn):
    lags = np.arange(-30, 31)  # -1.25 .. 1.25 chips, 1/24 chip steps: VE/VL at +-0.5 included
    tau = lags / UP
    numeric = _sampled_correlation(prn, lags)
    # The model's tap at offset o sees R(e - o): one tap set spanning the lags at e = 0.
    taps = {f"t{i}": float(o) for i, o in enumerate(tau)}
    mean = correlator_mean(1.0, 0.0, 0.0, 0.0, 0.004, np.array(list(taps.values())), signal=SPEC)
    np.testing.assert_allclose(mean.real, numeric, atol=0.05)
    # The closed form of BOC(1,1) (Betz 2016, ch. 12) at the side peaks and the zeros.
    np.testing.assert_allclose(
        SPEC.autocorrelation(np.array([0.0, 1 / 3, 0.5, 1.0])), [1.0, 0.0, -0.5, 0.0], atol=1e-12
    )


def test_extra_taps_are_drawn_with_the_boc_mean_and_covariance():
    sim = CorrelatorSimulator(0.004, 0.2, extra_taps={"very_early": -0.5, "very_late": 0.5}, signal=SPEC)
    rng = np.random.default_rng(1)
    e = np.full(40000, 0.1)
    A = 3.0
    c = sim.draw(e, np.zeros_like(e), np.zeros_like(e), A, rng)
    taps = np.stack([c.early, c.prompt, c.late, c.extra["very_early"], c.extra["very_late"]], -1)
    expected = A * SPEC.autocorrelation(0.1 - np.array([-0.1, 0.0, 0.1, -0.5, 0.5]))
    np.testing.assert_allclose(taps.real.mean(0), expected, atol=0.03)  # SE 1/sqrt(40000) = 0.005
    cov = np.cov((taps.real - expected).T)
    o = np.array([-0.1, 0.0, 0.1, -0.5, 0.5])
    np.testing.assert_allclose(cov, SPEC.autocorrelation(o[:, None] - o[None, :]), atol=0.03)


def _taps(e: np.ndarray, A: float = 1.0) -> Correlators:
    """Noise-free taps of a BOC(1,1) signal at code error ``e`` (E/L at +-0.1, VE/VL at +-0.5)."""
    off = np.array([-0.1, 0.0, 0.1, -0.5, 0.5])
    m = correlator_mean(A, e, 0.0, 0.0, 0.004, off, signal=SPEC)
    return Correlators(m[..., 0], m[..., 1], m[..., 2], extra={"very_early": m[..., 3], "very_late": m[..., 4]})


@pytest.mark.parametrize("name", ["boc-eml", "boc-vemlp", "bump-jumping"])
def test_boc_discriminators_return_the_error_on_the_main_peak(name):
    d = registry.create("discriminator", name, coherent_time_s=0.004, early_late_spacing_chips=0.2)
    e = np.linspace(-0.095, 0.095, 39)
    np.testing.assert_allclose(d(_taps(e)), e, atol=1e-12)


def test_boc_eml_noise_variance_matches_monte_carlo():
    d = registry.create("discriminator", "boc-eml", coherent_time_s=0.004, early_late_spacing_chips=0.2)
    sim = CorrelatorSimulator(0.004, 0.2, signal=SPEC)
    rng = np.random.default_rng(7)
    for cn0 in (40.0, 50.0):
        out = d(sim.draw(np.zeros(40000), 0.0, 0.0, amplitude_from_cn0(cn0, 0.004), rng))
        # The variance of a sample variance of 40000 draws: 0.7 % SE; the squaring-loss
        # term is a few % at 40 dB-Hz.
        assert out.var() == pytest.approx(float(d.noise_variance(cn0)), rel=0.05)


@pytest.mark.parametrize(
    "name, params", [("bump-jumping", {"counter_threshold": 8}), ("boc-vemlp", {"window_intervals": 8})]
)
def test_side_peak_detectors_jump_towards_the_main_peak_and_not_from_it(name, params):
    d = registry.create("discriminator", name, coherent_time_s=0.004, early_late_spacing_chips=0.2, **params)
    sim = CorrelatorSimulator(0.004, 0.2, extra_taps=d.extra_taps(), signal=SPEC)
    rng = np.random.default_rng(3)
    A = amplitude_from_cn0(40.0, 0.004)
    e = np.array([0.5, -0.5, 0.0, 0.02])  # on the late and early side peaks, on the main peak
    jumps = []
    for _ in range(8):
        d(sim.draw(e, 0.0, 0.0, A, rng))
        jumps.append(np.broadcast_to(d.code_jump_chips(), e.shape))
    jumps = np.array(jumps)
    # Truth ahead of the replica by half a chip: the main peak is on the very-late tap,
    # the replica must jump +0.5 (the output's sign), once, on the 8th interval.
    np.testing.assert_array_equal(jumps[:, 0], [0] * 7 + [0.5])
    np.testing.assert_array_equal(jumps[:, 1], [0] * 7 + [-0.5])
    assert np.all(jumps[:, 2:] == 0)


def test_plain_discriminators_command_no_jump_and_no_taps():
    d = registry.create("discriminator", "eml-envelope")
    assert d.extra_taps() == {} and d.code_jump_chips() == 0.0


def test_boc_tracking_scenario_detectors_leave_the_side_peaks_eml_keeps():
    """A tiny run started 0.45 chip off, near the side peaks: boc-eml locks there,
    bump-jumping and boc-vemlp jump to the main peak; the scores say so."""
    from gnssframework.experiments.scenarios import get_scenario
    from gnssframework.experiments.scenarios.boc_tracking import boc_scores

    scenario = get_scenario({"kind": "boc-tracking", "duration_s": 1.2, "settle_s": 0.8, "lock_window_s": 0.2})
    start = np.array([0.45, -0.45, 0.45, -0.45])
    for name, side in (("boc-eml", 1.0), ("bump-jumping", 0.0), ("boc-vemlp", 0.0)):
        channel = registry.create(
            "channel_filter",
            "scalar",
            pll_bandwidth_hz=10.0,
            fll_bandwidth_hz=0.0,
            dll_bandwidth_hz=1.0,
            code_discriminator={"name": name},
        )
        phase, code, T = scenario.track({"cn0_dbhz": 40.0}, channel, start.size, np.random.default_rng(0), start)
        final = np.abs(code[-50:]).mean(0)
        assert np.all((final > 0.4) if side else (final < 0.05)), (name, final)
        scores = boc_scores(code, phase, T, scenario.params)
        np.testing.assert_array_equal(scores["side_peak_lock"], side)
        assert np.isnan(scores["code_rms_main_chips"]).all() == bool(side)


def test_boc_scorers_keep_no_state_between_scenarios_or_batches():
    """Two scorers (and one scorer twice) on the same series object under scenarios whose
    side_peak_chips differ: each answers for its own scenario. Run 0 ends 0.2 chip off, run 1
    0.05: side-peak locked (mean |error| > side_peak_chips / 2) at 0.3 chips, not at 0.5."""
    from gnssframework.experiments.scenarios import get_scenario
    from gnssframework.experiments.scenarios.boc_tracking import METRICS, BocScore

    K = 50
    time_s = 0.004 * (1 + np.arange(K))
    code = np.tile([0.2, 0.05], (K, 1))
    series = {"code_error_chips": code, "phase_error_rad": np.zeros((K, 2))}
    narrow, wide = (
        get_scenario({"kind": "boc-tracking", "side_peak_chips": s, "lock_window_s": 0.02}) for s in (0.3, 0.5)
    )
    first = next(m for m in METRICS if m.name == "side_peak_lock")
    second = BocScore("side_peak_lock", "")
    np.testing.assert_array_equal(first.compute(series, time_s, narrow).value, [1.0, 0.0])
    np.testing.assert_array_equal(second.compute(series, time_s, wide).value, [0.0, 0.0])
    np.testing.assert_array_equal(first.compute(series, time_s, wide).value, [0.0, 0.0])
    # the RMS is undefined (side-peak lock) on run 0 only where that run is side-locked
    rms = next(m for m in METRICS if m.name == "code_rms_main_chips")
    assert np.isnan(rms.compute(series, time_s, narrow).value[0])
    np.testing.assert_allclose(rms.compute(series, time_s, wide).value, [0.2, 0.05])
