"""Built-in sample formats (plugin kind ``sample_source``).

SigMF datatype names where SigMF has one (SigMF specification, "Dataset Format"):
``ri8`` (real int8), ``ci8`` (interleaved int8 I/Q), ``ci16_le`` (interleaved
little-endian int16 I/Q), ``cf32_le`` (interleaved float32 I/Q, GNSS-SDR's
``gr_complex``), ``cu8`` (interleaved unsigned 8-bit I/Q, the RTL-SDR's ``rtl_sdr`` and
``rtl_tcp`` output: each byte ``b`` stands for ``b - 127.5``). Packed 2-bit samples (``ri2``, ``ci2``), which SigMF has no name for:
four 2-bit values a byte, the first sample in the least significant bits, each a
two's-complement value v in -2..1 standing for the level 2v + 1 (-3, -1, +1, +3), the
symmetric four-level quantiser of front ends such as the MAX2771.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from gnssframework.plugin import PluginParams
from gnssframework.receiver.frontend.source import SampleSource

__all__ = ["RealInt8", "ComplexInt8", "ComplexUint8", "ComplexInt16", "ComplexFloat32", "RealPacked2", "ComplexPacked2"]


class FormatParams(PluginParams):
    """The parameters of a sample format (none)."""

    no_parameters: ClassVar[str] = (
        "the format fixes the sample layout; the sample rate, IF and Q sign are the "
        "recording's (its SigMF metadata or --fs, --if, --q-sign)"
    )


def _to_int(x: np.ndarray, dtype) -> np.ndarray:
    info = np.iinfo(dtype)
    return np.clip(np.rint(x), info.min, info.max).astype(dtype)


def _interleave(x: np.ndarray) -> np.ndarray:
    return np.stack([x.real, x.imag], axis=-1).reshape(-1)


class RealInt8(SampleSource):
    """Real samples, one signed byte each (SigMF ``ri8``)."""

    name = "ri8"
    Params = FormatParams
    params: FormatParams  # self.params, as validated
    description = "real int8 samples (SigMF ri8)"
    is_complex = False
    bytes_per_chunk = 1
    samples_per_chunk = 1
    sigmf_datatype = "ri8"

    def decode(self, raw: np.ndarray) -> np.ndarray:
        return raw.view(np.int8).astype(np.float32)

    def encode(self, samples: np.ndarray) -> bytes:
        return _to_int(samples, np.int8).tobytes()


class ComplexInt8(SampleSource):
    """Interleaved I/Q, one signed byte each (SigMF ``ci8``; gps-sdr-sim ``-b 8``)."""

    name = "ci8"
    Params = FormatParams
    params: FormatParams  # self.params, as validated
    description = "interleaved int8 I/Q (SigMF ci8)"
    bytes_per_chunk = 2
    sigmf_datatype = "ci8"

    def decode(self, raw: np.ndarray) -> np.ndarray:
        iq = raw.view(np.int8).astype(np.float32)
        return iq.view(np.complex64)

    def encode(self, samples: np.ndarray) -> bytes:
        return _to_int(_interleave(samples), np.int8).tobytes()


class ComplexUint8(SampleSource):
    """Interleaved I/Q, one unsigned byte each, offset binary (SigMF ``cu8``; RTL-SDR's
    ``rtl_sdr`` and ``rtl_tcp`` output): byte ``b`` is the value ``b - 127.5`` (the
    RTL2832U's 8-bit ADC codes centred between 127 and 128)."""

    name = "cu8"
    Params = FormatParams
    description = "interleaved unsigned 8-bit I/Q, offset 127.5 (SigMF cu8; rtl_sdr, rtl_tcp)"
    bytes_per_chunk = 2
    sigmf_datatype = "cu8"

    def decode(self, raw: np.ndarray) -> np.ndarray:
        return (raw.astype(np.float32) - np.float32(127.5)).view(np.complex64)

    def encode(self, samples: np.ndarray) -> bytes:
        return np.clip(np.rint(_interleave(samples) + 127.5), 0, 255).astype(np.uint8).tobytes()


class ComplexInt16(SampleSource):
    """Interleaved I/Q, little-endian int16 each (SigMF ``ci16_le``; gps-sdr-sim ``-b 16``)."""

    name = "ci16_le"
    Params = FormatParams
    params: FormatParams  # self.params, as validated
    description = "interleaved little-endian int16 I/Q (SigMF ci16_le)"
    bytes_per_chunk = 4
    sigmf_datatype = "ci16_le"

    def decode(self, raw: np.ndarray) -> np.ndarray:
        return raw.view("<i2").astype(np.float32).view(np.complex64)

    def encode(self, samples: np.ndarray) -> bytes:
        return _to_int(_interleave(samples), np.int16).astype("<i2").tobytes()


class ComplexFloat32(SampleSource):
    """Interleaved I/Q, little-endian float32 each (SigMF ``cf32_le``; GNSS-SDR ``gr_complex``)."""

    name = "cf32_le"
    Params = FormatParams
    params: FormatParams  # self.params, as validated
    description = "interleaved float32 I/Q (SigMF cf32_le, GNSS-SDR gr_complex)"
    bytes_per_chunk = 8
    sigmf_datatype = "cf32_le"

    def decode(self, raw: np.ndarray) -> np.ndarray:
        return raw.view("<f4").astype(np.float32).view(np.complex64)

    def encode(self, samples: np.ndarray) -> bytes:
        return _interleave(np.asarray(samples, np.complex64)).astype("<f4").tobytes()


_LEVELS = np.array([1.0, 3.0, -3.0, -1.0], np.float32)  # two's complement 0, 1, -2, -1 -> 2v + 1


def _unpack2(raw: np.ndarray) -> np.ndarray:
    codes = (raw[:, None] >> np.array([0, 2, 4, 6], np.uint8)) & 3
    return _LEVELS[codes.reshape(-1)]


def _pack2(values: np.ndarray) -> bytes:
    # Nearest level: v = clip(round((x - 1) / 2), -2, 1), stored as two's complement.
    v = np.clip(np.rint((np.asarray(values, float) - 1.0) / 2.0), -2, 1).astype(np.int8)
    codes = (v & 3).astype(np.uint8).reshape(-1, 4)
    return (codes[:, 0] | codes[:, 1] << 2 | codes[:, 2] << 4 | codes[:, 3] << 6).astype(np.uint8).tobytes()


class RealPacked2(SampleSource):
    """Real 2-bit samples, four a byte (first in the low bits), levels -3, -1, +1, +3."""

    name = "ri2"
    Params = FormatParams
    params: FormatParams  # self.params, as validated
    description = "real 2-bit samples packed four a byte (levels +-1, +-3)"
    is_complex = False
    bytes_per_chunk = 1
    samples_per_chunk = 4

    def decode(self, raw: np.ndarray) -> np.ndarray:
        return _unpack2(raw)

    def encode(self, samples: np.ndarray) -> bytes:
        return _pack2(samples)


class ComplexPacked2(SampleSource):
    """Complex 2-bit samples: I then Q, two complex samples a byte (first in the low bits)."""

    name = "ci2"
    Params = FormatParams
    params: FormatParams  # self.params, as validated
    description = "complex 2-bit I/Q packed two samples a byte (levels +-1, +-3)"
    bytes_per_chunk = 1
    samples_per_chunk = 2

    def decode(self, raw: np.ndarray) -> np.ndarray:
        return _unpack2(raw).view(np.complex64)

    def encode(self, samples: np.ndarray) -> bytes:
        return _pack2(_interleave(samples))
