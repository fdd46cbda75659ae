"""The ``receive`` command's options as a user types them: coordinates of the southern and
western hemispheres (negative numbers, which argparse takes for options) in both spellings,
and the vector mode's navigation-filter process noise."""

from __future__ import annotations

import pytest

from gnssframework import cli

SANTIAGO = "-33.4,-70.6,500"


@pytest.fixture
def parsed(monkeypatch):
    """The namespace ``receive`` is called with, without running it."""
    seen = {}
    monkeypatch.setattr(cli, "_cmd_receive", lambda args: seen.setdefault("args", args) and 0)
    return seen


@pytest.mark.parametrize("spelling", [["--truth", SANTIAGO], [f"--truth={SANTIAGO}"]])
def test_truth_takes_negative_coordinates(parsed, spelling):
    assert cli.main(["receive", "rec.bin", "--out", "o", *spelling]) == 0
    assert cli._truth_from_args(parsed["args"]) == (-33.4, -70.6, 500.0)


@pytest.mark.parametrize("spelling", [["--approx-position", "-33.1,-70.2,-20"],
                                      ["--approx-position=-33.1,-70.2,-20"],
                                      ["--approx-position", "-.5,10,0"]])
def test_approx_position_takes_negative_coordinates(parsed, spelling):
    assert cli.main(["receive", "rec.bin", "--out", "o", "--tracking", "vector", *spelling]) == 0
    assert parsed["args"].approx_position == spelling[-1].split("=")[-1]
    assert parsed["args"].tracking == "vector"


def test_only_the_coordinate_options_take_a_value_that_looks_like_an_option():
    # A negative value after another option, or a real option after --truth, is left to argparse.
    assert cli.attach_negative_values(["--truth", "--out", "-1", "--rate", "-2"]) == \
        ["--truth", "--out", "-1", "--rate", "-2"]
    assert cli.attach_negative_values(["--", "--truth", "-1,2,3"]) == ["--", "--truth", "-1,2,3"]
    assert cli.attach_negative_values(["--truth", "-1,2,3", "x"]) == ["--truth=-1,2,3", "x"]


@pytest.fixture
def tiny_recording(tmp_path):
    import numpy as np

    from gnssframework.receiver.frontend import write_recording

    return write_recording(tmp_path / "noise.sigmf-data", np.ones(4096, complex), "ci16_le", 2.046e6, 0.0)


@pytest.fixture
def received(monkeypatch):
    """The keyword arguments ``receive`` gets from the command (it is not run)."""
    from gnssframework.receiver.navigation import receive as receive_module

    seen = {}

    class Stop(Exception):
        pass

    def fake(*args, **kwargs):
        seen.update(kwargs)
        raise Stop

    monkeypatch.setattr(receive_module, "receive", fake)
    return seen, Stop


def test_vector_accel_psd_reaches_the_navigation_filter(tiny_recording, tmp_path, received):
    from gnssframework import registry

    seen, stop = received
    with pytest.raises(stop):
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--tracking", "vector",
                  "--vector-accel-psd", "2.5"])
    vector = seen["vector"]
    assert vector.nav_params == {"accel_psd": 2.5}
    assert registry.create("nav_filter", vector.nav_filter, **vector.nav_params).params.accel_psd == 2.5
    with pytest.raises(stop):  # without it, the filter's own default
        cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), "--tracking", "vector"])
    assert seen["vector"].nav_params == {}


@pytest.mark.parametrize("extra", [["--tracking", "vector", "--vector-accel-psd", "0"],
                                   ["--tracking", "vector", "--vector-accel-psd", "nan"],
                                   ["--vector-accel-psd", "1"]])
def test_a_bad_or_misplaced_vector_accel_psd_exits_2_naming_it(tiny_recording, tmp_path, capsys, extra):
    assert cli.main(["receive", str(tiny_recording), "--out", str(tmp_path / "o"), *extra]) == 2
    assert "--vector-accel-psd" in capsys.readouterr().err
