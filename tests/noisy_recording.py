"""The tail the generated recordings share (`lnav_recordings`, `inav_recordings`,
`mixed_recordings`, tests/receiver/test_lnav_samples.py): chunks of signal, white noise added,
written as complex int16 SigMF, chunk by chunk so a long recording never sits in memory."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from gnssframework import registry
from gnssframework.receiver.frontend.sigmf_meta import meta_path_for, write_sigmf_meta

#: Factor from the generator's units (unit-variance noise per component) to int16 counts.
SCALE = 300.0
FORMAT = "ci16_le"
#: The noise's standard deviation in counts of each format (int8: 16, as `if_samples` scales it).
SCALES = {"ci16_le": SCALE, "ci8": 16.0}


def write_noisy_recording(
    path: Path, chunks: Iterable[np.ndarray], fs: float, rng: np.random.Generator | None = None, fmt: str = FORMAT
) -> Path:
    """Write the complex ``chunks`` (a generator: each is made when written) to ``path`` as
    ``(x + n) * SCALES[fmt]`` in ``fmt`` (ci16_le, or ci8 for a file half the size), ``n``
    complex white noise of variance 1 per component drawn from ``rng`` after the chunk is
    made (``rng=None``: the chunks carry their noise), and the ``.sigmf-meta`` beside it
    (rate ``fs``, IF 0) as `write_recording` writes it."""
    source = registry.create("sample_source", fmt)
    with open(path, "wb") as out:
        for x in chunks:
            if rng is not None:
                x = x + (rng.standard_normal(x.size) + 1j * rng.standard_normal(x.size))
            out.write(source.encode(x * SCALES[fmt]))
    write_sigmf_meta(
        meta_path_for(path), format=fmt, sigmf_datatype=source.sigmf_datatype, sample_rate_hz=fs, if_hz=0.0
    )
    return path
