r"""A SoapySDR device as a live stream: ``soapy://KEY=VALUE,...`` (``soapy://driver=rtlsdr``,
``soapy://driver=airspy,serial=...``), read as interleaved ``int16`` I/Q (SoapySDR's ``CS16``
format, the ``ci16_le`` source).

SoapySDR (Pothos project) puts most SDR front ends behind one API: ``Device(args)``,
``setSampleRate`` / ``setFrequency`` / ``setGain`` on ``(SOAPY_SDR_RX, channel)``,
``setupStream(SOAPY_SDR_RX, SOAPY_SDR_CS16, [channel])``, ``activateStream`` and
``readStream(stream, [buffer], n, timeoutUs=...)``, which returns ``ret`` (samples read, or a
negative error code), ``flags`` and ``timeNs``. Its Python module comes with the C++
library's packages (Debian's ``python3-soapysdr``, conda-forge's ``soapysdr``), not from
PyPI, so it is optional: imported only when a ``soapy://`` address is opened, and refused in
one line where this Python cannot import it.

`SoapyReader` is the binary file object `stream.StreamRecording` reads. What a device loses
is never silent:

- ``SOAPY_SDR_OVERFLOW`` (the driver's buffer overran: samples lost before they reached us)
  is counted; where the device stamps its reads (``SOAPY_SDR_HAS_TIME``), the samples lost
  follow from the stamps, and the reader puts that many zero samples in their place so the
  recording's time base stays whole, and tells the recording, which marks them as a gap
  (channels crossing it are lost and re-acquired, as after a ``--realtime`` overrun);
- without time stamps the count of samples lost is unknown: the overflows are counted and
  reported as breaking the time base.
- ``SOAPY_SDR_TIMEOUT`` is waited through; any other error ends the stream with
  ``errToStr``'s text.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, BinaryIO, cast

import numpy as np

from ...errors import ConfigError

__all__ = ["SOAPY_SCHEME", "SOAPY_FORMAT", "SoapySettings", "SoapyReader", "open_soapy", "device_args"]

SOAPY_SCHEME = "soapy://"
#: The sample source of SoapySDR's ``CS16`` stream format (interleaved little-endian int16 I/Q).
SOAPY_FORMAT = "ci16_le"
#: SoapySDR's error codes and flags (SoapySDR/Errors.h, Constants.h), for a module without them.
_TIMEOUT, _OVERFLOW, _HAS_TIME = -1, -4, 1 << 2
#: Microseconds one read may wait for samples.
READ_TIMEOUT_US = 200_000
#: Most zero samples put in for one gap (a stamp jump beyond it is an error, not a gap).
MAX_GAP_S = 10.0


@dataclass(frozen=True)
class SoapySettings:
    """What to set on the device (None: leave its setting); ``channel`` the RX channel."""

    sample_rate_hz: float
    center_freq_hz: float | None = None
    gain_db: float | None = None
    channel: int = 0


def device_args(address: str) -> dict[str, str]:
    """``{"driver": "rtlsdr", ...}`` of ``soapy://driver=rtlsdr,...`` (SoapySDR's key=value
    markup; an empty address: the first device SoapySDR finds)."""
    text = address[len(SOAPY_SCHEME) :]
    args = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        key, sep, value = part.partition("=")
        if not sep or not key.strip():
            raise ConfigError("recording", f"{address}: expected soapy://KEY=VALUE[,KEY=VALUE...], got {part!r}")
        args[key.strip()] = value.strip()
    return args


class SoapyReader:
    """``read(n)`` bytes of ``CS16`` samples from an active SoapySDR RX stream (module text).

    ``on_lost(first_byte, count_bytes)``, when set (by `stream.StreamRecording`), is called
    for each run of zero samples put in for samples the device lost. ``overflows`` counts the
    device's overflow reports, ``lost_samples`` the samples put in for them (known from
    time stamps), ``unstamped_overflows`` those whose size was unknown.
    """

    def __init__(self, soapy: Any, device: Any, stream: Any, sample_rate_hz: float, description: str) -> None:
        self._soapy, self._device, self._stream = soapy, device, stream
        self.sample_rate_hz = sample_rate_hz
        self.name = description
        self.on_lost: Callable[[int, int], None] | None = None
        self.overflows = 0
        self.lost_samples = 0
        self.unstamped_overflows = 0
        self._bytes = 0  # bytes handed out so far
        self._next_ns: int | None = None  # the time stamp the next sample should carry
        self._pending = b""  # zero samples still to hand out, then the samples read with them
        self._closed = False
        self._timeout = getattr(soapy, "SOAPY_SDR_TIMEOUT", _TIMEOUT)
        self._overflow = getattr(soapy, "SOAPY_SDR_OVERFLOW", _OVERFLOW)
        self._has_time = getattr(soapy, "SOAPY_SDR_HAS_TIME", _HAS_TIME)

    def readable(self) -> bool:
        return True

    def read(self, n: int = -1) -> bytes:
        """Up to ``n`` bytes (whole samples), waiting for the device; ``b""`` once closed."""
        if self._pending:
            out, self._pending = self._pending[:n], self._pending[n:]
            self._bytes += len(out)
            return out
        count = max(1, n // 4)
        buffer = np.empty(2 * count, np.int16)
        while not self._closed:
            result = self._device.readStream(self._stream, [buffer], count, timeoutUs=READ_TIMEOUT_US)
            ret, flags, time_ns = int(result.ret), int(result.flags), int(result.timeNs)
            if ret == self._timeout:
                continue
            if ret == self._overflow:
                if self._bytes or self._pending:  # (before the first sample: nothing of the run lost)
                    self.overflows += 1
                    self.unstamped_overflows += self._next_ns is None
                continue
            if ret < 0:
                raise OSError(f"SoapySDR readStream: {self._soapy.errToStr(ret)} ({ret})")
            data = buffer[: 2 * ret].tobytes()
            if flags & self._has_time:
                gap = self._gap_samples(time_ns)
                self._next_ns = time_ns + round(ret * 1e9 / self.sample_rate_hz)
                if gap:
                    zeros = bytes(4 * gap)
                    if self.on_lost is not None:
                        self.on_lost(self._bytes, len(zeros))
                    self.lost_samples += gap
                    data = zeros + data
            elif self._next_ns is not None:
                self._next_ns = None  # stamps stopped: later overflows are unstamped
            out, self._pending = data[:n], data[n:]
            self._bytes += len(out)
            return out
        return b""

    def _gap_samples(self, time_ns: int) -> int:
        """Samples between the last read's end and a read stamped ``time_ns`` (0: none)."""
        if self._next_ns is None:
            return 0
        gap = round((time_ns - self._next_ns) * 1e-9 * self.sample_rate_hz)
        if gap < 0 or gap > MAX_GAP_S * self.sample_rate_hz:
            raise OSError(
                f"SoapySDR time stamps jumped by {(time_ns - self._next_ns) * 1e-9:+.3f} s between reads "
                "(not a gap of lost samples)"
            )
        return gap

    def summary(self) -> str:
        """What the device lost, or ``""``."""
        if not self.overflows:
            return ""
        text = f"device overflows: {self.overflows} ({self.lost_samples / self.sample_rate_hz:.3f} s zero-filled"
        if self.unstamped_overflows:
            text += f"; {self.unstamped_overflows} without time stamps: samples lost uncounted, the time base broken"
        return text + ")"

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self._device.deactivateStream(self._stream)
            self._device.closeStream(self._stream)
        except Exception:  # noqa: BLE001 - a device gone already: nothing left to close
            pass


def open_soapy(address: str, settings: SoapySettings) -> tuple[BinaryIO, str]:
    """Open ``address`` (``soapy://...``), apply ``settings``, start its ``CS16`` RX stream;
    the reader (a `SoapyReader`) and a line describing the device.

    Raises
    ------
    ConfigError
        No SoapySDR Python module, a bad address, or a device SoapySDR cannot open.
    """
    args = device_args(address)
    try:
        soapy = importlib.import_module("SoapySDR")
    except ImportError:
        raise ConfigError(
            "recording",
            f"{address}: needs the SoapySDR Python module, which this Python cannot import (it is not on "
            "PyPI: Debian's python3-soapysdr or conda-forge's soapysdr, with this Python)",
        ) from None
    rx = soapy.SOAPY_SDR_RX
    try:
        device = soapy.Device(args)
        device.setSampleRate(rx, settings.channel, settings.sample_rate_hz)
        if settings.center_freq_hz is not None:
            device.setFrequency(rx, settings.channel, settings.center_freq_hz)
        device.setGainMode(rx, settings.channel, settings.gain_db is None)
        if settings.gain_db is not None:
            device.setGain(rx, settings.channel, settings.gain_db)
        stream = device.setupStream(rx, soapy.SOAPY_SDR_CS16, [settings.channel])
        device.activateStream(stream)
    except (RuntimeError, ValueError) as exc:
        raise ConfigError("recording", f"{address}: SoapySDR: {exc}") from None
    rate = float(device.getSampleRate(rx, settings.channel))
    if abs(rate - settings.sample_rate_hz) > 1e-6 * settings.sample_rate_hz:
        device.deactivateStream(stream)
        device.closeStream(stream)
        raise ConfigError(
            "sample_rate_hz",
            f"{address}: the device runs at {rate:.0f} Hz, not the {settings.sample_rate_hz:.0f} Hz asked",
        )
    driver = args.get("driver", "first found")
    reader = SoapyReader(soapy, device, stream, rate, f"SoapySDR {driver} {address}")
    return cast(BinaryIO, reader), f"SoapySDR device {address}"  # read as a binary file
