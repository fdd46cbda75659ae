"""The ``sample-recording`` scenario: the receiver on disjoint segments of a recorded file.

The file is `test_receiver_fix`'s kind of recording (five satellites of real broadcast
records seen from a known station, LNAV, 45 dB-Hz), two segments of 12 s long, each with
a subframe boundary 2.6 s in. Checked: run 0's metrics are those of an independent
`receive` on the first 12 s cut out by hand (the scenario reads the segment it says);
run 1 is the second segment (its first fix comes at the same time into its segment as
run 0's, and its numbers differ from run 0's); the errors against the truth are within
the code noise; without a truth those metrics are undefined and the others unchanged (a
run's numbers do not depend on its batch); a segment past the end is refused naming how
many the file holds."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework.experiments  # noqa: F401 - registers the scenario kinds
from gnssframework import random_streams, registry
from gnssframework.errors import ConfigError
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.experiments.scenarios.sample_recording import segment_bounds
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording, write_recording
from gnssframework.receiver.navigation.receive import position_errors, receive
from lnav_recordings import FS, NAV, STATION, TOW0, WEEK, _strongest, write_lnav_recording

SEGMENT_S, RATE_HZ = 12.0, 5.0


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    import pymap3d

    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    path = write_lnav_recording(tmp_path_factory.mktemp("rec") / "recorded.sigmf-data", sats, TOW0, 2 * SEGMENT_S, 9)
    truth = [float(v) for v in pymap3d.ecef2geodetic(*STATION)]
    params = {
        "kind": "sample-recording",
        "recording": str(path),
        "ephemeris": str(NAV),
        "segment_s": SEGMENT_S,
        "rate_hz": RATE_HZ,
        "gps_week": WEEK,
        "ionosphere": False,
        "truth_lat_lon_h": truth,
    }
    scenario = get_scenario(params)
    scenario.check_case({"name": "rec"}, "cases[0]")
    plugins = {"channel_filter": registry.create("channel_filter", "scalar")}
    both = scenario.run_batch({"name": "rec"}, plugins, 2, random_streams.run_streams(5, (1,), [0, 1]))
    no_truth = get_scenario({**params, "truth_lat_lon_h": None})
    second = no_truth.run_batch({"name": "rec"}, plugins, 1, random_streams.run_streams(5, (1,), [1]))
    # Run 0 by hand: the first 12 s cut out of the file and given to `receive`.
    rec = open_recording(path)
    first = tmp_path_factory.mktemp("first") / "first.sigmf-data"
    write_recording(first, rec.read(0, int(SEGMENT_S * FS)).astype(complex), "ci16_le", FS, 0.0)
    hand = receive(
        open_recording(first),
        registry.create("acquisition", "pcps"),
        tracking_config(),
        rate_hz=RATE_HZ,
        rinex=read_rinex_nav(NAV),
        ionosphere=False,
        reference_week=WEEK,
    ).positions
    return truth, both, second, hand


def _value(batch, name):
    return np.asarray(batch.metrics[name], float)


@pytest.mark.slow
def test_run_0_is_the_first_segment_read_by_hand(recorded):
    truth, both, _, table = recorded
    assert table is not None and len(table) > 5
    enu = position_errors(table, tuple(truth))
    assert _value(both, "horizontal_error_rms")[0] == pytest.approx(
        np.sqrt(np.mean(np.sum(enu[:, :2] ** 2, 1))), rel=1e-9
    )
    assert _value(both, "vertical_error_rms")[0] == pytest.approx(np.sqrt(np.mean(enu[:, 2] ** 2)), rel=1e-9)
    assert _value(both, "time_to_first_fix_s")[0] == pytest.approx(table.sample_time_s[0], abs=1e-9)
    assert _value(both, "fix_fraction")[0] == pytest.approx(len(table) / (SEGMENT_S * RATE_HZ))
    assert _value(both, "channels_locked")[0] == 5
    mean = table.ecef_m.mean(axis=0)
    assert _value(both, "horizontal_scatter_rms")[0] <= np.sqrt(np.mean(np.sum((table.ecef_m - mean) ** 2, 1))) + 1e-9


@pytest.mark.slow
def test_run_1_is_the_second_segment_with_its_own_noise_and_errors_within_the_code_noise(recorded):
    _, both, _, table = recorded
    first_fix = _value(both, "time_to_first_fix_s")
    # Both segments hold a subframe boundary 2.6 s in: the TOW has arrived 8.6 s in.
    assert np.all((first_fix > 8.6) & (first_fix < 8.6 + 1.5))
    assert _value(both, "horizontal_error_rms")[0] != _value(both, "horizontal_error_rms")[1]
    # 45 dB-Hz: about 1.7 m of code noise per satellite (`test_receiver_fix`), scaled by
    # the dilution of precision of the five satellites (the same 24 s apart): 4 sigma.
    assert np.all(_value(both, "horizontal_error_rms") < 4 * 1.7 * np.max(table.columns["hdop"]))
    assert np.all(_value(both, "vertical_error_rms") < 4 * 1.7 * np.max(table.columns["vdop"]))
    assert np.all(_value(both, "channels_locked") == 5)


@pytest.mark.slow
def test_without_a_truth_the_errors_are_undefined_and_the_rest_is_the_same_run(recorded):
    _, both, second, _ = recorded
    assert np.isnan(_value(second, "horizontal_error_rms")[0]) and np.isnan(_value(second, "vertical_error_rms")[0])
    for name in (
        "time_to_first_fix_s",
        "fix_fraction",
        "channels_locked",
        "horizontal_scatter_rms",
        "vertical_scatter_rms",
    ):
        assert _value(second, name)[0] == _value(both, name)[1], name


@pytest.mark.slow
def test_segments_map_to_samples_and_one_past_the_end_is_refused(recorded, tmp_path):
    rec = open_recording(
        write_recording(tmp_path / "short.sigmf-data", np.zeros(int(2 * SEGMENT_S * FS), complex), "ci16_le", FS, 0.0)
    )
    assert segment_bounds(rec, 0.0, SEGMENT_S, 1) == (int(SEGMENT_S * FS), int(SEGMENT_S * FS))
    with pytest.raises(
        ConfigError,
        match=r"scenario.segment_s: run 2's segment ends at 36.000 s, past the end of "
        r"short.sigmf-data \(24.000 s\): the file holds 2 segment\(s\)",
    ):
        segment_bounds(rec, 0.0, SEGMENT_S, 2)
    with pytest.raises(ConfigError, match="scenario.recording: nowhere.bin: no such file"):
        get_scenario({"kind": "sample-recording", "recording": "nowhere.bin", "segment_s": 5.0}).check_case(
            {"name": "x"}, "cases[0]"
        )
