"""SigMF metadata beside a recording (``NAME.sigmf-meta`` for ``NAME.sigmf-data``), read
and written with the ``sigmf`` package.

SigMF's ``core:frequency`` of a capture is the radio frequency at 0 Hz of the sample
stream; the intermediate frequency of a recording of a signal at carrier ``f_L`` (L1,
1575.42 MHz, by default: ``carrier_freq_hz``, a `SignalSpec`'s) is then
``IF = f_L - core:frequency``. The Q-branch sign (+1, or -1 for a front end whose samples
read as I - jQ) and the format of a recording SigMF has no datatype for are kept under
this project's namespace ``gnssframework:`` in the global object.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from dataclasses import dataclass
from pathlib import Path

from ...errors import DataFileError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec

__all__ = ["SigmfInfo", "meta_path_for", "read_sigmf_meta", "write_sigmf_meta"]

IF_KEY = "gnssframework:if_hz"
Q_SIGN_KEY = "gnssframework:q_sign"
FORMAT_KEY = "gnssframework:format"


@dataclass(frozen=True)
class SigmfInfo:
    """What a SigMF metadata file says about a recording (``None`` where it says nothing).

    ``sample_start`` is the first capture's ``core:sample_start`` (the sample its
    frequency and time apply from; ``None`` when not stated)."""

    format: str | None
    sample_rate_hz: float | None
    if_hz: float | None
    q_sign: int | None
    start_time: str | None
    sample_start: int | None = None
    #: The first capture's ``core:frequency`` (Hz) when the IF was derived from it (no
    #: project IF key): the IF is then the signal's carrier minus it.
    centre_freq_hz: float | None = None


def meta_path_for(recording: str | Path) -> Path:
    """The metadata file that belongs to ``recording`` (``x.sigmf-data`` or ``x.bin`` -> ``x.sigmf-meta``)."""
    p = Path(recording)
    return p.with_suffix(".sigmf-meta")


#: Largest metadata file read (a SigMF file for one recording is a few kB; a larger one is
#: not metadata of a recording: refused before parsing).
MAX_META_BYTES = 16 * 1024 * 1024

#: Largest sample rate accepted, as SigMF's schema bounds ``core:sample_rate`` (1 THz).
MAX_SAMPLE_RATE_HZ = 1e12


def _number(path: Path, where: str, value, *, positive: bool = False, limit: float | None = None) -> float | None:
    """``value`` of field ``where`` as a finite float (``None`` stays ``None``), else a
    `DataFileError` naming the file and the field."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DataFileError(str(path), None, f"{where} must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise DataFileError(str(path), None, f"{where} must be a finite number, got {value!r}")
    if positive and not x > 0:
        raise DataFileError(str(path), None, f"{where} must be > 0, got {value!r}")
    if limit is not None and abs(x) > limit:
        raise DataFileError(str(path), None, f"{where} = {value!r} is beyond {limit:g}")
    return x


def _load_json(path: Path) -> object:
    """The file's JSON, or a `DataFileError` naming it: too large, not UTF-8, not JSON,
    nested too deeply."""
    if path.stat().st_size > MAX_META_BYTES:
        raise DataFileError(
            str(path), None, f"{path.stat().st_size} bytes: too large for SigMF metadata (at most {MAX_META_BYTES})"
        )
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise DataFileError(
            str(path),
            line,
            f"not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}): SigMF metadata is UTF-8 JSON",
        ) from None
    try:
        return json.loads(text, parse_constant=lambda c: float(c))
    except json.JSONDecodeError as exc:
        raise DataFileError(str(path), exc.lineno, f"not JSON: {exc.msg}") from None
    except RecursionError:
        raise DataFileError(str(path), None, "JSON nested too deeply to be SigMF metadata") from None


def _is_iso_datetime(value: object) -> bool:
    """Whether ``value`` is an ISO 8601 date-time string (``Z`` for UTC accepted)."""
    if not isinstance(value, str) or "T" not in value:
        return False
    try:
        dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
    except ValueError:
        return False
    return True


def _check_fields(path: Path, meta: object) -> tuple[dict, list]:
    """The global object and the captures, each field this project reads checked for its
    type and range (the schema is only checked when the datatype is SigMF's)."""
    if not isinstance(meta, dict):
        raise DataFileError(str(path), None, f"SigMF metadata is a JSON object, got a {type(meta).__name__}")
    glob = meta.get("global", {})
    if not isinstance(glob, dict):
        raise DataFileError(str(path), None, f"global must be a JSON object, got {glob!r:.40}")
    captures = meta.get("captures", [])
    if not isinstance(captures, list) or not all(isinstance(c, dict) for c in captures):
        raise DataFileError(str(path), None, f"captures must be a list of JSON objects, got {captures!r:.40}")
    for key in ("core:datatype", FORMAT_KEY):
        if key in glob and not isinstance(glob[key], str):
            raise DataFileError(str(path), None, f"global {key} must be a string, got {glob[key]!r}")
    if glob.get("core:datatype") is None and glob.get(FORMAT_KEY) is None:
        raise DataFileError(str(path), None, 'global core:datatype missing: the samples\' format (e.g. "ci8")')
    _number(path, "global core:sample_rate", glob.get("core:sample_rate"), positive=True, limit=MAX_SAMPLE_RATE_HZ)
    _number(path, f"global {IF_KEY}", glob.get(IF_KEY), limit=MAX_SAMPLE_RATE_HZ)
    first = captures[0] if captures else {}
    _number(path, "captures[0] core:frequency", first.get("core:frequency"), positive=True, limit=MAX_SAMPLE_RATE_HZ)
    start = first.get("core:sample_start")
    if start is not None and (isinstance(start, bool) or not isinstance(start, int) or start < 0):
        raise DataFileError(
            str(path), None, f"captures[0] core:sample_start must be a whole number >= 0, got {start!r}"
        )
    when = first.get("core:datetime")
    if when is not None and not _is_iso_datetime(when):
        raise DataFileError(
            str(path),
            None,
            f"captures[0] core:datetime must be an ISO 8601 date and time string (2021-12-02T08:47:00Z), got {when!r}",
        )
    return glob, captures


def read_sigmf_meta(path: str | Path, carrier_freq_hz: float | None = None, signal: SignalSpec = GPS_L1CA) -> SigmfInfo:
    """Read a SigMF metadata file.

    Without the ``gnssframework`` IF key, the IF is ``carrier_freq_hz - core:frequency``, with
    ``carrier_freq_hz`` ``signal``'s carrier frequency by default.

    The fields this project reads are checked for type and range first (each error names
    the file and the field); the JSON is then validated by ``sigmf``'s schema when its
    datatype is SigMF's, and the fields are read from the global object and the first
    capture.

    Raises
    ------
    DataFileError
        Naming the file (and the field or line): not UTF-8, not JSON, nested too deeply,
        a field of the wrong type or out of range, a schema error.
    """
    from jsonschema.exceptions import ValidationError as SchemaError
    from sigmf.error import SigMFError
    from sigmf.sigmffile import SigMFFile

    path = Path(path)
    meta = _load_json(path)
    glob, captures = _check_fields(path, meta)
    fmt = glob.get(FORMAT_KEY)
    try:
        sig = SigMFFile(metadata=meta, skip_checksum=True)
        if fmt is None:  # a datatype SigMF knows: the schema checks it
            sig.validate()
    except SchemaError as exc:
        where = " ".join(str(k) for k in exc.absolute_path) or "the metadata"
        raise DataFileError(str(path), None, f"not valid SigMF metadata: {where}: {exc.message}") from None
    except (SigMFError, KeyError, TypeError, ValueError, AttributeError) as exc:
        raise DataFileError(str(path), None, f"not valid SigMF metadata: {exc}") from None
    first = captures[0] if captures else {}
    freq = first.get("core:frequency")
    if_hz = glob.get(IF_KEY)
    centre = None
    if if_hz is None and freq is not None:
        centre = float(freq)
        if_hz = (signal.carrier_freq_hz if carrier_freq_hz is None else carrier_freq_hz) - centre
    q_sign = glob.get(Q_SIGN_KEY)
    if q_sign not in (None, 1, -1) or isinstance(q_sign, bool):
        raise DataFileError(str(path), None, f"{Q_SIGN_KEY} must be 1 or -1, got {q_sign!r}")
    rate = glob.get("core:sample_rate")
    return SigmfInfo(
        fmt or glob.get("core:datatype"),
        None if rate is None else float(rate),
        None if if_hz is None else float(if_hz),
        q_sign,
        first.get("core:datetime"),
        first.get("core:sample_start"),
        centre,
    )


def write_sigmf_meta(
    path: str | Path,
    *,
    format: str,
    sigmf_datatype: str,
    sample_rate_hz: float,
    if_hz: float,
    q_sign: int = 1,
    start_time: str | None = None,
    description: str = "",
    carrier_freq_hz: float | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> Path:
    """Write the metadata of a recording with ``sigmf`` (validated against its schema);
    ``core:frequency`` is ``carrier_freq_hz - if_hz`` (``carrier_freq_hz``: ``signal``'s by default)."""
    if carrier_freq_hz is None:
        carrier_freq_hz = signal.carrier_freq_hz
    from sigmf.sigmffile import SigMFFile

    glob = {
        "core:sample_rate": float(sample_rate_hz),
        "core:version": "1.0.0",
        "core:description": description or "written by gnssframework",
        "core:recorder": "gnssframework",
        IF_KEY: float(if_hz),
        Q_SIGN_KEY: int(q_sign),
        "core:extensions": [{"name": "gnssframework", "version": "0.1.0", "optional": True}],
    }
    if sigmf_datatype:
        glob["core:datatype"] = sigmf_datatype
    else:  # SigMF has no datatype for it: a placeholder of the same sample width and our own key
        glob["core:datatype"] = "ru8"
        glob[FORMAT_KEY] = format
    sig = SigMFFile(global_info=glob, skip_checksum=True)
    capture = {"core:frequency": carrier_freq_hz - float(if_hz)}
    if start_time:
        capture["core:datetime"] = start_time
    sig.add_capture(0, metadata=capture)
    path = Path(path)
    path.write_text(sig.dumps(pretty=True))
    return path
