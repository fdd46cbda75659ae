"""Issue 38: command-line input that misled (each accepted or misworded on main): NaN
samples hiding every satellite, non-finite options, a device given as a recording, a
missing output folder named by a temporary file, impossible --truth/--rate/--duration/
--prns values, NaN in a tracking summary."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework.cli import main

REAL = Path(__file__).parents[1] / "data" / "pocketsdr_L1_4MHz_IQ_100ms.bin"
RINEX2 = Path(__file__).parents[1] / "data" / "07590920.05o"
FOUND = {16, 26, 29, 31, 32}  # PocketSDR's strong satellites in this file (/work/shared/data/README.md)


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "Traceback" not in err, err
    return err


def test_nan_samples_are_zeroed_counted_and_do_not_hide_the_satellites(tmp_path, capsys):
    raw = np.fromfile(REAL, np.int8).astype(np.float32)
    nan_at = np.linspace(1000, 60_000, 10).astype(int)  # inside the 8 ms the search reads
    raw[nan_at] = np.nan
    path = tmp_path / "nan.bin"
    raw.tofile(path)
    out = tmp_path / "a.csv"
    assert main(["acquire", str(path), "--format", "cf32_le", "--fs", "4e6", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "note: nan.bin: 10 non-finite values (NaN or inf) in the samples read were set to 0" in said
    found = {int(r.split(",")[0]) for r in out.read_text().splitlines()[1:]}
    assert FOUND <= found


@pytest.mark.parametrize(
    "option, value", [("--if", "nan"), ("--fs", "inf"), ("--doppler-max", "inf"), ("--pfa", "nan")]
)
def test_non_finite_options_are_refused_naming_them(option, value, tmp_path, capsys):
    given = {"--fs": "4e6", option: value}
    args = ["acquire", str(REAL), "--format", "ci8", "--out", str(tmp_path / "a.csv")]
    args += [x for kv in given.items() for x in kv]
    assert main(args) == 2
    assert f"{option}: must be a finite number" in _one_error_line(capsys)


def test_smooth_refuses_an_infinite_r(tmp_path, capsys):
    assert (
        main(["smooth", str(RINEX2), "--prn", "G08", "--filter", "kf", "--r", "inf", "--out", str(tmp_path / "s.csv")])
        == 2
    )
    assert "--r: must be a finite number" in _one_error_line(capsys)


def test_a_device_is_not_a_recording(tmp_path, capsys):
    assert main(["acquire", "/dev/zero", "--format", "ci8", "--fs", "4e6", "--out", str(tmp_path / "a.csv")]) == 2
    err = _one_error_line(capsys)
    assert "/dev/zero: not a regular file" in err and "no such file" not in err


def test_a_missing_output_folder_is_named(tmp_path, capsys):
    out = tmp_path / "missing" / "a.csv"
    assert main(["acquire", str(REAL), "--format", "ci8", "--fs", "4e6", "--out", str(out)]) == 2
    err = _one_error_line(capsys)
    assert f"the output folder {out.parent} does not exist" in err and ".tmp" not in err


def test_a_full_disk_names_the_output(tmp_path):
    import errno

    from gnssframework.io.files import atomic_open

    with pytest.raises(OSError) as err:
        with atomic_open(tmp_path / "out.csv") as fh:
            fh.write("x")
            raise OSError(errno.ENOSPC, "No space left on device")
    assert err.value.filename == str(tmp_path / "out.csv") and err.value.errno == errno.ENOSPC
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize(
    "extra, says",
    [
        (["--truth", "91,0,0"], "--truth: latitude 91"),
        (["--truth", "0,200,0"], "--truth: longitude 200"),
        (["--truth", "nan,nan,nan"], "--truth: LAT,LON,H must be finite"),
        (["--rate", "1e9"], "--rate: must be at most 1000 Hz"),
        (["--duration", "1e-9"], "--duration: must be at least"),
        (["--prns", "1", "1", "1"], "--prns: PRN 1 given more than once"),
    ],
)
def test_impossible_receiver_options_are_refused(extra, says, tmp_path, capsys):
    code = main(["receive", str(REAL), "--format", "ci8", "--fs", "4e6", "--out", str(tmp_path / "r")] + extra)
    assert code == 2
    assert says in _one_error_line(capsys)


def test_a_channel_that_never_locked_prints_no_nan(tmp_path, capsys):
    code = main(
        [
            "track",
            str(REAL),
            "--format",
            "ci8",
            "--fs",
            "4e6",
            "--q-sign",
            "-1",
            "--duration",
            "0.02",
            "--no-plots",
            "--out",
            str(tmp_path / "t"),
        ]
    )
    said = capsys.readouterr().out
    assert code == 0 and "PRN 26" in said
    assert "nan" not in said.lower().replace("nan.bin", "")


def test_a_never_locked_channel_leaves_its_summary_cells_empty_not_nan(tmp_path):
    """issue 38: no non-finite number in a summary; a channel that never locked has no C/N0
    while locked, and a channel without rows no last Doppler: empty cells, as pandas reads
    a missing number."""
    import csv as csv_module

    from gnssframework.receiver.acquisition.search import AcquisitionResult
    from gnssframework.receiver.channels.records import ChannelRecord, TrackingResult
    from gnssframework.receiver.channels.report import write_tracking_outputs

    acq = [AcquisitionResult(p, True, 1000.0, 10, 100.0, 40.0, 30.0, 20.0) for p in (3, 7)]
    never = ChannelRecord(3, rows=[(0.001 * k, 20.0, 0.1, 1000.0, 5.0, 0.0, 0, 0, 1.0, 0.0, 1) for k in range(5)])
    empty = ChannelRecord(7)
    result = TrackingResult({3: never, 7: empty}, acq, 0.005, "scalar")
    write_tracking_outputs(tmp_path, result, plots=False)
    with open(tmp_path / "summary.csv", newline="") as fh:
        rows = list(csv_module.DictReader(fh))
    assert [r["prn"] for r in rows] == ["3", "7"]
    assert rows[0]["cn0_dbhz_locked"] == "" and rows[0]["locked_fraction"] == "0"
    assert rows[1]["doppler_hz_last"] == "" and rows[1]["cn0_dbhz_locked"] == ""
    assert "nan" not in (tmp_path / "summary.csv").read_text().lower()


def test_a_summary_counts_each_channels_own_code_periods():
    """Rows count code periods (``coherent_ms``): 1 ms on GPS L1 C/A, 4 ms on Galileo E1, so
    five one-period rows span 5 ms on the one and 20 ms on the other; with several signals
    (``signal_of``) each channel gets its own."""
    from gnssframework.receiver.acquisition.search import AcquisitionResult
    from gnssframework.receiver.channels.records import ChannelRecord, TrackingResult
    from gnssframework.receiver.channels.report import channel_summary
    from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
    from gnssframework.signal.gps_l1ca import GPS_L1CA

    acq = [AcquisitionResult(p, True, 1000.0, 10, 100.0, 40.0, 30.0, 20.0) for p in (3, 1003)]
    rows = [(0.001 * k, 40.0, 0.9, 1000.0, 5.0, 0.0, 1, 0, 1.0, 0.0, 1) for k in range(5)]
    result = TrackingResult({3: ChannelRecord(3, rows=rows), 1003: ChannelRecord(1003, rows=rows)}, acq, 0.02, "scalar")
    assert [s["tracked_s"] for s in channel_summary(result)] == pytest.approx([0.005, 0.005])
    assert [s["tracked_s"] for s in channel_summary(result, GALILEO_E1B_BOC11)] == pytest.approx([0.02, 0.02])
    mixed = channel_summary(result, signal_of=lambda prn: GALILEO_E1B_BOC11 if prn >= 1000 else GPS_L1CA)
    assert [s["tracked_s"] for s in mixed] == pytest.approx([0.005, 0.02])
