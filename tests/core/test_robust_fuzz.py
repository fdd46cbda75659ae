"""Issue 38: fuzzing what a user hands the framework: comparison configs, SigMF metadata,
RINEX and NMEA lines, command lines. Every outcome is a plausible result or one line of
library error naming what is wrong: never a traceback (an exception other than the
library's), never a non-finite number in a summary. Bounded in examples and without
deadlines so the module runs in well under a minute; a failure prints the smallest input
Hypothesis found."""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from gnssframework.cli import main
from gnssframework.errors import GnssFrameworkError
from gnssframework.experiments import load_config

from two_candidates import two_candidate_config

DATA = Path(__file__).parents[1] / "data"
REAL = DATA / "pocketsdr_L1_4MHz_IQ_100ms.bin"
FUZZ = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
NON_FINITE_WORD = re.compile(r"(?<![\w.])[-+]?(nan|inf|infinity)(?![\w])", re.IGNORECASE)


def _one_line(exc: BaseException) -> None:
    """A library error of one line that says something."""
    assert isinstance(exc, GnssFrameworkError), f"{type(exc).__name__}: {exc}"
    text = str(exc)
    assert text and "\n" not in text and "Traceback" not in text, text


@contextlib.contextmanager
def _fresh(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# -- values a user may write -------------------------------------------------------------------

NUMBERS = st.one_of(
    st.integers(-(10**15), 10**15),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e300, -1e300, 1e-300, 1e12, 0.5, 2]),
)
TEXT = st.one_of(
    st.text(max_size=12),
    st.sampled_from(["", ".", "..", "../x", "a/b", "a\x00b", "ci8", "kf", "nan", "2021-12-02T08:47:00Z", "1e6"]),
)
SCALARS = st.one_of(NUMBERS, TEXT, st.booleans())
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(["name", "params", "x", "q0"]), inner, max_size=3)
    ),
    max_leaves=8,
)


def _toml(value) -> str:
    """``value`` written as a TOML value (inline tables for dicts)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # TOML basic strings take JSON's escapes
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{ " + ", ".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in value.items()) + " }"


# The places of the smallest comparison config a fuzzed value goes in: (old text, key).
CONFIG_PLACES = [
    ('name = "fuzz"', "name"),
    ("runs = 4", "runs"),
    ("batch_size = 2", "batch_size"),
    ("epochs = 40", "epochs"),
    ('name = "only"', "name"),
    ('name = "a"', "name"),
    ('name = "b"', "name"),
    ('nav_filter = { name = "position-ca" }', "nav_filter"),
    ('estimator = { name = "kf" }', "estimator"),
    ("workers = 1", "workers"),
    ("[executor]", "[executor]\naddress"),
]
EXTRA_PLACES = ["psi", "dt_s", "seed", "reference", "metrics"]


@FUZZ
@given(
    place=st.sampled_from(CONFIG_PLACES + [(None, k) for k in EXTRA_PLACES]),
    value=VALUES,
    params=st.dictionaries(
        st.sampled_from(["r0", "q0", "dt_s", "accel_psd", "bogus"]),
        st.one_of(NUMBERS, st.lists(NUMBERS, min_size=3, max_size=3), VALUES),
        max_size=2,
    ),
    claim=st.one_of(
        st.none(),
        st.dictionaries(st.sampled_from(["ratio_min", "ratio_max", "within", "direction"]), VALUES, max_size=2),
    ),
)
def test_fuzzed_configs_load_or_fail_in_one_line(tmp_path_factory, place, value, params, claim):
    text = two_candidate_config("fuzz")
    old, key = place
    if old is None:
        text = text.replace('kind = "multipath"', f'kind = "multipath"\n{key} = {_toml(value)}')
    else:
        text = text.replace(old, f"{key} = {_toml(value)}", 1)
    if params:
        text = text.replace(
            'nav_filter = { name = "position-ca" }',
            f'nav_filter = {{ name = "position-ca", params = {_toml(params)} }}',
            1,
        )
    if claim is not None:
        body = "\n".join(f"{k} = {_toml(v)}" for k, v in claim.items())
        text += f'[[claims]]\ncandidate = "a"\nreference = "b"\nmetric = "lat_error_rmse"\n{body}\n'
    with _fresh(tmp_path_factory) as folder:
        path = folder / "c.toml"
        path.write_text(text)
        try:
            config = load_config(path)
        except Exception as exc:  # noqa: BLE001 - the assertion says which kind it was
            _one_line(exc)
            return
    for name in [config.name] + [c.name for c in config.cases] + [c.name for c in config.candidates]:
        assert name not in ("", ".", "..") and "/" not in name and "\x00" not in name
    for cand in config.candidates:
        for spec in cand.components().values():
            for v in (spec.params or {}).values():
                for x in v if isinstance(v, list) else [v]:
                    assert not isinstance(x, float) or (math.isfinite(x) and abs(x) <= 1e100), (spec, x)


# -- SigMF metadata -------------------------------------------------------------------------------

SIGMF_KEYS = [
    "core:datatype",
    "core:sample_rate",
    "core:version",
    "gnssframework:q_sign",
    "gnssframework:if_hz",
    "gnssframework:format",
]
CAPTURE_KEYS = ["core:sample_start", "core:frequency", "core:datetime"]
GOOD_GLOBAL = {"core:datatype": "ci8", "core:sample_rate": 4e6, "core:version": "1.0.0", "gnssframework:q_sign": -1}
GOOD_CAPTURE = {"core:sample_start": 0, "core:frequency": 1575.42e6}
META_VALUES = st.one_of(
    VALUES, st.sampled_from([4e6, 8e6, 1575.42e6, 1575.42e6 + 1e5, "ci8", "ci16_le", "cf32_le", "ri8", 1, -1, 0])
)


@st.composite
def sigmf_meta(draw) -> bytes:
    kind = draw(st.sampled_from(["fields", "fields", "fields", "structure", "bytes"]))
    if kind == "bytes":
        return draw(st.binary(max_size=64))
    glob, capture = dict(GOOD_GLOBAL), dict(GOOD_CAPTURE)
    for key, value in draw(st.dictionaries(st.sampled_from(SIGMF_KEYS), META_VALUES, max_size=3)).items():
        glob[key] = value
    for key, value in draw(st.dictionaries(st.sampled_from(CAPTURE_KEYS), META_VALUES, max_size=2)).items():
        capture[key] = value
    for key in draw(st.lists(st.sampled_from(SIGMF_KEYS + CAPTURE_KEYS), max_size=2)):
        glob.pop(key, None)
        capture.pop(key, None)
    meta = {"global": glob, "captures": [capture], "annotations": []}
    if kind == "structure":
        meta[draw(st.sampled_from(["global", "captures", "annotations"]))] = draw(VALUES)
    return json.dumps(meta).encode()


@FUZZ
@given(meta=sigmf_meta())
def test_fuzzed_sigmf_metadata_opens_or_fails_in_one_line(tmp_path_factory, meta):
    from gnssframework.receiver.frontend import open_recording

    with _fresh(tmp_path_factory) as folder:
        data = folder / "rec.sigmf-data"
        data.write_bytes(REAL.read_bytes()[:40_000])
        (folder / "rec.sigmf-meta").write_bytes(meta)
        try:
            rec = open_recording(data)
        except Exception as exc:  # noqa: BLE001
            _one_line(exc)
            # the metadata file's field, or the parameter the library names (the CLI shows its option)
            assert "rec.sigmf-meta" in str(exc) or str(exc).startswith(
                ("format", "sample_rate_hz", "if_hz", "q_sign", "recording")
            ), str(exc)
            return
        info = rec.info
        assert math.isfinite(info.sample_rate_hz) and info.sample_rate_hz >= 2.046e6
        assert math.isfinite(info.if_hz) and abs(info.if_hz) < info.sample_rate_hz / 2
        assert info.q_sign in (1, -1) and rec.n_samples > 0


# -- RINEX and NMEA lines ---------------------------------------------------------------------------


def _head(path: Path, epochs: int, epoch_line: re.Pattern) -> list[str]:
    lines = path.read_text().splitlines()
    end = next(i for i, line in enumerate(lines) if "END OF HEADER" in line)
    starts = [i for i in range(end + 1, len(lines)) if epoch_line.match(lines[i])]
    return lines[: starts[epochs]] if len(starts) > epochs else lines


RINEX2_LINES = _head(DATA / "07590920.05o", 12, re.compile(r"^ \d\d [ \d]\d [ \d]\d "))
RINEX3_LINES = _head(DATA / "pixel6.23o", 6, re.compile(r"^> "))
LINE_TEXT = st.one_of(
    st.text(alphabet=st.sampled_from(list("0123456789 .-+eEGRNAinf>\t")), max_size=80), st.text(max_size=40)
)


@st.composite
def mutated_lines(draw, lines: list[str]) -> str:
    out = list(lines)
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(out) - 1))
        how = draw(st.sampled_from(["replace", "splice", "delete", "duplicate", "truncate"]))
        if how == "replace":
            out[i] = draw(LINE_TEXT)
        elif how == "splice":
            j = draw(st.integers(0, max(0, len(out[i]) - 1)))
            out[i] = out[i][:j] + draw(LINE_TEXT) + out[i][j + draw(st.integers(0, 16)) :]
        elif how == "delete":
            del out[i]
        elif how == "duplicate":
            out.insert(i, out[i])
        else:
            out = out[: i + 1]
            out[-1] = out[-1][: draw(st.integers(0, len(out[-1])))]
            return "\n".join(out)
    return "\n".join(out) + "\n"


def _check_observations(tmp_path_factory, name: str, text: str) -> None:
    """``text`` written as the observation file ``name`` reads as plausible observations or
    fails in one line."""
    from gnssframework.io.observations import read_observations
    from gnssframework.io.rinex import PSEUDORANGE_MAX_M, PSEUDORANGE_MIN_M

    with _fresh(tmp_path_factory) as folder:
        path = folder / name
        path.write_text(text)
        try:
            obs = read_observations(path, "G")
        except Exception as exc:  # noqa: BLE001
            _one_line(exc)
            return
        code = obs.pseudorange_m[obs.valid]
        assert np.all((code >= PSEUDORANGE_MIN_M) & (code <= PSEUDORANGE_MAX_M)), code
        assert np.all(np.isfinite(obs.time_s)) and np.all(np.diff(obs.time_s) > 0)


@FUZZ
@given(text=mutated_lines(RINEX2_LINES))
def test_fuzzed_rinex2_lines_read_or_fail_in_one_line(tmp_path_factory, text):
    _check_observations(tmp_path_factory, "f.05o", text)


@FUZZ
@given(text=mutated_lines(RINEX3_LINES))
def test_fuzzed_rinex3_lines_read_or_fail_in_one_line(tmp_path_factory, text):
    _check_observations(tmp_path_factory, "f.23o", text)


NMEA_LINES = (DATA / "ublox-zed-f9p-nmea.log").read_text(errors="replace").splitlines()[:80]


@FUZZ
@given(text=mutated_lines(NMEA_LINES))
def test_fuzzed_nmea_lines_read_or_fail_in_one_line(tmp_path_factory, text):
    from gnssframework.io.nmea import read_nmea

    with _fresh(tmp_path_factory) as folder:
        path = folder / "f.nmea"
        path.write_text(text)
        try:
            fixes = read_nmea(path)
        except Exception as exc:  # noqa: BLE001
            _one_line(exc)
            return
    assert np.all(np.isfinite(fixes.time_s)) and np.all(np.diff(fixes.time_s) > 0)
    assert np.all(np.abs(fixes.lat_deg) <= 90) and np.all(np.abs(fixes.lon_deg) <= 180)


# -- command lines ------------------------------------------------------------------------------------

OPTION_VALUES = st.one_of(
    st.sampled_from(
        [
            "nan",
            "inf",
            "-inf",
            "0",
            "-1",
            "1e300",
            "1e-9",
            "1 1",
            "",
            "x",
            "4e6",
            "91,0,0",
            "0,0,0",
            "nan,nan,nan",
            "ci8",
            "ci16_le",
            "G08",
            "hatch",
        ]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-5, 40).map(str),
)
COMMANDS = {
    "acquire": (
        ["{REAL}", "--prns", "16", "26", "31"],
        ["--format", "--fs", "--if", "--q-sign", "--coherent-ms", "--noncoherent", "--doppler-max", "--pfa", "--prns"],
    ),
    "smooth": (
        ["{RINEX}", "--prn", "G08"],
        [
            "--filter",
            "--window",
            "--q",
            "--r",
            "--slip-threshold",
            "--max-gap",
            "--max-cmc-rate",
            "--pseudorange-min",
            "--pseudorange-max",
            "--prn",
        ],
    ),
    "filter-positions": (["{NMEA}"], ["--filter", "--psi", "--max-speed", "--max-height", "--noise-adapter"]),
}


@pytest.mark.slow
@settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(command=st.sampled_from(sorted(COMMANDS)), data=st.data())
def test_fuzzed_command_lines_end_in_a_result_or_one_error_line(tmp_path_factory, command, data):
    base, options = COMMANDS[command]
    chosen = data.draw(st.dictionaries(st.sampled_from(options), OPTION_VALUES, min_size=1, max_size=3))
    with _fresh(tmp_path_factory) as folder:
        files = {
            "{REAL}": str(REAL),
            "{RINEX}": str(DATA / "07590920.05o"),
            "{NMEA}": str(DATA / "ublox-zed-f9p-nmea.log"),
        }
        argv = [command] + [files.get(a, a) for a in base] + ["--out", str(folder / "out.csv")]
        if command == "acquire" and "--format" not in chosen:
            argv += ["--format", "ci8"]
        if command == "acquire" and "--fs" not in chosen:
            argv += ["--fs", "4e6"]
        for option, value in chosen.items():
            argv += [option, *value.split(" ")] if option == "--prns" else [f"{option}={value}"]
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse's own refusal: usage and one error line
                code = exc.code
                assert code == 2 and err.getvalue().strip().splitlines()[-1].startswith("gnssframework"), err.getvalue()
                return
    said, errors = out.getvalue(), err.getvalue()
    assert code in (0, 1, 2, 3), (argv, code, errors)
    if code == 2:
        assert errors.count("\n") == 1 and errors.startswith("error: "), (argv, errors)
    assert not NON_FINITE_WORD.search(said), (argv, said)
