"""Opening a recording and streaming its samples in blocks (memory bounded by the block size)."""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace
from pathlib import Path
from collections.abc import Iterator

import numpy as np

from ... import registry
from ...errors import ConfigError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .sigmf_meta import SigmfInfo, meta_path_for, read_sigmf_meta
from .source import SampleSource

__all__ = ["RecordingInfo", "Recording", "open_recording", "check_recording_info"]

#: SigMF datatypes whose bytes are the samples' components as they are (SigMF
#: specification, "Dataset Format"): read without decoding (`Recording.read_components`).
AS_STORED = {
    "ci8": np.int8,
    "ri8": np.int8,
    "ci16_le": np.dtype("<i2"),
    "ri16_le": np.dtype("<i2"),
    "cf32_le": np.dtype("<f4"),
    "rf32_le": np.dtype("<f4"),
}


@dataclass(frozen=True)
class RecordingInfo:
    """How to read a recording: its format and the front end's sample rate, IF and Q sign."""

    format: str
    sample_rate_hz: float
    if_hz: float
    q_sign: int = 1
    start_time: str | None = None

    def describe(self) -> str:
        """One line for messages: what was assumed about the recording."""
        return f"format {self.format}, fs {self.sample_rate_hz:g} Hz, IF {self.if_hz:g} Hz" + (
            ", Q inverted" if self.q_sign < 0 else ""
        )


class Recording:
    """A recording on disk, read in whole chunks of its format.

    Attributes
    ----------
    path, info, source
        The file, how it is read, and the ``sample_source`` plugin of its format.
    n_samples
        Whole samples in the file.
    trailing_bytes
        Bytes after the last whole chunk (a truncated last sample): never read, and
        reported by the commands.
    nonfinite_zeroed
        Non-finite values (NaN, inf) of a floating-point format set to 0 in what was
        read so far (a sample read twice counts twice), reported by the commands: one NaN
        would otherwise spread through a whole FFT search and hide every satellite.
    """

    #: Samples that arrive as they are read (a stream), not a file any process can read.
    is_live = False

    def __init__(self, path: str | Path, info: RecordingInfo) -> None:
        self.path = Path(path)
        self.info = info
        self.source: SampleSource = registry.create("sample_source", info.format)
        size = self.path.stat().st_size
        bpc, spc = self.source.bytes_per_chunk, self.source.samples_per_chunk
        self.n_samples = (size // bpc) * spc
        self.trailing_bytes = size % bpc
        self.nonfinite_zeroed = 0
        self._floating = "f" in self.source.sigmf_datatype

    def tuned(self, if_hz: float) -> Recording:
        """The same samples read as if the front end had put the tracked signal at
        ``if_hz``: a signal on another carrier of a wide-band recording (its IF the first's
        plus the carriers' difference). A shallow copy: the file, or a live stream's buffer,
        is shared."""
        if not np.isfinite(if_hz) or abs(if_hz) >= self.info.sample_rate_hz / 2:
            raise ConfigError(
                "if_hz",
                f"{if_hz:g} Hz is outside the band of {self.path.name} (fs {self.info.sample_rate_hz:g} Hz): "
                "the signal is not in this recording",
            )
        out = copy.copy(self)
        out.info = replace(self.info, if_hz=float(if_hz))
        return out

    def _zero_nonfinite(self, x: np.ndarray) -> np.ndarray:
        """``x`` (a fresh array) with NaN/inf values set to 0, counted in `nonfinite_zeroed`."""
        bad = ~np.isfinite(x)
        if bad.any():
            x = np.where(bad, np.zeros((), x.dtype), x)
            self.nonfinite_zeroed += int(bad.sum())
        return x

    def _raw(self, offset_bytes: int, count_bytes: int) -> np.ndarray:
        """``count_bytes`` bytes (``uint8``) of the samples from byte ``offset_bytes`` (fewer
        at the end): the one place the bytes are fetched (a live stream,
        `frontend.stream.StreamRecording`, fetches them from its buffer)."""
        return np.fromfile(self.path, dtype=np.uint8, count=count_bytes, offset=offset_bytes)

    def dropped_between(self, first: int, stop: int) -> tuple[int, int] | None:
        """The first run ``(first_sample, end_sample)`` of samples lost (never received: a
        live stream's overrun) overlapping ``[first, stop)``; None for a file (none lost)."""
        return None

    @property
    def is_complex(self) -> bool:
        return self.source.is_complex

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.info.sample_rate_hz

    def read(self, start: int, count: int) -> np.ndarray:
        """``count`` samples from sample ``start`` (fewer at the end of the file).

        Complex formats return ``complex64`` with the Q sign applied, real ones ``float32``.
        """
        if start < 0 or count < 0:
            raise ConfigError("start", f"sample range must be non-negative, got start {start}, count {count}")
        count = max(0, min(count, self.n_samples - start))
        bpc, spc = self.source.bytes_per_chunk, self.source.samples_per_chunk
        first = start // spc
        last = -(-(start + count) // spc)
        raw = self._raw(first * bpc, (last - first) * bpc)
        x = self.source.decode(raw)[start - first * spc : start - first * spc + count]
        if self._floating:
            x = self._zero_nonfinite(x)
        if self.is_complex and self.info.q_sign < 0:
            x = np.conj(x)
        return x

    def read_components(self, start: int, count: int) -> np.ndarray:
        """``count`` samples from sample ``start`` as the correlator reads them: interleaved
        I, Q components (complex formats; ``2 * count`` values) or real values, in the type
        the file stores them in where SigMF names it (``int8``, ``int16``, ``float32``: no
        decoding, no float copy), else decoded to ``float32``. The Q sign is not applied
        (``info.q_sign`` says it)."""
        stored = AS_STORED.get(self.source.sigmf_datatype)
        if stored is None or self.source.samples_per_chunk != 1:
            x = self.read(start, count)
            x = np.conj(x) if self.is_complex and self.info.q_sign < 0 else x  # undo: the caller applies it
            return x.view(np.float32) if self.is_complex else x.astype(np.float32, copy=False)
        if start < 0 or count < 0:
            raise ConfigError("start", f"sample range must be non-negative, got start {start}, count {count}")
        count = max(0, min(count, self.n_samples - start))
        bpc = self.source.bytes_per_chunk
        raw = self._raw(start * bpc, count * bpc)
        out = raw.view(stored).astype(np.dtype(stored).newbyteorder("="), copy=False)
        return self._zero_nonfinite(out) if self._floating else out

    def blocks(self, block_samples: int, start: int = 0, stop: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """``(first_sample, samples)`` blocks of ``block_samples`` from ``start`` to ``stop``."""
        if block_samples <= 0:
            raise ConfigError("block_samples", f"must be > 0, got {block_samples}")
        stop = self.n_samples if stop is None else min(stop, self.n_samples)
        for first in range(start, stop, block_samples):
            yield first, self.read(first, min(block_samples, stop - first))


def _pick(name: str, given, from_meta, default=None):
    if given is not None:
        return given
    if from_meta is not None:
        return from_meta
    if default is not None:
        return default
    raise ConfigError(name, "not given and no SigMF metadata file beside the recording states it")


def check_recording_info(
    format: str,
    sample_rate_hz: float,
    if_hz: float = 0.0,
    q_sign: int = 1,
    start_time: str | None = None,
    fields: dict[str, str] | None = None,
) -> RecordingInfo:
    """The `RecordingInfo` of these values once checked (a file's or a live stream's);
    ``fields`` renames a parameter in the errors (where its value came from).

    Raises
    ------
    ConfigError
        An unknown format, a rate or IF a GPS L1 C/A receiver cannot use, a bad Q sign.
    """
    name = (fields or {}).get
    known = registry.names("sample_source")
    if format not in known:
        raise ConfigError(name("format", "format"), f"unknown sample format {format!r}; known: {', '.join(known)}")
    fs, fif, qs = float(sample_rate_hz), float(if_hz), int(q_sign)
    fs_field, if_field = name("sample_rate_hz", "sample_rate_hz"), name("if_hz", "if_hz")
    if not np.isfinite(fs) or fs < 2.046e6:
        raise ConfigError(fs_field, f"{fs:g} Hz is below the C/A main lobe (needs >= 2.046 MHz)")
    if not np.isfinite(fif):
        raise ConfigError(if_field, f"must be a finite number of Hz, got {fif:g}")
    if qs not in (1, -1):
        raise ConfigError("q_sign", f"must be 1 or -1, got {qs}")
    is_complex = registry.create("sample_source", format).is_complex
    if not is_complex and not 0 < fif < fs / 2:
        raise ConfigError(if_field, f"real samples need 0 < IF < fs/2 = {fs / 2:g} Hz, got {fif:g}")
    if is_complex and abs(fif) >= fs / 2:
        raise ConfigError(if_field, f"complex samples need |IF| < fs/2 = {fs / 2:g} Hz, got {fif:g}")
    return RecordingInfo(format, fs, fif, qs, start_time)


def open_recording(
    path: str | Path,
    format: str | None = None,
    sample_rate_hz: float | None = None,
    if_hz: float | None = None,
    q_sign: int | None = None,
    signal: SignalSpec = GPS_L1CA,
) -> Recording:
    """Open ``path``; what is not given comes from its SigMF metadata file if there is one.

    Values given here win over the metadata's (a wrong metadata file can be overridden).
    Without the project's IF key, a metadata file's IF is ``signal``'s carrier (GPS L1 C/A's
    by default) minus its ``core:frequency``; a centre frequency too far from it for the
    sample rate is refused naming the options to give.

    Raises
    ------
    ConfigError
        Missing file, an unknown format, a value neither given nor in metadata, a rate or
        IF a GPS L1 C/A receiver cannot use, or a file too short to hold one sample.
    """
    path = Path(path)
    if path.exists() and not path.is_file():
        raise ConfigError(
            "recording", f"{path}: not a regular file (a device, pipe or folder): give a file of recorded samples"
        )
    if not path.is_file():
        raise ConfigError("recording", f"{path}: no such file")
    meta_file = meta_path_for(path)
    meta = (
        read_sigmf_meta(meta_file, signal=signal)
        if meta_file.is_file() and meta_file != path
        else SigmfInfo(None, None, None, None, None)
    )

    def field(parameter: str, given, meta_key: str) -> str:
        """The parameter's name, or the metadata file's field where the value came from it."""
        return parameter if given is not None else f"{meta_file} {meta_key}"

    fmt = _pick("format", format, meta.format)
    if fmt not in registry.names("sample_source"):  # named before a missing rate
        check_recording_info(fmt, 0.0, fields={"format": field("format", format, "global core:datatype")})
    fs = float(_pick("sample_rate_hz", sample_rate_hz, meta.sample_rate_hz))
    fif = float(_pick("if_hz", if_hz, meta.if_hz, 0.0))
    if if_hz is None and meta.centre_freq_hz is not None and abs(fif) >= fs / 2:
        # The centre frequency is of another band than the signal's carrier: say which.
        raise ConfigError(
            f"{meta_file} captures[0] core:frequency",
            f"{meta.centre_freq_hz / 1e6:.6g} MHz is {fif / 1e6:.6g} MHz from {signal.name}'s carrier "
            f"({signal.carrier_freq_hz / 1e6:.6g} MHz), beyond what {fs / 1e6:g} MHz samples hold: give the "
            "signal recorded in that band (signal, --signal NAME) or the IF (if_hz, --if-hz)",
        )
    qs = int(_pick("q_sign", q_sign, meta.q_sign, 1))
    info = check_recording_info(
        fmt,
        fs,
        fif,
        qs,
        meta.start_time,
        fields={
            "format": field("format", format, "global core:datatype"),
            "sample_rate_hz": field("sample_rate_hz", sample_rate_hz, "global core:sample_rate"),
            "if_hz": field("if_hz", if_hz, "captures[0] core:frequency"),
        },
    )
    rec = Recording(path, info)
    if rec.n_samples == 0:
        raise ConfigError("recording", f"{path}: holds no whole sample of format {fmt}")
    if meta.sample_start:  # the metadata describes the samples from there on: not read from a later start
        where = "beyond the end of" if meta.sample_start >= rec.n_samples else "inside"
        raise ConfigError(
            f"{meta_file} captures[0] core:sample_start",
            f"{meta.sample_start} is {where} the {rec.n_samples} samples of {path.name}: a first capture "
            "that does not start at sample 0 is not supported (cut the file there and set 0)",
        )
    return rec
