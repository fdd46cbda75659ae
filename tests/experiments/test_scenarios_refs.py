"""Reference experiments 003 (scintillation) and 004 (multipath) on short runs."""

import numpy as np
import pytest

from gnssframework.experiments import get_scenario
from gnssframework.receiver.tracking.jitter import loop_variance
import gnssframework as gf

PLL = {
    "name": "scalar",
    "params": {"pll_bandwidth_hz": 10.0, "pll_order": 2, "fll_bandwidth_hz": 0.0, "dll_bandwidth_hz": 0.5},
}
KF2 = {"name": "kf-carrier-loop", "params": {"q": [0.01, 0.1], "r": 5.0, "angle_unit": "deg", "dll_bandwidth_hz": 0.5}}


def _scint(case, cand, runs=6, seed=1, duration=20.0):
    scen = get_scenario({"kind": "scintillation", "duration_s": duration})
    return scen.run_batch(case, scen.build({"channel_filter": cand}), runs, np.random.default_rng(seed)).metrics


def test_without_scintillation_the_pll_error_is_thermal():
    m = _scint({"model": "aj-stanford", "s4": 0.01, "sigma_phi_rad": 0.0}, PLL)
    costas = gf.registry.create("discriminator", "costas-atan", coherent_time_s=0.01)
    theory = np.sqrt(loop_variance(costas.noise_variance(45.0), 10.0, 0.01))
    assert np.mean(m["phase_error_rmse"]) == pytest.approx(theory, rel=0.25)
    assert np.all(m["loss_of_lock_fraction"] == 0)
    assert np.mean(m["discriminator_std"]) == pytest.approx(np.sqrt(costas.noise_variance(45.0)), rel=0.25)


def test_strong_amplitude_scintillation_widens_the_discriminator_spread():
    weak = _scint({"model": "aj-stanford", "s4": 0.3}, PLL)
    strong = _scint({"model": "aj-stanford", "s4": 0.9}, PLL)
    assert np.mean(strong["discriminator_std"]) > 1.3 * np.mean(weak["discriminator_std"])


def test_kalman_loop_beats_the_pll_under_aj_stanford_s4_0_9():
    case = {"model": "aj-stanford", "s4": 0.9, "sigma_phi_rad": 0.1}
    assert np.mean(_scint(case, KF2)["phase_error_rmse"]) < np.mean(_scint(case, PLL)["phase_error_rmse"])


def _multipath(components, runs=10, psi=0.95):
    scen = get_scenario({"kind": "multipath", "epochs": 300, "psi": psi})
    base = {
        "nav_filter": {"name": "position-ca", "params": {}},
        "estimator": {"name": "ukf", "params": {"alpha": 0.01, "beta": 2.0, "kappa": 0.0}},
    }
    res = scen.run_batch({}, scen.build({**base, **components}), runs, np.random.default_rng(4))
    return res


COLORED = {"augmentation": {"name": "colored-ar1", "params": {"psi": 0.5}}}
ADAPTIVE = {"noise_adapter": {"name": "sage-husa", "params": {"variant": "improved", "alpha_r": 0.5, "alpha_q": 0.5}}}


def test_colored_model_lowers_the_rms_error_as_published():
    ukf = _multipath({}, psi=0.5).metrics
    ukf1 = _multipath(COLORED, psi=0.5).metrics
    for m in ("lat_error_rmse", "lon_error_rmse"):
        assert np.mean(ukf1[m]) < 0.9 * np.mean(ukf[m])


def test_adaptive_ukf_does_not_diverge_in_its_first_30_epochs():
    # Reference 004's adaptive UKF diverges for ~30 epochs; with the safeguards it must not.
    plain = _multipath({})
    adaptive = _multipath({**ADAPTIVE, "augmentation": {"name": "colored-ar1", "params": {"psi": 0.95}}})
    first = lambda r: np.sqrt(np.mean(r.series["horizontal_error_rmse"][:30] ** 2))  # noqa: E731
    assert first(adaptive) < 1.2 * first(plain)
    assert np.all(np.isfinite(adaptive.series["horizontal_error_rmse"]))


def test_smaller_q_helps_where_thermal_noise_dominates_and_hurts_where_phase_scintillation_does():
    # Reference 003's "smaller Q is better" is a bandwidth trade-off (kf-3 is a 1.5 Hz
    # loop, kf-2 a 2.2 Hz one): paired over the same runs, kf-3 wins at 35 dB-Hz and
    # loses at 45 dB-Hz under 0.1 rad of AJ-Stanford phase scintillation.
    kf3 = {"name": "kf-carrier-loop", "params": {**KF2["params"], "q": [0.01, 0.01]}}
    case = {"model": "aj-stanford", "s4": 0.9, "sigma_phi_rad": 0.1}
    for cn0, sign in ((35.0, -1), (45.0, +1)):
        c = {**case, "cn0_dbhz": cn0}
        d = (
            _scint(c, kf3, runs=12, duration=20.0)["phase_error_rmse"]
            - _scint(c, KF2, runs=12, duration=20.0)["phase_error_rmse"]
        )
        assert sign * np.mean(d) > 2 * np.std(d, ddof=1) / np.sqrt(d.size), (cn0, d)
