"""Acquisition's cost: the ``pcps`` search of 32 PRNs, and its carrier wipe-off against the
exact ``complex128`` carrier it replaced, in the same run.

Two searches on a generated recording (8 satellites at 45 dB-Hz, the rest noise):

- the default search, 1 ms coherent times 2 non-coherent blocks;
- the weak-signal search, 10 ms blocks summed by parity (``alternate_blocks``), 8 blocks.

For each, best of ``--repeat``: the whole search, and the same search with the previous
carrier wipe-off swapped in (``np.exp`` in ``complex128`` cast to ``complex64``, kept here
as the reference) with the ratio; then the wipe-off of one Doppler chunk alone, ours
(`fft_search._wiped_spectra`: a ``float32`` carrier from a phase reduced to one cycle)
against the previous. A weak-signal search's grid holds about 3 PRNs at a time
(``_GRID_ELEMENTS``), so it wipes off and transforms the blocks once per group of PRNs.

    python benchmarks/acquisition.py [--fs 2.6e6] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import time
from functools import partial

import numpy as np
from scipy import fft

from gnssframework import registry
from gnssframework.receiver.acquisition import fft_search
from gnssframework.receiver.acquisition.fft_search import _CHUNK_ELEMENTS, _wiped_spectra
from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples


def _exact_wiped(blocks: np.ndarray, dopplers_hz: np.ndarray, fs: float, if_hz: float) -> np.ndarray:
    """The previous wipe-off: ``complex128`` ``exp`` over the blocks, cast to ``complex64``."""
    k, n = blocks.shape
    t = (np.arange(k * n) / fs).reshape(k, n)
    carrier = np.exp(-2j * np.pi * (if_hz + dopplers_hz[:, None, None]) * t).astype(np.complex64)
    return fft.fft(blocks[None].astype(np.complex64) * carrier, axis=-1, workers=1)


def _best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


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
    print(
        f"{'search':30s} {'whole s':>8s} {'with exp s':>11s} {'ratio':>6s} {'chunk s':>8s} {'exp s':>7s} {'ratio':>6s}"
    )
    for label, params in (
        ("1 ms x 2 (default)", {}),
        ("10 ms x 8 by parity (weak)", {"coherent_ms": 10, "noncoherent": 8, "alternate_blocks": True}),
    ):
        acq = registry.create("acquisition", "pcps", **params)
        whole = _best(partial(acq.acquire, x, fs, 0.0), args.repeat)
        fft_search._wiped_spectra = _exact_wiped
        try:
            previous = _best(partial(acq.acquire, x, fs, 0.0), args.repeat)
        finally:
            fft_search._wiped_spectra = _wiped_spectra
        n = int(round(acq._coherent_s(acq_signal := sats[0].signal) * fs))
        k = acq.params.noncoherent
        blocks = x[: n * k].reshape(k, n)
        step = max(1, _CHUNK_ELEMENTS // (k * n))
        dopplers = acq.dopplers_hz(acq_signal)[:step]
        ours = _best(partial(_wiped_spectra, blocks, dopplers, fs, 0.0), args.repeat)
        exact = _best(partial(_exact_wiped, blocks, dopplers, fs, 0.0), args.repeat)
        print(
            f"{label:30s} {whole:8.2f} {previous:11.2f} {previous / whole:6.2f} "
            f"{ours:8.3f} {exact:7.3f} {exact / ours:6.2f}"
        )


if __name__ == "__main__":
    main()
