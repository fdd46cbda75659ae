"""Writing samples in any registered format, with a SigMF metadata file beside them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import registry
from ...errors import ConfigError
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .sigmf_meta import meta_path_for, write_sigmf_meta

__all__ = ["write_recording"]


def write_recording(
    path: str | Path,
    samples: np.ndarray,
    format: str,
    sample_rate_hz: float,
    if_hz: float,
    *,
    q_sign: int = 1,
    scale: float = 1.0,
    start_time: str | None = None,
    sigmf: bool = True,
    signal: SignalSpec = GPS_L1CA,
) -> Path:
    """Write ``samples * scale`` to ``path`` in ``format`` (and ``path``'s ``.sigmf-meta``).

    Parameters
    ----------
    samples
        Complex samples for complex formats, real ones for real formats.
    q_sign
        -1 writes the Q branch inverted (as some front ends do); the metadata says so,
        so reading it back gives ``samples`` again.
    scale
        Factor to the format's units (integer formats are rounded and clipped).
    signal
        The signal of the band recorded: the metadata's ``core:frequency`` is its carrier
        minus ``if_hz`` (GPS L1 C/A's by default).
    """
    source = registry.create("sample_source", format)
    samples = np.asarray(samples)
    if source.is_complex != np.iscomplexobj(samples):
        raise ConfigError(
            "format",
            f"{format} holds {'complex' if source.is_complex else 'real'} samples, got "
            f"{'complex' if np.iscomplexobj(samples) else 'real'} ones",
        )
    if samples.size % source.samples_per_chunk:
        raise ConfigError("samples", f"{format} stores {source.samples_per_chunk} samples a chunk; got {samples.size}")
    x = samples * scale
    if source.is_complex and q_sign < 0:
        x = np.conj(x)
    path = Path(path)
    path.write_bytes(source.encode(x))
    if sigmf:
        write_sigmf_meta(
            meta_path_for(path),
            format=format,
            sigmf_datatype=source.sigmf_datatype,
            sample_rate_hz=sample_rate_hz,
            if_hz=if_hz,
            q_sign=q_sign,
            start_time=start_time,
            signal=signal,
        )
    return path
