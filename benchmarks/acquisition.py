"""Acquisition's cost: the ``pcps`` search of 32 PRNs against its own earlier wipe-offs, in
the same run.

Two searches on a generated recording (8 satellites at 45 dB-Hz, the rest noise):

- the default search, 1 ms coherent times 2 non-coherent blocks;
- the weak-signal search, 10 ms blocks summed by parity (``alternate_blocks``), 8 blocks.

Each is timed (best of ``--repeat``) three ways, the rest of the search unchanged:

- ``ours``: the Doppler bins that lie whole DFT bins apart are shifts of a few wiped spectra
  (`fft_search._DopplerSpectra`: two per search on the default grids);
- ``per bin``: every bin's blocks wiped and transformed on their own, with the ``float32``
  carrier from a phase reduced to one cycle (`fft_search._wiped_spectra`);
- ``exp``: the same with ``np.exp`` in ``complex128`` cast to ``complex64``, the carrier of
  0.2.x (kept here as the reference).

A weak-signal search's grid holds about 3 PRNs at a time (the pcps plugin's
``_GRID_ELEMENTS``): the per-bin ways wipe off and transform every bin once per group.

    python benchmarks/acquisition.py [--fs 2.6e6] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import timeit
from functools import partial

import numpy as np
from scipy import fft

from gnssframework import registry
from gnssframework.receiver.acquisition import fft_search
from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples


def _exact_wiped(blocks: np.ndarray, dopplers_hz: np.ndarray, fs: float, if_hz: float) -> np.ndarray:
    """The 0.2.x wipe-off: ``complex128`` ``exp`` over the blocks, cast to ``complex64``."""
    k, n = blocks.shape
    t = (np.arange(k * n) / fs).reshape(k, n)
    carrier = np.exp(-2j * np.pi * (if_hz + dopplers_hz[:, None, None]) * t).astype(np.complex64)
    return fft.fft(blocks[None].astype(np.complex64) * carrier, axis=-1, workers=1)


class _PerBin(fft_search._DopplerSpectra):
    """Every bin wiped on its own (no shifted spectra)."""

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.base = None


def _timed(acquire, repeat: int, spectra=None, wiped=None) -> float:
    """``acquire`` timed with ``fft_search``'s spectra class and wipe-off swapped for these."""
    saved = fft_search._DopplerSpectra, fft_search._wiped_spectra
    fft_search._DopplerSpectra = spectra or saved[0]
    fft_search._wiped_spectra = wiped or saved[1]
    try:
        return min(timeit.repeat(acquire, number=1, repeat=repeat))  # best of `repeat`
    finally:
        fft_search._DopplerSpectra, fft_search._wiped_spectra = saved


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fs", type=float, default=2.6e6, help="sample rate (Hz), complex samples at zero IF")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    fs = args.fs
    sats = [
        SatelliteSignal(p, 45.0, float(rng.uniform(-4000, 4000)), float(rng.uniform(0, 1023)), 0.0, 0)
        for p in (3, 6, 9, 12, 17, 22, 25, 31)
    ]
    x = synthesize_samples(sats, 0.081, fs, 0.0, rng)
    print(f"load average {os.getloadavg()[0]:.1f} at start, {os.cpu_count()} cores; fs {fs / 1e6:g} MHz, 32 PRNs")
    print(f"{'search (s)':30s} {'ours':>7s} {'per bin':>8s} {'exp':>7s} {'per bin / ours':>15s} {'exp / ours':>11s}")
    for label, params in (
        ("1 ms x 2 (default)", {}),
        ("10 ms x 8 by parity (weak)", {"coherent_ms": 10, "noncoherent": 8, "alternate_blocks": True}),
    ):
        acquire = partial(registry.create("acquisition", "pcps", **params).acquire, x, fs, 0.0)
        ours = _timed(acquire, args.repeat)
        per_bin = _timed(acquire, args.repeat, spectra=_PerBin)
        exp = _timed(acquire, args.repeat, spectra=_PerBin, wiped=_exact_wiped)
        print(f"{label:30s} {ours:7.2f} {per_bin:8.2f} {exp:7.2f} {per_bin / ours:15.2f} {exp / ours:11.2f}")


if __name__ == "__main__":
    main()
