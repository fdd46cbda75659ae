"""Sample sources: every format written by the project's generator reads back, SigMF metadata
round-trips through the ``sigmf`` package, streaming covers the file once, bad input is named."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import builtin_names
from gnssframework.errors import ConfigError, DataFileError
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples, write_recording
from gnssframework.receiver.frontend.sigmf_meta import read_sigmf_meta

FS = 2.6e6
FORMATS = {"ri8": False, "ci8": True, "ci16_le": True, "cf32_le": True, "ri2": False, "ci2": True, "cu8": True}


def test_the_built_in_formats_are_sample_source_plugins():
    assert set(builtin_names("sample_source")) == set(FORMATS)


@pytest.mark.parametrize("fmt", sorted(FORMATS))
@pytest.mark.parametrize("q_sign", [1, -1])
def test_every_format_round_trips_with_its_sigmf_metadata(tmp_path, fmt, q_sign):
    rng = np.random.default_rng(1)
    cplx = FORMATS[fmt]
    if_hz = 0.0 if cplx else 0.6e6
    x = synthesize_samples([SatelliteSignal(5, 60.0, 1200.0, 100.0)], 0.002, FS, if_hz, rng, complex_samples=cplx)
    levels = fmt.endswith("2")
    scale = 1.0 if levels else (1000.0 if fmt == "ci16_le" else (1.0 if fmt == "cf32_le" else 20.0))
    path = write_recording(
        tmp_path / "rec.sigmf-data",
        x,
        fmt,
        FS,
        if_hz,
        q_sign=q_sign if cplx else 1,
        scale=scale,
        start_time="2026-01-01T00:00:00Z",
    )
    rec = open_recording(path)  # everything from the metadata
    assert (rec.info.format, rec.info.sample_rate_hz, rec.info.if_hz) == (fmt, FS, if_hz)
    assert rec.info.q_sign == (q_sign if cplx else 1) and rec.info.start_time == "2026-01-01T00:00:00Z"
    assert rec.n_samples == x.size and rec.trailing_bytes == 0
    got = rec.read(0, rec.n_samples)
    assert np.iscomplexobj(got) == cplx
    if levels:  # the 2-bit quantiser keeps the nearest of -3, -1, 1, 3 on each branch
        parts = [(got.real, x.real), (got.imag, x.imag)] if cplx else [(got, x)]
        for g, v in parts:
            assert set(np.unique(g)) <= {-3.0, -1.0, 1.0, 3.0}
            assert np.all(np.abs(g - np.clip(v, -3, 3)) <= 1.0 + 1e-6)
    else:  # integers: rounding to the LSB (and clipping, none at these scales)
        tol = 1e-6 * np.max(np.abs(x * scale)) if fmt == "cf32_le" else 0.5 * np.sqrt(2 if cplx else 1) + 1e-6
        assert np.max(np.abs(got - x * scale)) <= tol


@pytest.mark.parametrize("fmt", sorted(FORMATS))
def test_components_are_the_samples_as_stored_without_the_q_sign(tmp_path, fmt):
    """`read_components` (what the correlator reads): the SigMF types' own values, not a
    float copy, interleaved I then Q, the Q sign left to the reader; equal to `read`."""
    rng = np.random.default_rng(2)
    cplx = FORMATS[fmt]
    x = synthesize_samples(
        [SatelliteSignal(5, 60.0, 1200.0, 100.0)], 0.001, FS, 0.0 if cplx else 0.6e6, rng, complex_samples=cplx
    )
    path = write_recording(
        tmp_path / "rec.sigmf-data",
        x,
        fmt,
        FS,
        0.0 if cplx else 0.6e6,
        q_sign=-1 if cplx else 1,
        scale=1.0 if fmt.endswith("2") or fmt == "cf32_le" else 20.0,
    )
    rec = open_recording(path)
    comps = rec.read_components(7, 300)
    want = {"ri8": np.int8, "ci8": np.int8, "ci16_le": np.int16, "cf32_le": np.float32}.get(fmt, np.float32)
    assert comps.dtype == want and comps.size == 300 * (2 if cplx else 1)
    z = comps[0::2] + 1j * rec.info.q_sign * comps[1::2].astype(float) if cplx else comps
    np.testing.assert_array_equal(z, rec.read(7, 300))


def test_streaming_in_blocks_gives_the_whole_file_once_and_a_truncated_tail_is_reported(tmp_path):
    rng = np.random.default_rng(2)
    x = rng.integers(-100, 100, size=2 * 10_001).astype(np.int8)
    path = tmp_path / "r.bin"
    path.write_bytes(x.tobytes() + b"\x07")  # a last sample cut in half
    rec = open_recording(path, format="ci8", sample_rate_hz=FS, if_hz=0.0)
    assert rec.trailing_bytes == 1 and rec.n_samples == 10_001
    blocks = list(rec.blocks(3000))
    assert [b[0] for b in blocks] == [0, 3000, 6000, 9000]
    joined = np.concatenate([b[1] for b in blocks])
    np.testing.assert_array_equal(joined, x[0::2] + 1j * x[1::2].astype(np.float32))


def test_packed_reads_that_start_inside_a_byte(tmp_path):
    rng = np.random.default_rng(3)
    x = rng.choice([-3.0, -1.0, 1.0, 3.0], size=400)
    path = write_recording(tmp_path / "p.bin", x, "ri2", FS, 0.5e6, sigmf=False)
    rec = open_recording(path, format="ri2", sample_rate_hz=FS, if_hz=0.5e6)
    np.testing.assert_array_equal(rec.read(7, 13), x[7:20])


def test_command_line_values_win_over_the_metadata(tmp_path):
    x = np.ones(8, complex)
    path = write_recording(tmp_path / "a.sigmf-data", x, "ci8", FS, 0.0)
    rec = open_recording(path, sample_rate_hz=4e6, q_sign=-1)
    assert rec.info.sample_rate_hz == 4e6 and rec.info.q_sign == -1


def test_the_metadata_is_valid_sigmf_and_states_the_if_as_an_rf_frequency(tmp_path):
    write_recording(tmp_path / "a.sigmf-data", np.ones(8, complex), "ci16_le", FS, 4.092e6 - 4e6)
    meta = json.loads((tmp_path / "a.sigmf-meta").read_text())
    assert meta["global"]["core:datatype"] == "ci16_le"
    assert meta["captures"][0]["core:frequency"] == pytest.approx(1575.42e6 - 0.092e6)
    del meta["global"]["gnssframework:if_hz"]  # another tool's file: the IF from core:frequency
    (tmp_path / "a.sigmf-meta").write_text(json.dumps(meta))
    assert read_sigmf_meta(tmp_path / "a.sigmf-meta").if_hz == pytest.approx(0.092e6)


def test_another_bands_metadata_states_its_carrier_and_is_read_with_its_signal(tmp_path, capsys):
    # An L2 recording (another tool's metadata: no project IF key) is 1227.6 MHz centred;
    # read as GPS L1 C/A its IF would be 347.82 MHz: refused in one line naming the field
    # and the options, read with the L2C signal its IF is the offset from 1227.6 MHz.
    from gnssframework import registry
    from gnssframework.cli import main

    l2c = registry.signal_spec("gps-l2c")
    write_recording(tmp_path / "l2.sigmf-data", np.ones(8, complex), "ci8", FS, 0.05e6, signal=l2c)
    meta = json.loads((tmp_path / "l2.sigmf-meta").read_text())
    assert meta["captures"][0]["core:frequency"] == pytest.approx(1227.6e6 - 0.05e6)
    del meta["global"]["gnssframework:if_hz"]
    (tmp_path / "l2.sigmf-meta").write_text(json.dumps(meta))
    with pytest.raises(ConfigError, match=r"l2.sigmf-meta captures\[0\] core:frequency.*347\.87 MHz from gps-l1ca's"):
        open_recording(tmp_path / "l2.sigmf-data")
    assert open_recording(tmp_path / "l2.sigmf-data", signal=l2c).info.if_hz == pytest.approx(0.05e6)
    assert main(["acquire", str(tmp_path / "l2.sigmf-data"), "--out", str(tmp_path / "o")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--signal NAME" in err[0] and "--if-hz" in err[0]
    # With --signal the recording opens: what stops acquisition is its length, not its IF.
    main(["acquire", str(tmp_path / "l2.sigmf-data"), "--signal", "gps-l2c", "--out", str(tmp_path / "o")])
    assert "core:frequency" not in capsys.readouterr().err


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"format": "ci4"}, "format"),
        ({"format": "ci8"}, "sample_rate_hz"),
        ({"format": "ci8", "sample_rate_hz": 1e6}, "sample_rate_hz"),
        ({"format": "ri8", "sample_rate_hz": FS, "if_hz": 2e6}, "if_hz"),
        ({"format": "ci8", "sample_rate_hz": FS, "q_sign": 2}, "q_sign"),
    ],
)
def test_bad_options_are_named(tmp_path, kwargs, field):
    path = tmp_path / "r.bin"
    path.write_bytes(bytes(100))
    with pytest.raises(ConfigError) as err:
        open_recording(path, **kwargs)
    assert err.value.field == field


def test_missing_empty_and_broken_metadata_files(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        open_recording(tmp_path / "none.bin", format="ci8", sample_rate_hz=FS)
    (tmp_path / "one.bin").write_bytes(b"\x01")
    with pytest.raises(ConfigError, match="no whole sample"):
        open_recording(tmp_path / "one.bin", format="ci8", sample_rate_hz=FS)
    (tmp_path / "bad.sigmf-data").write_bytes(bytes(8))
    (tmp_path / "bad.sigmf-meta").write_text('{\n  "global": \n')
    with pytest.raises(DataFileError, match="bad.sigmf-meta"):
        open_recording(tmp_path / "bad.sigmf-data")


def test_a_recording_tuned_to_another_if_reads_the_same_samples_and_refuses_one_out_of_band(tmp_path):
    """`Recording.tuned`: the samples are the file's, the IF the one given (a second
    signal of a wide-band file); an IF beyond half the sample rate is refused in one line
    naming the file."""
    x = np.exp(2j * np.pi * 0.1 * np.arange(4000))
    path = write_recording(tmp_path / "wide.sigmf-data", x, "cf32_le", 8e6, 1e6)
    rec = open_recording(path)
    other = rec.tuned(-2.5e6)
    assert other.info.if_hz == -2.5e6 and rec.info.if_hz == 1e6
    assert other.info.sample_rate_hz == rec.info.sample_rate_hz and other.n_samples == rec.n_samples
    np.testing.assert_array_equal(other.read(100, 50), rec.read(100, 50))
    with pytest.raises(ConfigError, match="outside the band of wide.sigmf-data") as exc:
        rec.tuned(4.5e6)
    assert len(str(exc.value).splitlines()) == 1
