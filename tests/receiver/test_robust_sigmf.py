"""Issue 38: a malformed .sigmf-meta beside a recording is refused in one line naming the
file and the field, never with a traceback (on main 14 of 28 such files crashed
`acquire`), and a first capture's core:sample_start is not ignored."""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest

from gnssframework.cli import main
from gnssframework.receiver.frontend.sigmf_meta import read_sigmf_meta

REAL = Path(__file__).parents[1] / "data" / "pocketsdr_L1_4MHz_IQ_100ms.bin"
BASE = {
    "global": {"core:datatype": "ci8", "core:sample_rate": 4e6, "core:version": "1.0.0", "gnssframework:q_sign": -1},
    "captures": [{"core:sample_start": 0, "core:frequency": 1575.42e6, "core:datetime": "2021-12-02T08:47:00Z"}],
    "annotations": [],
}


def _global(key, value):
    meta = copy.deepcopy(BASE)
    if value is _DELETE:
        del meta["global"][key]
    else:
        meta["global"][key] = value
    return meta


def _capture(key, value):
    meta = copy.deepcopy(BASE)
    meta["captures"][0][key] = value
    return meta


_DELETE = object()

MALFORMED = {
    "rate negative": (_global("core:sample_rate", -4e6), "core:sample_rate"),
    "rate zero": (_global("core:sample_rate", 0), "core:sample_rate"),
    "rate a string": (_global("core:sample_rate", "4e6"), "core:sample_rate"),
    "rate a boolean": (_global("core:sample_rate", True), "core:sample_rate"),
    "datatype bogus": (_global("core:datatype", "ci7"), "core:datatype"),
    "datatype missing": (_global("core:datatype", _DELETE), "core:datatype"),
    "datatype a number": (_global("core:datatype", 5), "core:datatype"),
    "datetime not a date": (_capture("core:datetime", "not a date"), "core:datetime"),
    "datetime a number": (_capture("core:datetime", 5), "core:datetime"),
    "frequency 1e30": (_capture("core:frequency", 1e30), "core:frequency"),
    "frequency a string": (_capture("core:frequency", "1575.42e6"), "core:frequency"),
    "global a string": ({"global": "x", "captures": []}, "global"),
    "captures a string": ({"global": BASE["global"], "captures": "x"}, "captures"),
    "captures of strings": ({"global": BASE["global"], "captures": ["x"]}, "captures"),
    "top level a string": ("x", "JSON object"),
    "if a string": (_global("gnssframework:if_hz", "0"), "gnssframework:if_hz"),
    "format a number": (_global("gnssframework:format", 3), "gnssframework:format"),
    "sample start negative": (_capture("core:sample_start", -5), "core:sample_start"),
    "sample start a string": (_capture("core:sample_start", "5"), "core:sample_start"),
    "sample start beyond the data": (_capture("core:sample_start", 10**12), "core:sample_start"),
    "not UTF-8": (b'{"global": {"core:datatype": "ci8\xff\xfe"}}', "not UTF-8"),
    "deeply nested": (b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
    "NaN rate": (
        b'{"global": {"core:datatype": "ci8", "core:sample_rate": NaN, "core:version": "1.0.0"}, '
        b'"captures": [], "annotations": []}',
        "core:sample_rate",
    ),
}


@pytest.fixture
def recording(tmp_path):
    data = tmp_path / "rec.sigmf-data"
    shutil.copyfile(REAL, data)
    return data


@pytest.mark.parametrize("case", list(MALFORMED))
def test_malformed_metadata_is_one_line_naming_file_and_field(case, recording, capsys):
    meta, field = MALFORMED[case]
    meta_file = recording.with_suffix(".sigmf-meta")
    meta_file.write_bytes(meta if isinstance(meta, bytes) else json.dumps(meta).encode())
    code = main(["acquire", str(recording), "--out", str(recording.parent / "a.csv")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("error: ") and "Traceback" not in err
    assert str(meta_file) in err and field in err, err


def test_good_metadata_still_reads(recording, capsys):
    recording.with_suffix(".sigmf-meta").write_text(json.dumps(BASE))
    info = read_sigmf_meta(recording.with_suffix(".sigmf-meta"))
    assert (info.format, info.sample_rate_hz, info.if_hz, info.q_sign, info.sample_start) == ("ci8", 4e6, 0.0, -1, 0)
    assert main(["acquire", str(recording), "--out", str(recording.parent / "a.csv")]) == 0


def test_a_byte_order_mark_is_accepted(recording):
    meta_file = recording.with_suffix(".sigmf-meta")
    meta_file.write_bytes(b"\xef\xbb\xbf" + json.dumps(BASE).encode())
    assert read_sigmf_meta(meta_file).sample_rate_hz == 4e6


def test_non_finite_if_option_is_refused(recording, capsys):
    code = main(
        [
            "acquire",
            str(recording),
            "--format",
            "ci8",
            "--fs",
            "4e6",
            "--if",
            "nan",
            "--out",
            str(recording.parent / "a.csv"),
        ]
    )
    assert code == 2 and "--if" in capsys.readouterr().err
