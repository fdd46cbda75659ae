"""Plugin parameters a run cannot use are refused when the config loads, naming the field
from the config's root: lengths and signs of q, p0, initial_std and clock_psd, and loop
bandwidths against the interval T the harness runs them at (B_L T at most 0.2)."""

from __future__ import annotations

import pytest

import gnssframework as gf
from gnssframework.cli import main
from gnssframework.experiments import load_config
from gnssframework.receiver.tracking.loop_filters import MAX_BANDWIDTH_TIME, LoopFilter

MULTIPATH = """
name = "mp"
runs = 2
batch_size = 2
[scenario]
kind = "multipath"
epochs = 50
[[cases]]
name = "psi"
psi = 0.8
[[candidates]]
name = "ukf"
estimator = "ukf"
nav_filter = { name = "position-ca", params = { PARAMS } }
"""

SCINT = """
name = "sc"
runs = 2
batch_size = 2
[scenario]
kind = "scintillation"
duration_s = 1.0
coherent_time_s = 0.01
settle_s = 0.2
[[cases]]
name = "s4"
s4 = 0.5
[[candidates]]
name = "loop"
channel_filter = { name = "NAME", params = { PARAMS } }
"""

DEEP = """
name = "deep"
runs = 2
batch_size = 2
[scenario]
kind = "deep-integration"
profile = "straight"
duration_s = 0.5
coherent_time_s = 0.002
imu_interval_s = 0.004
nco_interval_s = 0.004
update_interval_s = 0.1
settle_s = 0.1
channels = 5
[[cases]]
name = "c45"
cn0_dbhz = 45.0
[[candidates]]
name = "cand"
channel_filter = CHANNEL
nav_filter = { name = "ins-ekf", params = { PARAMS } }
"""

VECTOR = """
name = "vt"
runs = 2
batch_size = 2
[scenario]
kind = "vector-tracking"
duration_s = 0.2
channels = 5
settle_s = 0.05
[[cases]]
name = "c45"
cn0_dbhz = 45.0
[[candidates]]
name = "iq"
channel_filter = { name = "iq-filter", params = { PARAMS } }
nav_filter = "ekf-pv"
"""

IQ_EQUIVALENT = '{ name = "iq-filter", params = { estimator = "ukf", adaptive = false, output = "equivalent" } }'


def _error(tmp_path, text) -> str:
    path = tmp_path / "c.toml"
    path.write_text(text)
    with pytest.raises(gf.ConfigError) as err:
        load_config(path)
    msg = str(err.value)
    assert "\n" not in msg
    return msg


def _loads(tmp_path, text) -> None:
    path = tmp_path / "c.toml"
    path.write_text(text)
    load_config(path)


@pytest.mark.parametrize("params", ["p0 = [10.0, 1.0, 0.1]", "q0 = [1.0, 0.0, 0.01]"])
def test_the_fixture_configs_load(tmp_path, params):
    _loads(tmp_path, MULTIPATH.replace("PARAMS", params))
    _loads(tmp_path, SCINT.replace("NAME", "scalar").replace("PARAMS", "pll_bandwidth_hz = 10.0"))
    _loads(tmp_path, DEEP.replace("CHANNEL", IQ_EQUIVALENT).replace("PARAMS", "clock_psd = [0.0, 0.1]"))
    _loads(tmp_path, VECTOR.replace("PARAMS", "adaptive = false"))


@pytest.mark.parametrize(
    "params, message",
    [
        (
            "p0 = [10.0, 1.0]",
            "candidates[0].nav_filter.params.p0: List should have at least 3 items after validation, not 2",
        ),
        ("p0 = [10.0, 0.0, 0.1]", "candidates[0].nav_filter.params.p0[1]: Input should be greater than 0 (got 0.0)"),
        (
            "q0 = [1.0, -0.1, 0.01]",
            "candidates[0].nav_filter.params.q0[1]: Input should be greater than or equal to 0 (got -0.1)",
        ),
    ],
)
def test_position_filter_lengths_and_signs(tmp_path, params, message):
    assert _error(tmp_path, MULTIPATH.replace("PARAMS", params)).startswith(message)


@pytest.mark.parametrize(
    "name, params, message",
    [
        (
            "kf-carrier-loop",
            "q = [-0.01, 0.1]",
            "candidates[0].channel_filter.params.q[0]: Input should be greater than or equal to 0 (got -0.01)",
        ),
        (
            "kf-carrier-loop",
            "q = [0.01, 0.1, 1.0]",
            "candidates[0].channel_filter.params.q: needs 2 values for states = 2 (got [0.01, 0.1, 1.0])",
        ),
        (
            "kf-carrier-loop",
            "states = 3, initial_std = [0.5, 5.0], q = [0.01, 0.1, 1.0]",
            "candidates[0].channel_filter.params.initial_std: needs at least 3 values for states = 3 (got [0.5, 5.0])",
        ),
        (
            "kf-carrier-loop",
            "initial_std = [0.0, 5.0]",
            "candidates[0].channel_filter.params.initial_std[0]: Input should be greater than 0 (got 0.0)",
        ),
        (
            "kf-carrier-loop",
            "initial_std = 0",
            "candidates[0].channel_filter.params.initial_std: Input should be a valid list (got 0)",
        ),
        (
            "scalar",
            "dll_bandwidth_hz = 1e6",
            "candidates[0].channel_filter.params.dll_bandwidth_hz: Input should be less "
            "than or equal to 200 (got 1000000.0)",
        ),
        (
            "scalar",
            "fll_bandwidth_hz = 1e6",
            "candidates[0].channel_filter.params.fll_bandwidth_hz: Input should be less "
            "than or equal to 200 (got 1000000.0)",
        ),
    ],
)
def test_carrier_loop_values_are_refused_naming_the_field(tmp_path, name, params, message):
    assert _error(tmp_path, SCINT.replace("NAME", name).replace("PARAMS", params)) == message


@pytest.mark.parametrize(
    "params, message",
    [
        (
            "q = [1e-3, 1e-8, -1e-5, 1e-4, 1e-2]",
            "candidates[0].channel_filter.params.q[2]: Input should be greater than or equal to 0 (got -1e-05)",
        ),
        (
            "initial_std = [2.0, 0.05, 0.3, 5.0]",
            "candidates[0].channel_filter.params.initial_std: List should have at "
            "least 5 items after validation, not 4",
        ),
        (
            "initial_std = [2.0, 0.05, 0.0, 5.0, 5.0]",
            "candidates[0].channel_filter.params.initial_std[2]: Input should be greater than 0 (got 0.0)",
        ),
    ],
)
def test_iq_filter_lengths_and_signs(tmp_path, params, message):
    assert _error(tmp_path, VECTOR.replace("PARAMS", params)).startswith(message)


def test_a_negative_clock_psd_is_refused_naming_the_field(tmp_path):
    text = DEEP.replace("CHANNEL", IQ_EQUIVALENT).replace("PARAMS", "clock_psd = [0.1, -1.0]")
    assert _error(tmp_path, text).startswith(
        "candidates[0].nav_filter.params.clock_psd[1]: Input should be greater than or equal to 0 (got -1.0)"
    )


def _too_wide(T: float) -> float:
    """A bandwidth (Hz) just above the B_L T bound at T, but allowed at 1 ms."""
    return 1.25 * MAX_BANDWIDTH_TIME / T


@pytest.mark.parametrize("field", ["pll_bandwidth_hz", "fll_bandwidth_hz", "dll_bandwidth_hz"])
def test_a_loop_bandwidth_too_wide_for_the_scenario_interval_is_refused_at_load(tmp_path, field):
    text = SCINT.replace("NAME", "scalar").replace("PARAMS", f"{field} = {_too_wide(0.01)}")
    msg = _error(tmp_path, text)
    assert msg.startswith(f"candidates[0].channel_filter.params.{field}: B_L T = 0.25 at T = 0.01 s is too large")
    assert "at most 0.2: 20 Hz at this T" in msg


def test_the_bandwidth_is_checked_at_a_case_s_own_interval(tmp_path):
    # 15 Hz is fine at the scenario's 10 ms and too wide at the case's 20 ms.
    text = SCINT.replace("NAME", "scalar").replace("PARAMS", "pll_bandwidth_hz = 15.0")
    _loads(tmp_path, text)
    msg = _error(tmp_path, text.replace("s4 = 0.5", "s4 = 0.5\ncoherent_time_s = 0.02"))
    assert msg.startswith("candidates[0].channel_filter.params.pll_bandwidth_hz: B_L T = 0.3 at T = 0.02 s")


def test_a_nested_carrier_filter_bandwidth_is_named_under_the_nav_filter(tmp_path):
    carrier = f'carrier_filter = {{ name = "kf-carrier-loop", params = {{ dll_bandwidth_hz = {_too_wide(0.002)} }} }}'
    text = DEEP.replace("CHANNEL", IQ_EQUIVALENT).replace("PARAMS", carrier)
    assert _error(tmp_path, text).startswith(
        "candidates[0].nav_filter.params.carrier_filter.params.dll_bandwidth_hz: "
        "B_L T = 0.25 at T = 0.002 s is too large"
    )


def test_a_loose_candidate_fll_too_wide_is_refused_not_reported_as_a_singular_geometry(tmp_path):
    channel = f'{{ name = "scalar", params = {{ fll_bandwidth_hz = {_too_wide(0.002)} }} }}'
    text = DEEP.replace("CHANNEL", channel).replace("PARAMS", "")
    assert _error(tmp_path, text).startswith("candidates[0].channel_filter.params.fll_bandwidth_hz: B_L T = 0.25")


def test_the_loop_filter_itself_refuses_a_too_wide_assist():
    with pytest.raises(gf.ConfigError, match=r"^assist_bandwidth_hz: B_L T = 0.5 at T = 0.01 s"):
        LoopFilter(3, 10.0, 0.01, 50.0)


@pytest.mark.slow
def test_the_cli_exits_2_with_the_field_before_any_run(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text(MULTIPATH.replace("PARAMS", "p0 = [10.0, 1.0]"))
    assert main(["compare", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: candidates[0].nav_filter.params.p0: ") and err.count("\n") == 1
    assert not (tmp_path / "out").exists()
