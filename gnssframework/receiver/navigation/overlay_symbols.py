"""Symbols from a run of one-code-period rows whose tracked component carries an overlay.

Where a data symbol spans the overlay's period (GPS L5 I5: ten 1 ms periods under NH10;
Galileo E5a-I: twenty under CS20_1), the overlay's first chip starts a symbol (IS-GPS-705
3.3.2.2; OS SIS ICD 3.5). The tracker integrates one code period and does not wipe the
overlay off (`channels.signal_settings.coherent_periods`), so a run's prompts carry
:math:`d_{\\lfloor (k+s)/N \rfloor}\\, o_{(k+s) \bmod N}`: the overlay's phase ``s`` is found by
the differential match of `signal.overlay.overlay_sync` (blind to the residual Doppler and,
but for one product a symbol, to the data), then wiped off, and the ``N`` rows of each
symbol are summed, in phase.
"""

from __future__ import annotations

import numpy as np

from ...signal.overlay import overlay_sync
from ...signal.spec import SignalSpec

__all__ = ["overlay_symbols_of_run"]


def overlay_symbols_of_run(
    prompt_i: np.ndarray, prompt_q: np.ndarray, signal: SignalSpec, prn: int
) -> tuple[np.ndarray, np.ndarray]:
    """The soft symbols of one gap-free run of one-period rows and, for each, the index in
    the run of the row its symbol starts on (module text): the rows themselves without an
    overlay (L2 CM, E1-B); under one, the overlay synchronised, wiped off and a symbol's rows
    summed (none when the run is too short to synchronise: three overlay periods)."""
    overlay = np.asarray(signal.overlay(prn), float)
    if overlay.size == 0:
        return np.asarray(prompt_i, float), np.arange(np.size(prompt_i))
    per = int(signal.code_periods_per_symbol or 1)
    if np.size(prompt_i) < 3 * overlay.size:
        return np.zeros(0), np.zeros(0, int)
    p = np.asarray(prompt_i, float) + 1j * np.asarray(prompt_q, float)
    shift = overlay_sync(p, overlay, signal.code_period_s).shift  # the overlay chip of row 0
    first = (-shift) % overlay.size  # the first row on chip 0: a symbol's start
    n = (p.size - first) // per
    rows = first + np.arange(n * per)
    wiped = np.asarray(prompt_i, float)[rows] * overlay[(rows + shift) % overlay.size]
    return wiped.reshape(n, per).sum(axis=1), first + per * np.arange(n)
