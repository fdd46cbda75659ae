"""Each filter's dynamics and noise assumptions in common units, and the report's table (issue 22)."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.experiments import load_config
from gnssframework.experiments.report import assumption_rows
from gnssframework.signal.constants import L1_FREQ_HZ

LAMBDA_M = 299792458.0 / L1_FREQ_HZ


def test_ekf_pv_assumes_its_white_acceleration_on_every_line_of_sight():
    nav = registry.create("nav_filter", "ekf-pv", accel_psd=0.37)
    assert nav.assumptions({}) == {"line-of-sight acceleration PSD": (0.37, "m²/s³")}


def test_iq_filter_frequency_random_walk_is_a_line_of_sight_acceleration():
    # df random walk of variance q3 per interval T: fdot white with PSD q3 / T (Hz²/s);
    # a = -lambda fdot, so the acceleration PSD is q3 / T * lambda² (m²/s³); likewise the jerk.
    q = [1e-3, 1e-8, 1e-5, 4e-4, 2e-2]
    ch = registry.create("channel_filter", "iq-filter", q=q, clock=None, adaptive=False)
    out = ch.assumptions({"coherent_time_s": 0.02})
    assert out["line-of-sight acceleration PSD"][0] == pytest.approx(4e-4 / 0.02 * LAMBDA_M**2, rel=1e-12)
    assert out["line-of-sight jerk PSD"][0] == pytest.approx(2e-2 / 0.02 * LAMBDA_M**2, rel=1e-12)
    assert out["correlator R"][0] == "true covariance"
    # A clock adds its frequency noise: more assumed acceleration, never less.
    with_clock = registry.create("channel_filter", "iq-filter", q=q, clock="tcxo", adaptive=False)
    assert (
        with_clock.assumptions({"coherent_time_s": 0.02})["line-of-sight acceleration PSD"][0]
        > out["line-of-sight acceleration PSD"][0]
    )


def test_a_fixed_r_discriminator_trusts_a_weaker_signal_too_much():
    fixed = registry.create("channel_filter", "discriminator", fixed_r_cn0_dbhz=45.0)
    at_45 = fixed.assumptions({"coherent_time_s": 0.01, "cn0_dbhz": 45.0})
    at_30 = fixed.assumptions({"coherent_time_s": 0.01, "cn0_dbhz": 30.0})
    assert at_45["frequency R / thermal variance"][0] == pytest.approx(1.0)
    assert at_45["code R / thermal variance"][0] == pytest.approx(1.0)
    # 15 dB less signal: the thermal variances grow about as 1/(C/N0), i.e. 10^1.5 times
    # (within the squaring-loss terms at C/N0 T = 10 and 316), so R tuned at 45 dB-Hz is about
    # a thirtieth of the variance at 30 dB-Hz.
    for label in ("frequency R / thermal variance", "code R / thermal variance"):
        assert 10**-1.5 / 1.5 < at_30[label][0] < 10**-1.5 * 1.5, label
    scaled = registry.create("channel_filter", "discriminator", freq_r_scale=0.2)
    assert scaled.assumptions({"coherent_time_s": 0.01, "cn0_dbhz": 30.0})["frequency R / thermal variance"][
        0
    ] == pytest.approx(0.2)


def test_the_report_lists_every_candidates_assumptions_side_by_side(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("""
runs = 2
batch_size = 2
[scenario]
kind = "vector-tracking"
duration_s = 0.3
settle_s = 0.1
channels = 5
[[cases]]
name = "c30"
cn0_dbhz = 30.0
[[candidates]]
name = "slow"
channel_filter = { name = "discriminator" }
nav_filter = { name = "ekf-pv", params = { accel_psd = 0.001 } }
[[candidates]]
name = "fast"
channel_filter = { name = "discriminator", params = { fixed_r_cn0_dbhz = 45.0 } }
nav_filter = { name = "ekf-pv", params = { accel_psd = 10.0 } }
""")
    rows = assumption_rows(load_config(path))
    by = {(r["candidate"], r["component"], r["label"]): r["value"] for r in rows}
    assert by[("slow", "nav_filter", "line-of-sight acceleration PSD")] == 0.001
    assert by[("fast", "nav_filter", "line-of-sight acceleration PSD")] == 10.0
    assert by[("slow", "channel_filter", "frequency R / thermal variance")] == pytest.approx(1.0)
    assert by[("fast", "channel_filter", "frequency R / thermal variance")] < 10**-1.5 * 1.5
    assert all(np.isscalar(r["value"]) or isinstance(r["value"], str) for r in rows)
