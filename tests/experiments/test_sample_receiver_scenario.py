"""The ``sample-receiver`` scenario: the whole receiver on generated LNAV recordings.

Its metrics are checked against a hand computation from an independent `receive` call on
the same run's recording; its fixes against the generator's receiver position with the
DLL noise of theory; every candidate of a run reads the same samples (common random
numbers); a run's numbers do not depend on its batch; a bad candidate is one line."""

from __future__ import annotations

import hashlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pymap3d
import pytest

import gnssframework.experiments  # noqa: F401 - registers the scenario kinds
from gnssframework import random_streams, registry
from gnssframework.errors import ConfigError
from gnssframework.experiments import load_config
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.experiments.scenarios import sample_receiver as sample_receiver_module
from gnssframework.experiments.scenarios.sample_receiver_signals import (
    SAMPLE_FORMAT,
    SAMPLE_SCALE,
    transmit_times,
    write_run_recording,
)
from gnssframework.navigation.ephemeris import satellite_state
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.receive import receive

pytestmark = pytest.mark.slow  # end to end (issue 37: the fast lane leaves these out)

# The clean control (no atmosphere, the receiver's models off): these tests check the
# generator's timing and the receiver's noise; tests/experiments/test_sample_receiver_atmosphere.py
# checks the atmosphere.
SCENARIO = {"kind": "sample-receiver", "duration_s": 8.0, "satellites": 4, "rate_hz": 5.0, "atmosphere": False}
CASE = {"name": "45", "cn0_dbhz": 45.0}
SEED_KEY = (11, 3)
C_MPS = 299_792_458.0


@pytest.fixture(scope="module")
def scenario():
    return get_scenario(SCENARIO)


def _scalar(**params):
    return {"channel_filter": registry.create("channel_filter", "scalar", **params)}


@pytest.fixture(scope="module")
def stored_run(scenario, tmp_path_factory):
    """Run 0 through the scenario, and the same run's recording written again by hand."""
    streams = random_streams.run_streams(SEED_KEY[0], SEED_KEY[1:], [0])
    batch = scenario.run_batch(CASE, _scalar(), 1, streams)
    plan = scenario.plan(CASE)
    path = write_run_recording(
        plan, streams.child("samples").generators[0], tmp_path_factory.mktemp("run") / f"run.{SAMPLE_FORMAT}"
    )
    return batch, plan, path


def test_the_generator_puts_each_code_epoch_at_the_transmit_time_of_the_geometry(scenario):
    """Independent truth for the recordings: the pseudorange the samples imply is the range
    (light time and Earth rotation) from the receiver to the satellite at its transmit time."""
    plan = scenario.plan(CASE)
    rx = np.array(plan.receiver_ecef_m)
    t_rx = plan.start_tow_s + 3.0
    t_sv = transmit_times(plan.ephemerides, rx, t_rx)
    st = satellite_state(plan.ephemerides, t_sv)
    tau = t_rx - t_sv
    th = 7.2921151467e-5 * tau  # Sagnac: the Earth-fixed frame turns during the flight
    p = st.position_m
    rot = np.stack(
        [np.cos(th) * p[:, 0] + np.sin(th) * p[:, 1], -np.sin(th) * p[:, 0] + np.cos(th) * p[:, 1], p[:, 2]], axis=1
    )
    assert np.allclose(C_MPS * tau, np.linalg.norm(rot - rx, axis=1), atol=1e-3)
    assert np.all((tau > 0.064) & (tau < 0.090))  # GPS flight times from above the mask


@pytest.mark.slow
def test_metrics_agree_with_a_hand_computation_on_a_stored_run(scenario, stored_run):
    batch, plan, path = stored_run
    result = receive(
        open_recording(path, SAMPLE_FORMAT, plan.sample_rate_hz, 0.0),
        registry.create("acquisition", "pcps"),
        _tracking(scenario),
        rate_hz=5.0,
        rinex=plan.ephemerides,
        ionosphere=False,
        troposphere=False,
        reference_week=plan.week,
    )
    table = result.positions
    assert table is not None and len(table) > 0
    t = table.sample_time_s
    e, n, u = pymap3d.ecef2enu(*table.ecef_m.T, *plan.receiver_lat_lon_h)
    m = batch.metrics
    assert m["horizontal_error_rms"][0] == pytest.approx(np.sqrt(np.mean(e**2 + n**2)), rel=1e-9)
    assert m["vertical_error_rms"][0] == pytest.approx(np.sqrt(np.mean(u**2)), rel=1e-9)
    assert m["time_to_first_fix_s"][0] == pytest.approx(t[0])
    epochs = int(SCENARIO["duration_s"] * SCENARIO["rate_hz"])
    assert m["fix_fraction"][0] == pytest.approx(len(table) / epochs)
    # Channels: the last record row at or before the last epoch, (duration - 1/rate) s in.
    t_last = SCENARIO["duration_s"] - 1 / SCENARIO["rate_hz"]
    grid = np.arange(epochs) / SCENARIO["rate_hz"]
    locked, cn0_sq = 0, [[] for _ in grid]
    for prn, ch in result.tracking.channels.items():
        rows = ch.rows
        times = [r[0] for r in rows]
        for k, tk in enumerate(grid):
            before = [i for i, tr in enumerate(times) if tr <= tk]
            if before and rows[before[-1]][6] and prn in plan.prns:
                cn0_sq[k].append((rows[before[-1]][1] - plan.cn0_dbhz) ** 2)
        last = [i for i, tr in enumerate(times) if tr <= t_last]
        locked += bool(last and rows[last[-1]][6] and prn in plan.prns)
    assert m["channels_locked"][0] == locked == len(plan.prns)
    assert m["false_channels_locked"][0] == 0
    per_epoch = [np.sqrt(np.mean(v)) for v in cn0_sq if v]
    assert m["cn0_error_rms_db"][0] == pytest.approx(np.sqrt(np.mean(np.square(per_epoch))), rel=1e-9)


def _tracking(scenario):
    from gnssframework.receiver.channels import tracking_config

    return tracking_config(coherent_ms=scenario.params.coherent_ms)


def test_fixes_sit_at_the_generators_position_within_the_dll_noise(stored_run):
    batch, plan, path = stored_run
    # EML code jitter with carrier aiding (Kaplan & Hegarty 3rd ed., eq. 8.33 with d = 1 chip,
    # B_L = 1 Hz, T = 10 ms, 45 dB-Hz): sigma^2 = B_L d / (2 C/N0) (1 + 2 / (T C/N0)) chips^2.
    cn0 = 10 ** (plan.cn0_dbhz / 10)
    sigma_m = np.sqrt(1.0 / (2 * cn0) * (1 + 2 / (0.01 * cn0))) * C_MPS / 1.023e6
    # With 4 satellites HDOP and VDOP are a few; 3 sigma of a per-axis PDOP-scaled noise.
    hdop_vdop_bound = 3 * 5.0 * sigma_m
    assert batch.metrics["horizontal_error_rms"][0] < hdop_vdop_bound
    assert batch.metrics["vertical_error_rms"][0] < 2 * hdop_vdop_bound
    # The first fix comes once a whole subframe has arrived: lead_s + 6 s after the start.
    lead = SCENARIO.get("lead_s", 1.5)
    assert lead + 6.0 < batch.metrics["time_to_first_fix_s"][0] < lead + 6.0 + 2 / SCENARIO["rate_hz"] + 0.1


def test_samples_carry_the_noise_of_the_run_stream_only(stored_run):
    _, plan, path = stored_run
    x = np.fromfile(path, np.int8).astype(float) / SAMPLE_SCALE
    # Unit variance per real dimension plus four signals of 45 dB-Hz (2 C/N0 / fs each).
    expected = 1.0 + 4 * 10**4.5 / plan.sample_rate_hz
    assert np.var(x) == pytest.approx(expected, rel=5e-3)


def test_candidates_share_the_samples_of_a_run_and_runs_do_not_depend_on_their_batch(scenario, monkeypatch):
    seen = []
    real = sample_receiver_module.receive_module.receive

    def spy(recording, *args, **kwargs):
        seen.append(hashlib.sha256(Path(recording.path).read_bytes()).hexdigest())
        return real(recording, *args, **kwargs)

    monkeypatch.setattr(sample_receiver_module.receive_module, "receive", spy)
    streams = random_streams.run_streams(SEED_KEY[0], SEED_KEY[1:], [1, 2])
    wide = scenario.run_batch(CASE, _scalar(), 2, streams)
    narrow = scenario.run_batch(CASE, _scalar(dll_bandwidth_hz=0.25), 2, streams)
    assert seen[0] == seen[2] and seen[1] == seen[3]  # candidate 2 reads candidate 1's samples, run by run
    assert seen[0] != seen[1]  # and each run has its own noise
    assert not np.array_equal(wide.metrics["horizontal_error_rms"], narrow.metrics["horizontal_error_rms"])
    alone = scenario.run_batch(CASE, _scalar(), 1, random_streams.run_streams(SEED_KEY[0], SEED_KEY[1:], [2]))
    assert seen[4] == seen[1]
    for name, value in alone.metrics.items():  # the same seed and run give the same numbers in any batch
        np.testing.assert_array_equal(value, wide.metrics[name][1:], err_msg=name)


CONFIG = """
runs = 1
[scenario]
kind = "sample-receiver"
[[cases]]
name = "a"
[[candidates]]
name = "x"
channel_filter = {{ name = "{name}" }}
"""


@pytest.mark.slow
def test_a_bad_channel_filter_is_one_line_naming_the_field(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.format(name="scalr"))
    with pytest.raises(ConfigError) as exc:
        load_config(path)
    assert exc.value.field == "candidates[0].channel_filter.name" and "scalar" in str(exc.value)
    assert "\n" not in str(exc.value)
    path.write_text(CONFIG.format(name="hatch"))
    with pytest.raises(ConfigError, match="cannot track on samples.*scalar") as exc:
        load_config(path)
    assert "\n" not in str(exc.value)
    out = subprocess.run(
        [sys.executable, "-m", "gnssframework", "compare", str(path), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2 and "hatch" in out.stderr and "Traceback" not in out.stderr


def test_too_many_satellites_or_too_short_a_recording_is_refused(tmp_path):
    scenario = get_scenario({"kind": "sample-receiver"})
    with pytest.raises(ConfigError, match="cases\\[0\\].satellites: only"):
        scenario.check_case({"name": "a", "satellites": 12}, "cases[0]")
    with pytest.raises(ConfigError, match="scenario.duration_s"):
        get_scenario({"kind": "sample-receiver", "duration_s": 5.0}).check_case({"name": "a"}, "cases[0]")
    with pytest.raises(ConfigError, match="subframe_tow_s"):
        get_scenario({"kind": "sample-receiver", "subframe_tow_s": 345613.0})


@pytest.mark.slow
def test_a_candidates_nav_filter_runs_on_the_run_s_pseudoranges(scenario, stored_run):
    """A candidate's ``nav_filter`` reaches `receive`: the scenario's series are those of
    `receive(..., nav_filter=ekf-pv)` on the same run's recording, and differ from the
    least squares' (the run without one)."""
    from gnssframework.experiments.scenarios.sample_receiver_metrics import run_series
    from gnssframework.plugin_ref import PluginSpec

    least_squares, plan, path = stored_run
    streams = random_streams.run_streams(SEED_KEY[0], SEED_KEY[1:], [0])
    plugins = {**_scalar(), "nav_filter": registry.create("nav_filter", "ekf-pv")}
    filtered = scenario.run_batch(CASE, plugins, 1, streams)
    by_hand = receive(
        open_recording(path, SAMPLE_FORMAT, plan.sample_rate_hz, 0.0),
        registry.create("acquisition", "pcps"),
        _tracking(scenario),
        rate_hz=5.0,
        rinex=plan.ephemerides,
        ionosphere=False,
        troposphere=False,
        reference_week=plan.week,
        nav_filter=PluginSpec("nav_filter", "ekf-pv", {}),
    )
    series = run_series(by_hand, plan.prns, plan.cn0_dbhz, plan.receiver_lat_lon_h, scenario.time_s())
    for name in ("horizontal_error_m", "vertical_error_m"):
        e = series[name][np.isfinite(series[name])]
        assert e.size > 0
        metric = name.replace("_m", "_rms")
        assert np.isclose(filtered.metrics[metric][0], np.sqrt(np.mean(e**2)), rtol=1e-12)
        assert filtered.metrics[metric][0] != least_squares.metrics[metric][0]  # the filter, not the least squares
    # the filter starts at the first least-squares fix: the same time to first fix
    assert filtered.metrics["time_to_first_fix_s"][0] == least_squares.metrics["time_to_first_fix_s"][0]


def test_a_nav_filter_that_cannot_run_on_pseudoranges_is_one_line_naming_the_field(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.format(name="scalar") + 'nav_filter = { name = "ins-ekf" }\n')
    with pytest.raises(ConfigError, match="cannot run on pseudoranges and Dopplers.*ekf-pv") as exc:
        load_config(path)
    assert exc.value.field == "candidates[0].nav_filter.name" and "\n" not in str(exc.value)
