"""Carrier smoothing (reference 001): Hatch and Kalman forms, slips, RINEX, the smooth command."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.experiments import get_scenario
from gnssframework.io.rinex import read_code_carrier

RNX = Path(__file__).resolve().parents[1] / "examples" / "data" / "simulated_pass.rnx"


def _run(name, code, carrier, **params):
    f = gf.registry.create("channel_filter", name, **params)
    f.reset(code.shape[1:], gf.RunContext(epoch_interval_s=1.0))
    return np.stack([f.step({"pseudorange_m": r, "carrier_m": c})["smoothed_m"] for r, c in zip(code, carrier)])


def _clean(rng, K=400, runs=200, sigma=1.0):
    truth = 2e7 + np.cumsum(rng.normal(300.0, 1.0, (K, runs)), axis=0)
    return truth, truth + sigma * rng.standard_normal((K, runs)), truth + 12345.678


def test_hatch_with_a_long_window_is_the_kalman_filter_without_process_noise(rng):
    # Independent truth: a KF with Q -> 0 started at P = R has gain 1/n at epoch n, which is
    # exactly the growing-window Hatch filter.
    truth, code, carrier = _clean(rng, K=200, runs=5)
    hatch = _run("hatch", code, carrier, window=10_000)
    kf = _run("kf-smoother", code, carrier, q=1e-14, r=1.0)
    np.testing.assert_allclose(hatch, kf, atol=1e-6)


def test_hatch_steady_state_variance_is_sigma2_over_2tau_minus_1(rng):
    tau, sigma = 50, 1.0
    truth, code, carrier = _clean(rng, K=600, runs=400, sigma=sigma)
    err = _run("hatch", code, carrier, window=tau)[300:] - truth[300:]
    assert np.var(err) == pytest.approx(sigma**2 / (2 * tau - 1), rel=0.15)


@pytest.fixture(scope="module")
def smoothing_results():
    scen = get_scenario({"kind": "carrier-smoothing"})
    out = {}
    comps = {
        "raw": {},
        "hatch": {"channel_filter": {"name": "hatch", "params": {"window": 100}}},
        "kf": {"channel_filter": {"name": "kf-smoother", "params": {"q": 1e-3, "r": 1.25}}},
        "adaptive-kf": {"channel_filter": {"name": "kf-smoother", "params": {
            "q": 1e-3, "r": 1.25, "adapter": "ml-q", "adapter_params": {"window": 10, "warmup": 20, "q_ceiling": 1e4}}}},
        "kf-slip-reset": {"channel_filter": {"name": "kf-smoother", "params": {"q": 1e-3, "r": 1.25,
                                                                              "slip_threshold_m": 4.0}}},
    }
    for name, c in comps.items():
        out[name] = scen.run_batch({}, scen.build(c), 20, np.random.default_rng(1)).metrics
    return out


def test_adaptive_q_recovers_from_slips_faster_than_the_plain_kalman_smoother(smoothing_results):
    rec = {k: np.nanmean(v["slip_recovery_epochs"]) for k, v in smoothing_results.items()}
    assert rec["adaptive-kf"] < 0.6 * rec["kf"]
    assert rec["adaptive-kf"] < 25  # the patent: back to normal within about 15 epochs


def test_slip_reset_gives_the_lowest_error(smoothing_results):
    err = {k: np.mean(v["error_rmse"]) for k, v in smoothing_results.items()}
    assert err["kf-slip-reset"] < 0.6 * err["raw"]
    assert err["kf-slip-reset"] == min(err.values())


def test_reads_the_generated_rinex_file_through_georinex():
    data = read_code_carrier(RNX, "G08")
    assert data.time_s.size == 721 and np.all(np.diff(data.time_s) == 1.0)
    cmc = data.pseudorange_m - data.carrier_m
    jumps = np.abs(np.diff(cmc))
    assert np.sum(jumps > 4.0) >= 1  # the file carries cycle slips
    with pytest.raises(gf.DataFileError, match="no observations of G31; satellites: G08"):
        read_code_carrier(RNX, "G31")


@pytest.mark.parametrize("corrupt, line, message", [
    (lambda lines: lines.__setitem__(20, lines[20][:3] + "  2040X487.070" + lines[20][17:]), 21, "not a number"),
    (lambda lines: lines.__setitem__(12, "> 2020 05 01 10 30 xx"), 13, "malformed epoch line"),
    (lambda lines: lines.__delitem__(11), None, "END OF HEADER"),
])
def test_malformed_rinex_names_the_file_and_line(tmp_path, corrupt, line, message):
    lines = RNX.read_text().splitlines()
    corrupt(lines)
    bad = tmp_path / "bad.rnx"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(gf.DataFileError, match=(rf"bad.rnx:{line}: " if line else "bad.rnx") + ".*" + message):
        read_code_carrier(bad, "G08")


def test_cli_smooth_writes_csv(tmp_path):
    out = tmp_path / "smoothed.csv"
    proc = subprocess.run([sys.executable, "-m", "gnssframework", "smooth", str(RNX), "--prn", "G08", "--out", str(out),
                           "--filter", "kf", "--slip-threshold", "4"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    rows = [r.split(",") for r in out.read_text().splitlines()]
    assert rows[0] == ["epoch", "time_s", "pseudorange_m", "carrier_m", "smoothed_m", "slip_detected"]
    assert len(rows) == 722 and sum(int(r[5]) for r in rows[1:]) >= 1
    code = np.array([float(r[2]) for r in rows[1:]])
    smooth = np.array([float(r[4]) for r in rows[1:]])
    # Smoothing removes most of the code noise: the smoothed track is far less rough.
    assert np.std(np.diff(smooth, 2)) < 0.3 * np.std(np.diff(code, 2))


def test_slip_sizes_must_be_ordered_at_config_time():
    with pytest.raises(gf.ConfigError, match="scenario.slip_max_cycles"):
        get_scenario({"kind": "carrier-smoothing", "slip_min_cycles": 20, "slip_max_cycles": 10})
