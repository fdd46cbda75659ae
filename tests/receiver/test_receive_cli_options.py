"""The ``receive`` command's options as a user types them: coordinates of the southern and
western hemispheres (negative numbers, which argparse takes for options) in both spellings,
and the vector mode's navigation-filter process noise."""

from __future__ import annotations

import re

import pytest

from gnssframework import cli

SANTIAGO = "-33.4,-70.6,500"


@pytest.fixture
def parsed(monkeypatch):
    """The namespace ``receive`` is called with, without running it."""
    seen = {}
    monkeypatch.setattr(cli, "_cmd_receive", lambda args: seen.setdefault("args", args) and 0)
    return seen


@pytest.mark.slow
@pytest.mark.parametrize("spelling", [["--truth", SANTIAGO], [f"--truth={SANTIAGO}"]])
def test_truth_takes_negative_coordinates(parsed, spelling):
    assert cli.main(["receive", "rec.bin", "--out", "o", *spelling]) == 0
    assert cli._truth_from_args(parsed["args"]) == (-33.4, -70.6, 500.0)


@pytest.mark.slow
@pytest.mark.parametrize(
    "spelling",
    [
        ["--approx-position", "-33.1,-70.2,-20"],
        ["--approx-position=-33.1,-70.2,-20"],
        ["--approx-position", "-.5,10,0"],
    ],
)
def test_approx_position_takes_negative_coordinates(parsed, spelling):
    assert cli.main(["receive", "rec.bin", "--out", "o", "--tracking", "vector", *spelling]) == 0
    assert parsed["args"].approx_position == spelling[-1].split("=")[-1]
    assert parsed["args"].tracking == "vector"


def test_only_the_coordinate_options_take_a_value_that_looks_like_an_option():
    # A negative value after another option, or a real option after --truth, is left to argparse.
    assert cli.attach_negative_values(["--truth", "--out", "-1", "--rate", "-2"]) == [
        "--truth",
        "--out",
        "-1",
        "--rate",
        "-2",
    ]
    assert cli.attach_negative_values(["--", "--truth", "-1,2,3"]) == ["--", "--truth", "-1,2,3"]
    assert cli.attach_negative_values(["--truth", "-1,2,3", "x"]) == ["--truth=-1,2,3", "x"]


@pytest.fixture
def tiny_recording(tmp_path):
    import numpy as np

    from gnssframework.receiver.frontend import write_recording

    return write_recording(tmp_path / "noise.sigmf-data", np.ones(4096, complex), "ci16_le", 2.046e6, 0.0)


@pytest.fixture
def received(monkeypatch):
    """The keyword arguments ``receive`` gets from the command (it is not run; nor are the
    acquisition and its plausibility check, which the tiny recording is too short for)."""
    from gnssframework.receiver.acquisition import plausibility, report
    from gnssframework.receiver.navigation import receive as receive_module

    monkeypatch.setattr(plausibility, "check_samples", lambda *a, **k: None)
    monkeypatch.setattr(plausibility, "check_acquisition", lambda *a, **k: None)
    monkeypatch.setattr(report, "acquire_recording", lambda *a, **k: [])

    seen = {}

    class Stop(Exception):
        pass

    def fake(*args, **kwargs):
        seen.update(kwargs)
        raise Stop

    monkeypatch.setattr(receive_module, "receive", fake)
    return seen, Stop


@pytest.mark.slow
def test_vector_accel_psd_reaches_the_navigation_filter(tiny_recording, tmp_path, received):
    from gnssframework import registry

    seen, stop = received
    with pytest.raises(stop):
        cli.main(
            [
                "receive",
                str(tiny_recording),
                "--out",
                str(tmp_path / "o"),
                "--tracking",
                "vector",
                "--vector-accel-psd",
                "2.5",
            ]
        )
    vector = seen["vector"]
    assert vector.nav_params == {"accel_psd": 2.5}
    assert registry.create("nav_filter", vector.nav_filter, **vector.nav_params).params.accel_psd == 2.5
    with pytest.raises(stop):  # without it, the filter's own default
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--tracking", "vector"])
    assert seen["vector"].nav_params == {}


@pytest.mark.slow
@pytest.mark.parametrize(
    "extra",
    [
        ["--tracking", "vector", "--vector-accel-psd", "0"],
        ["--tracking", "vector", "--vector-accel-psd", "nan"],
        ["--vector-accel-psd", "1"],
    ],
)
def test_a_bad_or_misplaced_vector_accel_psd_exits_2_naming_it(tiny_recording, tmp_path, capsys, extra):
    assert cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), *extra]) == 2
    assert "--vector-accel-psd" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["0", "-2", "1.5", "many"])
def test_a_bad_workers_value_exits_2_with_the_librarys_message(tiny_recording, tmp_path, capsys, value):
    from gnssframework.errors import ConfigError
    from gnssframework.receiver.channels.groups import check_workers

    with pytest.raises(SystemExit) as exit_:  # argparse's exit for an option's bad value
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--workers", value])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    with pytest.raises(ConfigError) as library:
        check_workers(int(value) if value.lstrip("-").isdigit() else value)
    assert "--workers" in err and library.value.detail in err


NAV = __import__("pathlib").Path(__file__).parents[1] / "data" / "07590920.05n"
#: The header of NAV: ION ALPHA and ION BETA as written there.
NAV_ALPHA = (1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08)
NAV_BETA = (8.8060e04, 1.6380e04, -1.9660e05, -1.3110e05)
#: An assisted start in NAV's span (Saturday 2005-04-02 00:05, GPS week 1316) near its station.
ASSISTED = [
    "--tracking",
    "vector",
    "--ephemeris",
    str(NAV),
    "--approx-position",
    "35.7,139.5,100",
    "--start-time",
    "1316,518703.4",
]


@pytest.mark.slow
def test_an_assisted_start_takes_the_ephemeris_files_klobuchar(tiny_recording, tmp_path, received):
    seen, stop = received
    with pytest.raises(stop):
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), *ASSISTED])
    assert seen["assist"].iono.alpha == NAV_ALPHA and seen["assist"].iono.beta == NAV_BETA
    with pytest.raises(stop):
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), *ASSISTED, "--no-iono"])
    assert seen["assist"].iono is None and seen["ionosphere"] is False


@pytest.mark.slow
def test_receive_takes_the_week_of_the_ephemeris_file_without_week(tiny_recording, tmp_path, received):
    seen, stop = received
    with pytest.raises(stop):
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--ephemeris", str(NAV)])
    assert seen["reference_week"] == 1316  # NAV's records: 2005-04-01 23:59:44 to 2005-04-03 00:00:00
    with pytest.raises(stop):
        cli.main(
            ["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--ephemeris", str(NAV), "--week", "1317"]
        )
    assert seen["reference_week"] == 1317  # --week rules


def test_an_ephemeris_of_another_day_is_named_as_such(tiny_recording, tmp_path, capsys, received):
    argv = ["receive", str(tiny_recording), "--out", str(tmp_path / "o"), *ASSISTED]
    argv[argv.index("1316,518703.4")] = "1316,300000"  # Wednesday: two days before NAV's records
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "the ephemeris does not cover the recording" in err
    assert "2005-04-01 23:59:44 to 2005-04-03 00:00:00 GPS" in err and "no LNAV" not in err


@pytest.mark.slow
def test_the_ephemeris_files_klobuchar_and_the_weighting_reach_the_fixes(tiny_recording, tmp_path, received):
    """Where no channel decodes page 18, the fixes take the navigation file's header (as
    RTKLIB does); ``--weighting rtklib`` picks RTKLIB's error model."""
    seen, stop = received
    with pytest.raises(stop):
        cli.main(
            [
                "receive",
                str(tiny_recording),
                "--out",
                str(tmp_path / "o"),
                "--ephemeris",
                str(NAV),
                "--weighting",
                "rtklib",
            ]
        )
    assert seen["iono_fallback"].alpha == NAV_ALPHA and seen["weighting"] == "rtklib"
    with pytest.raises(stop):
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--ephemeris", str(NAV), "--no-iono"])
    assert seen["iono_fallback"] is None and seen["weighting"] == "elevation"


def test_the_cli_weightings_are_the_solvers():
    from gnssframework.navigation.pvt import WEIGHTINGS

    assert cli.WEIGHTINGS == WEIGHTINGS


def test_the_cli_raim_methods_are_the_modules():
    from gnssframework.navigation.integrity import RAIM_METHODS

    assert cli.RAIM_METHODS == RAIM_METHODS


def test_raim_options_are_read_and_checked(parsed):
    parsed.clear()
    assert cli.main(["receive", "rec.bin", "--out", "o", "--raim", "--raim-pmd", "1e-2"]) == 0
    options = cli._raim_from_args(parsed["args"])
    assert (options.method, options.false_alarm, options.missed_detection) == ("chi2", 1e-5, 1e-2)
    parsed.clear()
    assert cli.main(["receive", "rec.bin", "--out", "o", "--raim", "ss", "--raim-pfa", "1e-3"]) == 0
    options = cli._raim_from_args(parsed["args"])
    assert (options.method, options.false_alarm) == ("ss", 1e-3)
    parsed.clear()
    assert cli.main(["receive", "rec.bin", "--out", "o"]) == 0
    assert cli._raim_from_args(parsed["args"]) is None
    from gnssframework.errors import ConfigError

    parsed.clear()
    assert cli.main(["receive", "rec.bin", "--out", "o", "--raim-pfa", "1e-3"]) == 0
    with pytest.raises(ConfigError, match="--raim-pfa"):
        cli._raim_from_args(parsed["args"])
    parsed.clear()
    assert cli.main(["receive", "rec.bin", "--out", "o", "--raim", "--raim-pfa", "2"]) == 0
    with pytest.raises(ConfigError, match="raim_false_alarm") as refused:  # the library's parameter...
        cli._raim_from_args(parsed["args"])
    assert cli.option_field(refused.value.field) == "--raim-pfa"  # ...the command line's option


def test_off_a_terminal_receive_prints_a_line_per_phase_and_per_tenth_of_the_signal(
    tiny_recording, tmp_path, capsys, received
):
    """Issue 41: a log, CI or a notebook cell saw nothing for the whole run."""
    from gnssframework.receiver.channels.records import TrackingResult
    from gnssframework.receiver.navigation import receive as receive_module
    from gnssframework.receiver.navigation.receive import ReceiveResult

    def tracked_nothing(*args, progress=None, **kwargs):
        for fraction in (0.05, 0.25, 0.5):  # the tracker's reports
            if progress is not None:
                progress(fraction)
        return ReceiveResult(TrackingResult({}, [], 0.002, "scalar"), None, None)

    receive_module.receive = tracked_nothing  # (monkeypatched by `received`: restored after the test)
    assert cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--prn", "3"]) == 1
    err = capsys.readouterr().err.splitlines()  # capsys: not a terminal
    # A line as each phase ends (the acquisition is faked here: it found nothing).
    assert err[0].startswith(
        "noise.sigmf-data: acquisition found 0 of 0 PRNs; tracking, decoding LNAV, positioning, 0:00:0"
    )
    signal_s = 4096 / 2.046e6
    tenths = [line for line in err if " % (" in line]
    # One line per tenth crossed (a report past two tenths prints two lines, both at its
    # value), the last ones when the run is over; each with the signal time processed.
    done = [int(line.split(": ")[1].split("/")[0]) for line in tenths]
    assert done == [25, 25, 50, 50, 50, 100, 100, 100, 100, 100]
    for d, line in zip(done, tenths):
        processed, total = line.split(", ")[1].removesuffix(" s of signal").split("/")
        assert float(total) == pytest.approx(signal_s, abs=5e-4)
        assert float(processed) == pytest.approx(d / 100 * signal_s, abs=5e-4)
        assert re.search(r", \d+\.\d\dx real time, \d:\d\d:\d\d elapsed$", line)
    assert cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--prn", "3", "--quiet"]) == 1
    assert capsys.readouterr().err == ""
