"""`correlate_channels` against an independent replica (issue 36: "wrong correlations when
a block spans more than 2 code periods and starts at a negative code phase").

The replica is the correlator's definition written out sample by sample, without the
library's tables or its own reference (`correlate_numpy`): at sample :math:`i` the tap at
offset :math:`o` reads the code chip :math:`c(\\lfloor p + o + i\\,\\Delta p \\rfloor \\bmod L)`
straight from the code generator (times, for Galileo E1's BOC(1,1) replica, the
sub-carrier :math:`\\mathrm{sign}\\,\\sin 2\\pi x`: +1 on a chip's first half, -1 on its
second, E1-B's sign, Galileo OS SIS ICD sec. 2.3.3), the carrier
:math:`e^{-j2\\pi(\\phi + i\\Delta\\phi)}` is wiped off and the products summed.

The tolerance is what the two may honestly differ by: `correlation_error_bound` (the
kernel's float32 sums and its NCO words' rounding) plus :math:`2|x_i|` for every sample
whose replica phase lies within the NCO words' rounding (:math:`2^{-32}` of a table unit
per sample run, plus the initial word's) of a chip or sub-chip edge, where the exact
arithmetic and the fixed-point word may read neighbouring chips. A wrong chip over any
stretch of the block adds a random-walk sum of :math:`\\sqrt{N}|x|` order, far above it.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from gnssframework.receiver.channels.correlator import (
    code_tables,
    correlate_channels,
    correlation_error_bound,
    replica_codes,
    to_table_units,
)
from gnssframework.signal.codes import ca_code
from gnssframework.signal.galileo_codes import galileo_e1b_code
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA

CHIP_RATE_HZ = 1.023e6  # both signals' (IS-GPS-200 3.3.1.1; Galileo OS SIS ICD table 3)
#: (spec, code generator, code length in chips, BOC(1,1) sub-carrier?)
SIGNALS = {
    "gps-l1ca": (GPS_L1CA, ca_code, 1023, False),
    "galileo-e1b-boc11": (GALILEO_E1B_BOC11, galileo_e1b_code, 4092, True),
}


def replica_sums(x, start, count, phase_chips, step_chips, carrier_cycles, carrier_step, prn, offsets_chips, signal):
    """The independent replica: ``(n_taps,)`` sums of one channel, and each tap's
    ``(count,)`` mask of samples on an edge (within the NCO words' rounding)."""
    _, generator, length, boc = SIGNALS[signal]
    code = np.asarray(generator(prn), float)
    i = np.arange(count)
    base = x[start : start + count].astype(complex) * np.exp(-2j * np.pi * (carrier_cycles + i * carrier_step))
    units = 2 if boc else 1  # table units (sub-chips) per chip
    slack = (2.0 + i) * 2.0**-32 + 1e-9  # the words' rounding, in table units, and float64's
    sums, edges = [], []
    for o in offsets_chips:
        x_chips = phase_chips + o + i * step_chips
        chip = code[np.floor(x_chips).astype(np.int64) % length]
        if boc:
            chip = chip * np.where(np.mod(x_chips, 1.0) < 0.5, 1.0, -1.0)
        sums.append(np.sum(base * chip))
        u = x_chips * units
        edges.append(np.abs(u - np.rint(u)) < slack)
    return np.array(sums), edges


def check(signal, fs, starts, counts, phases, rates_hz, dopplers_hz, carrier0, prns, offsets, rng, tables=None):
    """correlate_channels (both backends) against `replica_sums`, channel by channel, tap by tap."""
    spec = SIGNALS[signal][0]
    n = int(np.max(starts + counts)) + 7
    x = (rng.normal(0, 20, n) + 1j * rng.normal(0, 20, n)).astype(np.complex64)
    steps = rates_hz / fs
    dph = dopplers_hz / fs
    codes = replica_codes(spec, prns)
    args = (
        x,
        starts,
        counts,
        to_table_units(phases, spec),
        to_table_units(steps, spec),
        carrier0,
        dph,
        codes,
        to_table_units(offsets, spec),
    )
    for backend in ("numba", "numpy"):
        got = correlate_channels(*args, backend=backend, tables=tables if backend == "numba" else None)
        for c in range(len(starts)):
            want, edges = replica_sums(
                x, starts[c], counts[c], phases[c], steps[c], carrier0[c], dph[c], prns[c], offsets, signal
            )
            bound = correlation_error_bound(x, starts[c], counts[c])
            mag = np.abs(x[starts[c] : starts[c] + counts[c]])
            for t in range(len(offsets)):
                allowed = bound + 2 * float(np.sum(mag[edges[t]]))
                err = abs(got[c, t] - want[t])
                assert err <= allowed, (
                    f"{backend} {signal} fs={fs:g} channel {c}: start phase {phases[c]:g} chips, "
                    f"{counts[c] * steps[c] / SIGNALS[signal][2]:.3f} code periods, tap {offsets[t]:g}: "
                    f"|{got[c, t]:.1f} - {want[t]:.1f}| = {err:.3g} > {allowed:.3g}"
                )


#: Start phases in chips, as fractions: just below 0, 0, just below the period's end,
#: several periods below 0, several above, mid-period.
def start_phases(length, rng):
    return np.array(
        [
            -rng.uniform(1e-6, 0.9),
            0.0,
            length - rng.uniform(1e-6, 0.9),
            -2.7 * length,
            3.3 * length + 0.25,
            length / 2 + 0.1,
        ]
    )


@pytest.mark.parametrize(
    "signal,fs", [("gps-l1ca", 2.6e6), ("gps-l1ca", 16.3676e6), ("galileo-e1b-boc11", 4e6), ("galileo-e1b-boc11", 12e6)]
)
@pytest.mark.parametrize("periods", [0.6, 2.5, 4.7])
def test_correlate_channels_matches_an_independent_replica(signal, fs, periods):
    """Six channels per call (every start-phase kind of `start_phases`) over blocks of
    ``periods`` code periods (0.6 to 4.7 ms of C/A, 2.4 to 19 ms of E1; C/A at 4 MHz is in
    the Hypothesis sweep below), Doppler within ±6 kHz and code rates off the nominal by
    ±5e-6 (Doppler) and ±3e-4 (a loop's NCO correction)."""
    rng = np.random.default_rng([len(signal), int(fs), int(periods * 10)])
    length = SIGNALS[signal][2]
    phases = start_phases(length, rng)
    k = phases.size
    rates = CHIP_RATE_HZ * (1 + rng.uniform(-5e-6, 5e-6, k) + rng.choice([0.0, 3e-4, -3e-4], k))
    counts = (periods * length / (rates / fs) * rng.uniform(0.97, 1.03, k)).astype(np.int64)
    starts = rng.integers(0, 50, k)
    offsets = np.array([-0.5, -0.1, 0.0, 0.1, 0.5]) if SIGNALS[signal][3] else np.array([-0.5, 0.0, 0.5])
    check(
        signal,
        fs,
        starts,
        counts,
        phases,
        rates,
        rng.uniform(-6e3, 6e3, k),
        rng.uniform(0, 1, k),
        rng.integers(1, 33, k),
        offsets,
        rng,
    )


def test_a_callers_tables_too_short_for_the_block_are_not_used():
    """A tracker makes `code_tables` once for three code lengths of the prompt's word; a
    block of five periods from a negative phase needs more, and must not read past them."""
    rng = np.random.default_rng(36)
    fs = 4e6
    prns = np.array([3, 17])
    offsets = np.array([-0.5, 0.0, 0.5])
    tables = code_tables(replica_codes(GPS_L1CA, prns), offsets, 3)
    check(
        "gps-l1ca",
        fs,
        np.array([0, 11]),
        np.array([int(5.2e-3 * fs), int(4.1e-3 * fs)]),
        np.array([-0.3, -700.2]),
        np.full(2, CHIP_RATE_HZ * (1 + 2e-6)),
        np.array([1234.5, -3300.0]),
        np.array([0.1, 0.9]),
        prns,
        offsets,
        rng,
        tables=tables,
    )


@settings(max_examples=40, deadline=None, derandomize=True)
@given(
    phase_chips=st.one_of(st.floats(-1.0, 0.0), st.floats(-5000.0, 5000.0), st.floats(1022.0, 1023.0)),
    periods=st.floats(0.05, 5.5),
    fs=st.sampled_from([2.6e6, 4e6, 16.3676e6]),
    rate_error=st.floats(-1e-3, 1e-3),
    doppler_hz=st.floats(-8e3, 8e3),
    seed=st.integers(0, 2**32 - 1),
)
def test_correlate_channels_matches_the_replica_from_any_start_phase(
    phase_chips, periods, fs, rate_error, doppler_hz, seed
):
    rng = np.random.default_rng(seed)
    rate = CHIP_RATE_HZ * (1 + rate_error)
    count = max(1, int(periods * 1023 / (rate / fs)))
    check(
        "gps-l1ca",
        fs,
        np.array([5]),
        np.array([count]),
        np.array([phase_chips]),
        np.array([rate]),
        np.array([doppler_hz]),
        np.array([rng.uniform()]),
        np.array([int(rng.integers(1, 33))]),
        np.array([-0.5, 0.0, 0.5]),
        rng,
    )
