"""The ``sample_source`` plugin kind: how a recording's bytes become samples.

A sample source is a *format*: it says how many bytes hold how many samples, turns raw
bytes into samples and samples back into bytes. The reader
(`gnssframework.receiver.frontend.recording`) does the file handling and streaming, so a
third party adds a front end's format by registering one small class.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np

from ... import registry
from ...plugin import Plugin

__all__ = ["SampleSource"]


class SampleSource(Plugin, abc.ABC):
    """Plugin kind ``sample_source``: one recording format.

    Class attributes
    ----------------
    name
        The format's name; SigMF datatype names where SigMF has one (``ci8``, ``ri8``,
        ``ci16_le``, ``cf32_le``).
    is_complex
        I/Q samples (complex) or real samples.
    bytes_per_chunk, samples_per_chunk
        The smallest whole unit of the format: ``samples_per_chunk`` samples (complex
        samples count once) in ``bytes_per_chunk`` bytes. A reader reads whole chunks only.
    sigmf_datatype
        The SigMF ``core:datatype`` this format is, or ``""`` where SigMF has none
        (packed 2-bit samples).
    """

    kind = "sample_source"
    is_complex: ClassVar[bool] = True
    bytes_per_chunk: ClassVar[int] = 2
    samples_per_chunk: ClassVar[int] = 1
    sigmf_datatype: ClassVar[str] = ""

    @abc.abstractmethod
    def decode(self, raw: np.ndarray) -> np.ndarray:
        """Samples from ``raw`` (``uint8``, a whole number of chunks).

        Returns ``complex64`` for complex formats (as recorded: the reader applies the
        Q sign) or ``float32`` for real ones, one value per sample.
        """

    @abc.abstractmethod
    def encode(self, samples: np.ndarray) -> bytes:
        """Bytes of ``samples`` (complex or real, already scaled to the format's units;
        values are rounded and clipped to what the format holds)."""


registry.register_kind("sample_source", SampleSource)  # this layer owns the kind's base
