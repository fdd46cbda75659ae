"""The vector-tracking scenario's C/N0 fade (``fade_*`` case options, issue 22).

Independent truths: the correlators' C/N0 measured from their own samples by the
known-amplitude estimate (signal power from the coherent mean of the prompts, noise
from their spread, with the closed-form standard errors of both) and by the library's
narrowband-wideband power ratio estimator (Van Dierendonck 1996), against the C/N0 the
case asks for, interval window by interval window; elevations from pymap3d for which
channels are shadowed; the config's validation; and that a case without a fade draws
the same numbers as before the option existed (a run of the same case with the fade's
defaults written out, and with a fade on other channels only, for the untouched ones).
"""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

import gnssframework as gf
from gnssframework import random_streams as draw
from gnssframework.errors import ConfigError
from gnssframework.experiments import get_scenario
from gnssframework.experiments.config import ComparisonConfig
from gnssframework.interfaces import ChannelFilter
from gnssframework.receiver.tracking.vector import run_vector_loop
from gnssframework.signal.cn0 import cn0_nwpr
from gnssframework.simulation.fade import CN0Fade, lowest_channels

LAT, LON, H = 34.23, 108.3576, 590.6
T = 0.01
SCEN = {
    "kind": "vector-tracking",
    "duration_s": 3.0,
    "channels": 8,
    "settle_s": 0.5,
    "steady_state_s": 1.0,
    "pcrb": False,
    "data_bits": "none",
}


class _Recorder(ChannelFilter):
    """Records the prompts and hands the nav filter nothing it would use (variance 1e8),
    so the nav filter coasts on its exact initial state and the replica stays on the
    signal: the prompts' mean is then the signal amplitude at a constant phase."""

    name = "recorder"
    requires = ("correlators",)
    provides = ("code_error_chips", "code_error_var_chips2", "freq_error_hz", "freq_error_var_hz2")

    def reset(self, batch_shape, context):
        self.prompts, self.shape = [], batch_shape

    def step(self, inputs):
        self.prompts.append(inputs["correlators"].prompt.copy())
        zero, big = np.zeros(self.shape), np.full(self.shape, 1e8)
        return {
            "code_error_chips": zero,
            "code_error_var_chips2": big,
            "freq_error_hz": zero,
            "freq_error_var_hz2": big,
        }


def _prompts(case: dict, runs: int = 32, seed: int = 5) -> tuple[np.ndarray, object]:
    """The prompts ``(K, runs, ch)`` of a case's truth, the replica on the signal."""
    scen = get_scenario(SCEN)
    c = scen.CaseParams.model_validate(case)
    truth, _, _ = scen.truth(
        c.cn0_dbhz, runs, draw.run_streams(seed, (0,), range(runs)), None, c.fade(), c.fade_channels
    )
    x0 = truth.nav_truth(T / 2, 0)  # exact start: no tracking error to blur the amplitude
    P0 = np.diag([1e-6] * 3 + [1e-8] * 3 + [1e-6, 1e-8])
    rec = _Recorder()
    nav = gf.registry.create("nav_filter", "ekf-pv", clock="ocxo", accel_psd=1e-8)
    run_vector_loop(rec, nav, truth, x0, P0, draw.run_streams(seed + 1, (0,), range(runs)), data_bits="none")
    return np.asarray(rec.prompts), truth


def _known_amplitude_cn0(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per run and channel over a window of intervals (axis 0): C/N0 (linear, Hz) from the
    coherent mean's power (debiased by the mean's own noise power) over twice the
    per-component noise variance times T, with that noise variance."""
    n = p.shape[0]
    mean = p.mean(axis=0)
    var_component = np.sum(np.abs(p - mean) ** 2, axis=0) / (2 * (n - 1))
    amp2 = np.abs(mean) ** 2 - 2 * var_component / n
    return amp2 / (2 * var_component * T), var_component, amp2


def _check_window(p: np.ndarray, expected_dbhz: np.ndarray, expected_noise_var: np.ndarray) -> None:
    """The window's C/N0 and noise variance, averaged over runs, against the expected
    values within 4.5 standard errors (the SE from the runs' spread)."""
    cn0, var, _ = _known_amplitude_cn0(p)
    runs = cn0.shape[0]
    for measured, expected in ((cn0, 10 ** (expected_dbhz / 10)), (var, expected_noise_var)):
        m, se = measured.mean(axis=0), measured.std(axis=0, ddof=1) / np.sqrt(runs)
        assert np.all(np.abs(m - expected) < 4.5 * se), (m, expected, se)
        # The test has the power to see a 1 dB error (its SE is well below 26 % of the value).
        assert np.all(se < 0.05 * expected)


@pytest.mark.parametrize("cause", ["attenuation", "noise-floor"])
def test_correlator_cn0_follows_the_fade_over_time(cause):
    depth, start, length = 10.0, 1.0, 1.0
    case = {
        "cn0_dbhz": 42.0,
        "fade_depth_db": depth,
        "fade_start_s": start,
        "fade_duration_s": length,
        "fade_cause": cause,
    }
    if cause == "attenuation":
        case["fade_channels"] = 3
    prompts, truth = _prompts(case)
    K, runs, ch = prompts.shape
    t_mid = np.arange(K) * T + T / 2
    # Which channels: the 3 lowest at the start (pymap3d's elevations), every one for a noise floor.
    sat = truth.sat_state(np.asarray(0.0))[0]
    _, el, _ = pymap3d.ecef2aer(sat[..., 0], sat[..., 1], sat[..., 2], LAT, LON, H)
    faded = np.zeros(ch, bool)
    faded[np.argsort(el)[:3] if cause == "attenuation" else slice(None)] = True
    windows = {
        "before": (t_mid >= 0.1) & (t_mid < start),
        "during": (t_mid >= start) & (t_mid < start + length),
        "after": t_mid >= start + length,
    }
    for name, sel in windows.items():
        loss = depth * faded if name == "during" else np.zeros(ch)
        noise_var = 10 ** (loss / 10) if cause == "noise-floor" else np.ones(ch)
        _check_window(prompts[sel], np.broadcast_to(42.0 - loss, (runs, ch))[0], noise_var)
    # The channel filters are still told the nominal C/N0 (the fade is in the truth only).
    np.testing.assert_array_equal(truth.cn0_dbhz, np.full((runs, ch), 42.0))


def test_nwpr_estimate_sees_the_fade_depth():
    # The library's narrowband-wideband estimator (20 intervals a block, 1 s windows),
    # averaged over runs, against the requested C/N0 before and during a 10 dB fade.
    case = {"cn0_dbhz": 40.0, "fade_depth_db": 10.0, "fade_start_s": 1.0, "fade_duration_s": 1.0}
    prompts, _ = _prompts(case, runs=32)
    before = cn0_nwpr(prompts[0:100], T, m=20)  # (runs, ch), 5 blocks each
    during = cn0_nwpr(prompts[100:200], T, m=20)
    for est, expected in ((before, 40.0), (during, 30.0)):
        lin = 10 ** (est / 10)
        m, se = lin.mean(axis=0), lin.std(axis=0, ddof=1) / np.sqrt(lin.shape[0])
        # NWPR's ratio of block means is biased by a few percent at 5 blocks: 4.5 SE plus 5 %.
        assert np.all(np.abs(m - 10 ** (expected / 10)) < 4.5 * se + 0.05 * 10 ** (expected / 10))
    assert np.mean(before) - np.mean(during) == pytest.approx(10.0, abs=0.5)


def test_gains_closed_form():
    t = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    faded = np.array([[True, False]])
    s, n = CN0Fade(6.0, 1.0, 1.0, "attenuation").gains(t, faded)
    np.testing.assert_allclose(s[:, 0, 0], [1, 10**-0.3, 10**-0.3, 1, 1])
    np.testing.assert_array_equal(s[:, 0, 1], 1.0)
    np.testing.assert_array_equal(n, 1.0)
    s, n = CN0Fade(6.0, 1.0, None, "noise-floor").gains(t, faded)
    np.testing.assert_array_equal(s, 1.0)
    np.testing.assert_allclose(n[:, 0, 0], [1, 10**0.3, 10**0.3, 10**0.3, 10**0.3])
    mask = lowest_channels(np.array([[80.0, 20.0, 50.0, 15.0]]), 2)
    np.testing.assert_array_equal(mask, [[False, True, False, True]])
    assert lowest_channels(np.array([[80.0, 20.0]]), None).all()


def _batch(case: dict, seed: int = 3) -> dict[str, np.ndarray]:
    scen = get_scenario({**SCEN, "data_bits": "known"})
    plugins = {
        "channel_filter": gf.registry.create("channel_filter", "iq-filter", clock="ocxo"),
        "nav_filter": gf.registry.create("nav_filter", "ekf-pv", clock="ocxo"),
    }
    return scen.run_batch(case, plugins, 2, draw.run_streams(seed, (0,), range(2))).metrics


def test_no_fade_draws_the_same_numbers():
    # Writing out the fade's defaults changes nothing: same draws, same metrics.
    plain = _batch({"name": "a", "cn0_dbhz": 40.0})
    explicit = _batch({"name": "a", "cn0_dbhz": 40.0, "fade_depth_db": 0.0})
    for m in plain:
        np.testing.assert_array_equal(plain[m], explicit[m])
    # A fade changes the numbers (the option reaches the loop).
    faded = _batch({"name": "a", "cn0_dbhz": 40.0, "fade_depth_db": 10.0, "fade_start_s": 1.0})
    assert not np.array_equal(plain["carrier_freq_error_rmse"], faded["carrier_freq_error_rmse"])


def test_a_config_without_fade_keeps_its_identity():
    base = {
        "name": "x",
        "scenario": SCEN,
        "cases": [{"name": "c", "cn0_dbhz": 40.0}],
        "candidates": [{"name": "a", "channel_filter": "iq-filter", "nav_filter": "ekf-pv"}],
    }
    with_fade = {**base, "cases": [{"name": "c", "cn0_dbhz": 40.0, "fade_depth_db": 10.0}]}
    a, b = ComparisonConfig.model_validate(base), ComparisonConfig.model_validate(with_fade)
    # The identity hashes the config as written: an unset option is not in it.
    assert "fade" not in str(a.model_dump()["cases"])
    assert a.identity() != b.identity()


@pytest.mark.parametrize(
    "case, field",
    [
        ({"cn0_dbhz": 40.0, "fade_start_s": 2.0}, "fade_start_s"),
        ({"cn0_dbhz": 40.0, "fade_depth_db": 10.0, "fade_start_s": 3.0}, "fade_start_s"),
        ({"cn0_dbhz": 40.0, "fade_depth_db": 10.0, "fade_channels": 9}, "fade_channels"),
        ({"cn0_dbhz": 40.0, "fade_depth_db": 10.0, "fade_cause": "noise-floor", "fade_channels": 2}, "fade_channels"),
        ({"cn0_dbhz": 40.0, "fade_depth_db": 40.0}, "fade_depth_db"),
        ({"cn0_dbhz": 40.0, "fade_depth_db": 10.0, "fade_cause": "jamming"}, "fade_cause"),
    ],
)
def test_bad_fade_settings_are_refused_by_field(case, field):
    scen = get_scenario(SCEN)
    with pytest.raises(ConfigError, match=field):
        scen.check_case(case, "cases[0]")


def test_a_gain_of_the_wrong_shape_is_refused_by_name():
    import dataclasses

    scen = get_scenario(SCEN)
    truth, x0, P0 = scen.truth(40.0, 2, draw.run_streams(1, (0,), range(2)))
    bad = dataclasses.replace(truth, noise_gain=np.ones((3, 2, 8)))
    with pytest.raises(ConfigError, match="truth.noise_gain"):
        run_vector_loop(
            _Recorder(), gf.registry.create("nav_filter", "ekf-pv"), bad, x0, P0, draw.run_streams(2, (0,), range(2))
        )


def test_pcrb_is_refused_with_a_fade():
    scen = get_scenario({**SCEN, "pcrb": True})
    with pytest.raises(ConfigError, match="pcrb"):
        scen.check_case({"cn0_dbhz": 40.0, "fade_depth_db": 10.0}, "cases[0]")
