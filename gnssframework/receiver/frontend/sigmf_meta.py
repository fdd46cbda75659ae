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

import json
from dataclasses import dataclass
from pathlib import Path

from ...errors import DataFileError
from ...signal.gps_l1ca import GPS_L1CA

__all__ = ["SigmfInfo", "meta_path_for", "read_sigmf_meta", "write_sigmf_meta"]

IF_KEY = "gnssframework:if_hz"
Q_SIGN_KEY = "gnssframework:q_sign"
FORMAT_KEY = "gnssframework:format"


@dataclass(frozen=True)
class SigmfInfo:
    """What a SigMF metadata file says about a recording (``None`` where it says nothing)."""

    format: str | None
    sample_rate_hz: float | None
    if_hz: float | None
    q_sign: int | None
    start_time: str | None


def meta_path_for(recording: str | Path) -> Path:
    """The metadata file that belongs to ``recording`` (``x.sigmf-data`` or ``x.bin`` -> ``x.sigmf-meta``)."""
    p = Path(recording)
    return p.with_suffix(".sigmf-meta")


def read_sigmf_meta(path: str | Path, carrier_freq_hz: float = GPS_L1CA.carrier_freq_hz) -> SigmfInfo:
    """Read a SigMF metadata file.

    The JSON is validated by ``sigmf``'s schema; fields this project needs are then read
    from the global object and the first capture (the IF relative to ``carrier_freq_hz``).

    Raises
    ------
    DataFileError
        Naming the file, for JSON or schema errors.
    """
    from sigmf.error import SigMFError
    from sigmf.sigmffile import SigMFFile

    path = Path(path)
    try:
        meta = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise DataFileError(str(path), exc.lineno, f"not JSON: {exc.msg}") from None
    glob = meta.get("global", {}) if isinstance(meta, dict) else {}
    fmt = glob.get(FORMAT_KEY)
    try:
        sig = SigMFFile(metadata=meta, skip_checksum=True)
        if fmt is None:  # a datatype SigMF knows: the schema checks it
            sig.validate()
    except SigMFError as exc:
        raise DataFileError(str(path), None, f"not valid SigMF metadata: {exc}") from None
    captures = meta.get("captures") or [{}]
    freq = captures[0].get("core:frequency")
    if_hz = glob.get(IF_KEY)
    if if_hz is None and freq is not None:
        if_hz = carrier_freq_hz - float(freq)
    q_sign = glob.get(Q_SIGN_KEY)
    if q_sign not in (None, 1, -1):
        raise DataFileError(str(path), None, f"{Q_SIGN_KEY} must be 1 or -1, got {q_sign!r}")
    rate = glob.get("core:sample_rate")
    return SigmfInfo(fmt or glob.get("core:datatype"), None if rate is None else float(rate),
                     None if if_hz is None else float(if_hz), q_sign, captures[0].get("core:datetime"))


def write_sigmf_meta(path: str | Path, *, format: str, sigmf_datatype: str, sample_rate_hz: float, if_hz: float,
                     q_sign: int = 1, start_time: str | None = None, description: str = "",
                    carrier_freq_hz: float = GPS_L1CA.carrier_freq_hz) -> Path:
    """Write the metadata of a recording with ``sigmf`` (validated against its schema);
    ``core:frequency`` is ``carrier_freq_hz - if_hz``."""
    from sigmf.sigmffile import SigMFFile

    glob = {"core:sample_rate": float(sample_rate_hz), "core:version": "1.0.0",
            "core:description": description or "written by gnssframework", "core:recorder": "gnssframework",
            IF_KEY: float(if_hz), Q_SIGN_KEY: int(q_sign),
            "core:extensions": [{"name": "gnssframework", "version": "0.1.0", "optional": True}]}
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
