"""Issue 38: an acquisition result no GPS sky can give is refused with its likely cause,
never reported as satellites found (a wrong --format once gave "31 satellites found")."""

from __future__ import annotations

import pytest
from pathlib import Path

import numpy as np

from gnssframework.cli import main
from gnssframework.receiver.acquisition.plausibility import (
    MAX_DOPPLER_SPREAD_HZ,
    MAX_VISIBLE_GPS,
    format_hint,
    implausible_acquisition,
)
from gnssframework.receiver.acquisition.search import AcquisitionResult

DATA = Path(__file__).parents[1] / "data"
REAL = DATA / "pocketsdr_L1_4MHz_IQ_100ms.bin"  # ci8, 4 MHz, IF 0 (tests/data/README.md)


def _result(prn, detected, stat=10.0, doppler=0.0, threshold=50.0):
    return AcquisitionResult(prn, detected, doppler, 0, 0.0, 40.0, stat, threshold)


def test_real_ci8_recording_read_as_ci16_is_refused_naming_the_format(tmp_path, capsys):
    """On main this printed "31 satellites found" and exited 0."""
    out = tmp_path / "a.csv"
    code = main(["acquire", str(REAL), "--format", "ci16_le", "--fs", "4e6", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "--format ci8?" in err and str(REAL) in err and "PRNs found" in err
    assert not out.exists()


def test_real_recording_read_right_passes_the_check(tmp_path, capsys):
    out = tmp_path / "a.csv"
    assert main(["acquire", str(REAL), "--format", "ci8", "--fs", "4e6", "--out", str(out)]) == 0
    found = [int(r.split(",")[0]) for r in out.read_text().splitlines()[1:]]
    # PocketSDR finds 16 26 29 31 32 (and 18) in this file (/work/shared/data/README.md)
    assert {16, 26, 29, 31, 32} <= set(found) and len(found) <= MAX_VISIBLE_GPS


def test_count_above_the_visible_maximum_is_implausible():
    ok = [_result(p, p <= MAX_VISIBLE_GPS) for p in range(1, 33)]
    assert implausible_acquisition(ok) is None
    bad = [_result(p, p <= MAX_VISIBLE_GPS + 1) for p in range(1, 33)]
    assert "17 of 32 PRNs found" in implausible_acquisition(bad)


def test_noise_floor_above_the_threshold_is_implausible_even_with_few_found():
    quiet = [_result(p, p <= 4, stat=60.0 if p <= 4 else 20.0) for p in range(1, 11)]
    assert implausible_acquisition(quiet) is None  # median 20 below the threshold 50
    loud = [_result(p, p <= 6, stat=60.0 if p <= 6 else 20.0) for p in range(1, 11)]
    assert "median peak statistic" in implausible_acquisition(loud)  # median 60: 6 of 10 found is noise


def test_doppler_spread_beyond_satellite_motion_is_implausible():
    near = [_result(1, True, 90, -5000.0), _result(2, True, 90, 5000.0)] + [_result(p, False) for p in range(3, 11)]
    assert implausible_acquisition(near) is None
    far = [_result(1, True, 90, -6000.0), _result(2, True, 90, 6000.0)] + [_result(p, False) for p in range(3, 11)]
    assert 12000 > MAX_DOPPLER_SPREAD_HZ and "span 12000 Hz" in implausible_acquisition(far)


def test_format_hints_from_the_bytes(tmp_path):
    from gnssframework import registry

    def src(name):
        return registry.create("sample_source", name)

    rng = np.random.default_rng(1)
    levels = rng.choice(np.array([-3, -1, 1, 3], np.int8), 40_000)
    eight = tmp_path / "eight.bin"
    eight.write_bytes(levels.tobytes())
    assert "--format ci8?" in format_hint(eight, src("ci16_le"))
    assert "check --format" in format_hint(eight, src("ci8"))  # read right: nothing to say
    sixteen = tmp_path / "sixteen.bin"
    sixteen.write_bytes(levels.astype("<i2").tobytes())  # small 16-bit values: high bytes 0 or -1
    assert "--format ci16_le?" in format_hint(sixteen, src("ci8"))
    assert "check --format" in format_hint(sixteen, src("ci16_le"))
    assert "integer samples" in format_hint(eight, src("cf32_le"))
    floats = tmp_path / "f.bin"
    floats.write_bytes(rng.normal(size=20_000).astype("<f4").tobytes())
    assert "check --format" in format_hint(floats, src("cf32_le"))


@pytest.mark.slow
def test_receive_refuses_the_wrong_format_before_tracking(tmp_path, capsys):
    """On main, receive tracked the 31 'satellites' of a ci8 file read as ci16_le."""
    code = main(["receive", str(REAL), "--format", "ci16_le", "--fs", "4e6", "--out", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert code == 2 and "--format ci8?" in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()


def test_detections_that_do_not_recur_where_predicted_are_refused(tmp_path, capsys):
    """Seven PRNs of the ci8 file read as ci16_le: too few for the count and noise-floor
    checks, but none of the six "found" recurs 8 ms later (main reported 6 satellites)."""
    code = main(
        [
            "acquire",
            str(REAL),
            "--format",
            "ci16_le",
            "--fs",
            "4e6",
            "--out",
            str(tmp_path / "a.csv"),
            "--prns",
            "1",
            "2",
            "3",
            "4",
            "5",
            "6",
            "7",
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and "are not found again 8 ms later" in err and "--format ci8?" in err


def test_a_sample_rate_off_by_250_ppm_drifts_the_code_and_is_refused(tmp_path, capsys):
    """At 4.001 MHz instead of 4 MHz the code phase of every satellite moves by
    8 ms x 1.023 Mchip/s x 250e-6 = 2 chips between the two searches (tolerance 1 chip)."""
    code = main(["acquire", str(REAL), "--format", "ci8", "--fs", "4.001e6", "--out", str(tmp_path / "a.csv")])
    err = capsys.readouterr().err
    assert code == 2 and "not found again" in err and "--fs" in err


def test_a_blank_recording_is_refused_as_such(tmp_path, capsys):
    """All-zero samples: main divided by the zero noise floor (NumPy warnings) and said
    nothing about the file."""
    path = tmp_path / "zero.bin"
    path.write_bytes(bytes(400_000))
    assert main(["acquire", str(path), "--format", "ci8", "--fs", "4e6", "--out", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "are all 0" in err and "zero-filled" in err
