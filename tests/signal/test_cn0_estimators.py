"""C/N0 estimators (plugin kind ``cn0_estimator``) by Monte Carlo on the correlator model.

Truth: prompts drawn by `simulate_correlators` at a known C/N0 (amplitude ``sqrt(2cT)``,
unit-variance I and Q), a noise-only correlator as a tap 10 chips off the peak (no signal,
independent of the prompt in the model). Each estimator's mean is held to its closed-form
expectation where one exists, within ``Z`` standard errors of the runs:

- ``noise-channel``: E[c_hat] = c exactly, 15 to 50 dB-Hz and pure noise, T = 20 ms;
- ``snv``: E[P_s] = nu^2 + (1 + a^2 - nu^2)/K (folded normal), pure noise included;
- ``m2m4``: E[2 M2^2 - M4] = A^4 + 8(A^2 + 1)/K;
- ``narrow-wide``: on pure noise NBP/WBP = m Beta(1, m-1): E[mu] = 1, Var[mu] = (m-1)/((m+1) K_b).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.signal.cn0 import cn0_moments, cn0_nwpr
from gnssframework.signal.correlator_model import amplitude_from_cn0, simulate_correlators

#: Standard errors allowed: the tests below make about 40 such comparisons; 4.5 SE keeps the
#: chance that a correct estimator fails one under 1e-3 (two-sided normal tail 6.8e-6 each).
Z = 4.5
T_S = 0.02
K = 50
RUNS = 4000
CN0S = (15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0)


def draw(
    cn0_dbhz: float | None, rng: np.random.Generator, runs: int = RUNS, k: int = K, coherent_time_s: float = T_S
) -> tuple[np.ndarray, np.ndarray]:
    """Prompts and noise-only correlators ``(runs, k)``, phase-locked, bits wiped
    (``cn0_dbhz=None``: pure noise)."""
    amp = np.zeros((runs, k)) if cn0_dbhz is None else None
    c = simulate_correlators(
        np.zeros((runs, k)),
        0.0,
        0.0,
        0.0 if cn0_dbhz is None else cn0_dbhz,
        coherent_time_s,
        rng,
        extra_taps={"noise": -10.0},
        amplitude=amp,
    )
    return c.prompt, c.extra["noise"]


def within(values: np.ndarray, expected: float) -> tuple[bool, float]:
    """Whether the mean of ``values`` is within Z standard errors of ``expected``; its z."""
    z = (np.mean(values) - expected) / (np.std(values, ddof=1) / np.sqrt(values.size))
    return abs(z) < Z, float(z)


@pytest.mark.parametrize("cn0", CN0S + (None,))
def test_noise_channel_is_unbiased_in_linear_terms_down_to_pure_noise(cn0, rng):
    prompt, noise = draw(cn0, rng)
    est = registry.create("cn0_estimator", "noise-channel").estimate_hz(prompt, T_S, noise=noise)
    truth = 0.0 if cn0 is None else 10 ** (cn0 / 10)
    ok, z = within(est, truth)
    assert ok, f"{cn0} dB-Hz: mean {np.mean(est):.3f} Hz vs {truth:.3f} Hz, z = {z:.2f}"


def _folded_mean(a: float) -> float:
    return float(np.sqrt(2 / np.pi) * np.exp(-a * a / 2) + a * (1 - 2 * norm.cdf(-a)))


@pytest.mark.parametrize("cn0", CN0S + (None,))
def test_snv_signal_power_has_its_folded_normal_expectation(cn0, rng):
    prompt, _ = draw(cn0, rng)
    x = registry.create("cn0_estimator", "snv").estimate_hz(prompt, T_S) * T_S
    pt = np.mean(np.abs(prompt) ** 2, axis=-1)
    ps = x * pt / (1 + x)  # P_s / (P_t - P_s) = x
    a = 0.0 if cn0 is None else float(amplitude_from_cn0(cn0, T_S))
    nu = _folded_mean(a)
    ok, z = within(ps, nu**2 + (1 + a * a - nu**2) / K)
    assert ok, (cn0, z)


@pytest.mark.parametrize("cn0", (30.0, 35.0, 40.0, 45.0, 50.0))
def test_m2m4_signal_power_square_has_its_closed_form_expectation(cn0, rng):
    prompt, _ = draw(cn0, rng)
    x = registry.create("cn0_estimator", "m2m4").estimate_hz(prompt, T_S) * T_S
    assert np.all(x > 0)  # 2 M2^2 - M4 > 0 in every run: P_d is read back from the output exactly
    m2 = np.mean(np.abs(prompt) ** 2, axis=-1)
    pd = x * m2 / (1 + x)  # P_d / (M2 - P_d) = x
    a2 = float(amplitude_from_cn0(cn0, T_S)) ** 2
    ok, z = within(pd**2, a2**2 + 8 * (a2 + 1) / K)
    assert ok, (cn0, z)


def test_narrow_wide_on_pure_noise_has_the_beta_mean_and_variance(rng):
    m = 5
    prompt, _ = draw(None, rng)
    x = registry.create("cn0_estimator", "narrow-wide", m=m).estimate_hz(prompt, T_S) * T_S
    mu = (m * x + 1) / (x + 1)  # (mu - 1)/(m - mu) = x
    kb = K // m
    ok, z = within(mu, 1.0)
    assert ok, z
    ok, z = within((mu - mu.mean()) ** 2 * RUNS / (RUNS - 1), (m - 1) / ((m + 1) * kb))
    assert ok, z


def test_m2m4_and_narrow_wide_plugins_are_the_receivers_estimators_on_the_last_axis(rng):
    prompt, _ = draw(35.0, rng, runs=50, k=400, coherent_time_s=0.001)
    np.testing.assert_allclose(
        registry.create("cn0_estimator", "m2m4")(prompt, 0.001), cn0_moments(prompt.T, 0.001), rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(
        registry.create("cn0_estimator", "narrow-wide", m=20)(prompt, 0.001),
        cn0_nwpr(prompt.T, 0.001, m=20),
        rtol=0,
        atol=1e-9,
    )


def test_beaulieu_at_high_cn0_has_the_bias_of_its_inverted_mean(rng):
    # At high SNR P_d,k -> a^2 and P_n,k -> d_k^2, d_k = n_k - n_(k-1) ~ N(0, 2), with
    # successive d correlated by -1/2: X = mean(d_k^2) has mean 2 and variance
    # (8(K-1) + 4(K-2))/(K-1)^2, and the dB reading 10 log10(a^2/X) has the bias
    # -10/ln 10 * E[log(X/2)] = 10/ln 10 * Var[X]/8 to second order (+0.13 dB at K = 50).
    # 50 dB-Hz at T = 20 ms (rho = 2000): the O(1/rho) terms are below 0.01 dB; the
    # third-order term of the log below 0.02 dB.
    prompt, _ = draw(50.0, rng)
    db = registry.create("cn0_estimator", "beaulieu")(prompt, T_S)
    var_x = (8 * (K - 1) + 4 * (K - 2)) / (K - 1) ** 2
    expected = 50.0 + 10 / np.log(10) * var_x / 8
    se = np.std(db, ddof=1) / np.sqrt(db.size)
    assert abs(np.mean(db) - expected) < 0.03 + Z * se, (np.mean(db), expected, se)


def test_bad_input_is_one_config_error_naming_the_field(rng):
    prompt, noise = draw(40.0, rng, runs=3, k=10)
    with pytest.raises(ConfigError, match="noise: noise-channel measures N0 on a noise-only correlator"):
        registry.create("cn0_estimator", "noise-channel")(prompt, T_S)
    with pytest.raises(ConfigError, match=r"noise: shape \(3, 9\) differs"):
        registry.create("cn0_estimator", "noise-channel")(prompt, T_S, noise=noise[:, :9])
    with pytest.raises(ConfigError, match="prompt: narrow-wide needs at least 20 intervals"):
        registry.create("cn0_estimator", "narrow-wide")(prompt, T_S)
    with pytest.raises(ConfigError, match="coherent_time_s: must be a positive"):
        registry.create("cn0_estimator", "snv")(prompt, 0.0)
    with pytest.raises(ConfigError, match="m"):
        registry.create("cn0_estimator", "narrow-wide", m=1)


@pytest.mark.slow
def test_the_committed_docs_tables_are_what_the_generator_writes():
    # docs/cn0_tables.py draws from a fixed seed: the committed page's numbers (bias,
    # spread, floors) are a fresh run's, to their printed rounding (one unit of the last
    # digit for arithmetic another machine rounds the other way).
    import re
    import sys
    from pathlib import Path

    docs = Path(__file__).resolve().parents[2] / "docs"
    sys.path.insert(0, str(docs))
    try:
        import cn0_tables
    finally:
        sys.path.remove(str(docs))
    number = re.compile(r"[-+]?\d+\.\d+")
    fresh = cn0_tables.render()
    committed = cn0_tables.OUT.read_text()
    assert number.sub("#", fresh) == number.sub("#", committed)
    np.testing.assert_allclose(
        [float(x) for x in number.findall(committed)], [float(x) for x in number.findall(fresh)], rtol=0, atol=0.011
    )


def test_the_lock_detector_takes_a_prompt_only_plugin_and_refuses_the_rest(rng):
    from gnssframework.receiver.channels import estimate_cn0, tracking_config
    from gnssframework.receiver.channels.lock import cn0_estimator_names

    assert cn0_estimator_names()[:2] == ["nwpr", "moments"]
    assert {"snv", "beaulieu", "m2m4"} <= set(cn0_estimator_names()) and not {"noise-channel", "narrow-wide"} & set(
        cn0_estimator_names()
    )
    assert tracking_config().cn0_estimator == "nwpr"  # the default is unchanged
    assert tracking_config(cn0_estimator="snv").cn0_estimator == "snv"
    with pytest.raises(
        ConfigError,
        match=r"tracking\.cn0_estimator: .*unknown C/N0 estimator 'snr'.*"
        r"did you mean 'snv'",
    ):
        tracking_config(cn0_estimator="snr")
    with pytest.raises(ConfigError, match=r"tracking\.cn0_estimator: .*'noise-channel'"):
        tracking_config(cn0_estimator="noise-channel")
    prompt, _ = draw(40.0, rng, runs=1, k=400, coherent_time_s=0.001)
    p = prompt[0]
    assert estimate_cn0(p, "snv", None) == pytest.approx(float(registry.create("cn0_estimator", "snv")(p, 0.001)))
    assert estimate_cn0(p, "moments", None) == pytest.approx(float(cn0_moments(p, 0.001)))


@pytest.mark.parametrize("coherent_time_s, k", [(0.020, 50), (0.001, 20)])
def test_noise_floor_of_the_noise_channel_is_its_f_quantile(coherent_time_s, k):
    # On pure noise M2/N2 is a ratio of two independent Gamma(K) means: F(2K, 2K), so
    # c_hat T = (K-1)/K F - 1 and the floor's CDF value is known. The sample 95th
    # percentile of n windows sits where the CDF is 0.95 within Z sqrt(0.05 0.95 / n).
    from scipy.stats import f as f_dist

    from gnssframework.signal.cn0_estimator import noise_floor_dbhz

    runs = 4000
    floor = noise_floor_dbhz(registry.create("cn0_estimator", "noise-channel"), coherent_time_s, k, runs=runs, seed=7)
    ratio = (10 ** (floor / 10) * coherent_time_s + 1) * k / (k - 1)
    assert abs(f_dist.cdf(ratio, 2 * k, 2 * k) - 0.95) < Z * np.sqrt(0.05 * 0.95 / runs)
    with pytest.raises(ConfigError, match="percentile"):
        noise_floor_dbhz(registry.create("cn0_estimator", "snv"), 0.001, 20, percentile=100.0)


def test_batch_axes_and_data_bits(rng):
    # Any leading batch shape; the estimators that read magnitudes (or |I|) give the same
    # reading when data bits flip whole intervals, NWPR (coherent block sums) does not.
    prompt, noise = draw(30.0, rng, runs=12, k=40)
    bits = rng.choice([-1.0, 1.0], size=prompt.shape)
    for name in ("m2m4", "snv", "beaulieu", "noise-channel", "narrow-wide"):
        est = registry.create("cn0_estimator", name)
        flat = est.estimate_hz(prompt, T_S, noise=noise)
        assert est.estimate_hz(prompt.reshape(3, 4, 40), T_S, noise=noise.reshape(3, 4, 40)).shape == (3, 4)
        np.testing.assert_array_equal(
            est.estimate_hz(prompt.reshape(3, 4, 40), T_S, noise=noise.reshape(3, 4, 40)).ravel(), flat
        )
        flipped = est.estimate_hz(prompt * bits, T_S, noise=noise)
        if name == "narrow-wide":
            assert np.median(flipped) < 0.5 * np.median(flat)
        else:
            np.testing.assert_allclose(flipped, flat, rtol=1e-12)
