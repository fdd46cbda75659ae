"""The tail the generated recordings share (`lnav_recordings`, `inav_recordings`,
`mixed_recordings`, `l2c_recordings`, tests/receiver/test_lnav_samples.py): chunks of
signal (`signal_chunks`), white noise added, written as complex int16 (or int8) SigMF,
chunk by chunk so a long recording never sits in memory."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from gnssframework import registry
from gnssframework.signal.if_samples import generate_if_samples
from gnssframework.signal.spec import SignalSpec
from gnssframework.receiver.frontend.sigmf_meta import meta_path_for, write_sigmf_meta

#: Factor from the generator's units (unit-variance noise per component) to int16 counts.
SCALE = 300.0
FORMAT = "ci16_le"
#: Seconds of signal a chunk (the geometry is updated every chunk).
CHUNK_S = 0.5
#: The noise's standard deviation in counts of each format (int8: 16, as `if_samples` scales it).
SCALES = {"ci16_le": SCALE, "ci8": 16.0}


def write_noisy_recording(
    path: Path,
    chunks: Iterable[np.ndarray],
    fs: float,
    rng: np.random.Generator | None = None,
    fmt: str = FORMAT,
    if_hz: float = 0.0,
) -> Path:
    """Write the complex ``chunks`` (a generator: each is made when written) to ``path`` as
    ``(x + n) * SCALES[fmt]`` in ``fmt`` (ci16_le, or ci8 for a file half the size), ``n``
    complex white noise of variance 1 per component drawn from ``rng`` after the chunk is
    made (``rng=None``: the chunks carry their noise), and the ``.sigmf-meta`` beside it
    (rate ``fs``, IF ``if_hz``) as `write_recording` writes it."""
    source = registry.create("sample_source", fmt)
    with open(path, "wb") as out:
        for x in chunks:
            if rng is not None:
                x = x + (rng.standard_normal(x.size) + 1j * rng.standard_normal(x.size))
            out.write(source.encode(x * SCALES[fmt]))
    write_sigmf_meta(
        meta_path_for(path), format=fmt, sigmf_datatype=source.sigmf_datatype, sample_rate_hz=fs, if_hz=if_hz
    )
    return path


def signal_chunks(
    sats, tow0: float, duration_s: float, signal: SignalSpec, fs: float, sv_time, streams, cn0_dbhz, rng, if_hz=0.0
):
    """The noise-free samples of ``sats`` sending ``signal`` at IF ``if_hz``, chunk by chunk (`CHUNK_S` s):
    each satellite's code phase, Doppler and symbol timing from ``sv_time(sats, t_rx)`` (its
    signal's SV time at true time ``t_rx``), its symbols and their first's SV time from
    ``streams``; the overlay's chip ``k`` on the ``k``-th code period of SV time."""
    n = int(round(CHUNK_S * fs))
    period = signal.code_period_s
    periods = max(1, signal.overlay_length())  # code phase counted over the overlay's period
    phase = np.zeros(sats.sv.size)
    for c in range(int(round(duration_s / CHUNK_S))):
        t0 = c * CHUNK_S
        start = sv_time(sats, tow0 + t0)
        end = sv_time(sats, tow0 + t0 + CHUNK_S)
        doppler = signal.carrier_freq_hz * ((end - start) / CHUNK_S - 1.0)
        x = np.zeros(n, complex)
        for k in range(sats.sv.size):
            symbols, first_tsv = streams[k]
            x += generate_if_samples(
                int(sats.sv[k][1:]),
                CHUNK_S,
                fs,
                if_hz,
                cn0_dbhz,
                rng,
                doppler_hz=doppler[k],
                code_phase_chips=(start[k] / period % periods) * signal.code_length_chips,
                carrier_phase_rad=phase[k],
                complex_samples=True,
                data_bits=symbols,
                first_bit_edge_s=first_tsv - start[k],
                noise=False,
                signal=signal,
            ).samples
            phase[k] += 2 * np.pi * (if_hz + doppler[k]) * CHUNK_S
        yield x
