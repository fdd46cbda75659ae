"""`nco_words.period_words` (the compiled pass that makes a `correlate_periods` call's NCO
words and reach) against the NumPy arithmetic it replaced, written out here: the same
words to the bit, the same reach, periods and work, on phases and steps of either sign,
near whole cycles and near the 2^-32 word's rounding edges."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from gnssframework.errors import ConfigError
from gnssframework.receiver.channels.correlator import correlate_periods
from gnssframework.receiver.channels.nco_words import _period_words, carrier_words, period_words

N_CODE = 1023


def numpy_words(starts, n_periods, phase, step, carrier_phase, carrier_step, n_code):
    """The NumPy lines `correlate_periods` ran before `period_words` (commit 546c0d8)."""
    carrier0, dcarrier = carrier_words(carrier_phase, carrier_step)
    code0 = np.floor((phase + n_code) * 2.0**32).astype(np.int64)
    dcode = np.rint(step * 2.0**32).astype(np.int64)
    need = starts + np.ceil((n_periods * n_code - phase) / step + 1).astype(np.int64)
    work = int(n_periods.sum()) * n_code / float(step.min(initial=1.0))
    return carrier0, dcarrier, code0, dcode, starts.min(), need.max(), max(1, int(n_periods.max(initial=1))), work


edges = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.5, 1 - 2.0**-33, -(2.0**-33), 2.0**-33, 1e-20, -1e-20])
values = st.one_of(edges, st.floats(-3.0, 3.0, allow_nan=False), st.floats(-1e4, 1e4, allow_nan=False))


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 12).flatmap(
        lambda n: st.tuples(
            st.lists(st.integers(0, 10**6), min_size=n, max_size=n),
            st.lists(st.integers(0, 20), min_size=n, max_size=n),
            st.lists(st.one_of(edges, st.floats(-1.0, 1.0)), min_size=n, max_size=n),
            st.lists(st.floats(0.05, 2.5), min_size=n, max_size=n),
            st.lists(values, min_size=n, max_size=n),
            st.lists(values, min_size=n, max_size=n),
        )
    )
)
def test_period_words_equal_the_numpy_arithmetic(case):
    starts, n_periods, phase, step, cphase, cstep = (
        np.asarray(v, t) for v, t in zip(case, [np.int64] * 2 + [float] * 4)
    )
    args = (starts, n_periods, phase, step, cphase, cstep, N_CODE)
    want = numpy_words(*args)
    for got in (period_words(*args), _period_words(*args)):  # compiled, and the no-numba fallback
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)


def test_periods_beyond_the_block_are_refused_with_their_range():
    codes = np.ones((1, N_CODE), np.float32)
    x = np.zeros(2 * 5000, np.int8)
    args = ([100], [2], [0.0], [1.023e6 / 2.6e6], [0.0], [0.01], codes, [-0.5, 0.0, 0.5])
    with pytest.raises(ConfigError, match=r"periods \[100, 5\d\d\d\) reach outside the block of 5000 samples"):
        correlate_periods(x, *(np.asarray(a) for a in args[:6]), codes, np.asarray(args[7]), iq=True)
