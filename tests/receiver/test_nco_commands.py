"""One NCO convention (issue 36): the sample tracker's slot NCOs (`channels.nco`) take the
loop engine's three commands with the moves of the engine's `Channel`, on the same states
and commands.

The two hold the code phase differently (the engine absolutely, in chips of the primary
code; the tracker as chips into the current period, advanced in place by the compiled
kernel), so the comparison is of what each command moves: the code phase's jump
(``shift_chips``), the carrier frequency's (``shift_hz``), the new carrier frequency and
code rate, and the carrier phase step.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssframework.receiver.channels.nco import ReplicaNCOs
from gnssframework.receiver.engine.channel import Channel
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.galileo_e1 import GALILEO_E1C
from gnssframework.signal.spec import SignalSpec

T = 0.001
doppler = st.floats(-5e3, 5e3)
small = st.floats(-0.5, 0.5)


def _signals() -> list[SignalSpec]:
    return [GPS_L1CA, GALILEO_E1C]


def _pair(signal: SignalSpec, code_chips: float, doppler_hz: float) -> tuple[Channel, ReplicaNCOs]:
    """An engine channel at the end of an interval and the tracker's slot 1 of 3 in the same state."""
    ch = Channel.start((1,), code_chips, doppler_hz, signal=signal)
    ch.run_interval(T)
    nco = ReplicaNCOs(
        signal,
        np.array([5.0, code_chips, 7.0]),
        signal.code_freq_hz(np.array([100.0, doppler_hz, -300.0])),
        np.array([100.0, doppler_hz, -300.0]),
        np.zeros(3),
        np.zeros(3),
        np.zeros(3),
    )
    return ch, nco


def _untouched(nco: ReplicaNCOs) -> None:
    assert nco.code_phase[0] == 5.0 and nco.code_phase[2] == 7.0
    assert nco.doppler[0] == 100.0 and nco.doppler[2] == -300.0


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([0, 1]), st.floats(0, 1022), doppler, st.floats(-30, 30), st.floats(-3, 3))
def test_a_frequency_command_moves_both_alike(sig, code_chips, doppler_hz, d_hz, phase_step):
    signal = _signals()[sig]
    ch, nco = _pair(signal, code_chips, doppler_hz)
    carrier_end = ch._carrier_end
    f_new, code_f = doppler_hz + d_hz, signal.code_freq_hz(doppler_hz + d_hz) + 0.01 * d_hz
    ch.steer_frequency(np.array([f_new]), np.array([code_f]), phase_step)
    nco.at(np.array([1])).steer_frequency(np.array([f_new]), np.array([code_f]), phase_step)
    assert nco.shift_chips[1] == ch.shift_chips[0] == 0.0
    assert nco.shift_hz[1] == ch.shift_hz[0]
    assert nco.doppler[1] == ch.carrier_freq_hz[0] and nco.code_rate[1] == ch.code_rate_chips_s[0]
    np.testing.assert_allclose(2 * np.pi * nco.doppler_cycles[1], ch.carrier_phase_rad[0] - carrier_end[0], atol=1e-12)
    _untouched(nco)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([0, 1]), st.floats(0, 1022), doppler, small, st.floats(-20, 20))
def test_an_error_step_moves_both_alike(sig, code_chips, doppler_hz, code_step, freq_step):
    signal = _signals()[sig]
    ch, nco = _pair(signal, code_chips, doppler_hz)
    code_end = ch._code_end.copy()
    ch.steer_by_errors(np.array([code_step]), np.array([freq_step]))
    nco.at(np.array([1])).steer_by_errors(np.array([code_step]), np.array([freq_step]))
    assert nco.shift_chips[1] == ch.shift_chips[0] == code_step
    np.testing.assert_allclose(nco.shift_hz[1], ch.shift_hz[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(nco.code_phase[1] - code_chips, ch.code_phase_chips[0] - code_end[0], atol=1e-9)
    assert nco.doppler[1] == ch.carrier_freq_hz[0] and nco.code_rate[1] == ch.code_rate_chips_s[0]
    _untouched(nco)


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from([0, 1]),
    st.floats(2.0e7, 2.6e7),
    st.floats(-800, 800),
    st.floats(-150, 150),
    st.floats(-5, 5),
    st.floats(0.0, 600.0),
)
def test_a_range_command_moves_both_alike(sig, range_m, rate_m_s, d_range_m, d_rate_m_s, t_s):
    # The engine channel ran one interval from a range command at t - T: its replica now
    # holds the range + rate T at t; the tracker's slot is told that range.
    signal = _signals()[sig]
    ch = Channel.from_range((1,), np.array([range_m]), np.array([rate_m_s]), t_s=t_s - T, signal=signal)
    ch.run_interval(T)
    held_m = range_m + rate_m_s * T
    nco = ReplicaNCOs(
        signal,
        np.array([5.0, 300.0, 7.0]),
        signal.code_freq_hz(np.array([100.0, 0.0, -300.0])),
        np.array([100.0, ch.carrier_freq_hz[0], -300.0]),
        np.zeros(3),
        np.zeros(3),
        np.zeros(3),
    )
    new_range, new_rate = np.array([held_m + d_range_m]), np.array([rate_m_s + d_rate_m_s])
    ch.steer_range(new_range, new_rate, t_s)
    nco.steer_range(np.array([1]), np.array([held_m]), new_range, new_rate, np.array([t_s]))
    # Both jump by minus the range change over the chip length (chip counts of ~1e5: ulps of 1e-11).
    np.testing.assert_allclose(nco.shift_chips[1], -d_range_m / signal.chip_length_m, atol=1e-6)
    np.testing.assert_allclose(nco.shift_chips[1], ch.shift_chips[0], atol=1e-6)
    np.testing.assert_allclose(nco.code_phase[1] - 300.0, ch.shift_chips[0], atol=1e-6)
    assert nco.shift_hz[1] == ch.shift_hz[0]
    assert nco.doppler[1] == ch.carrier_freq_hz[0] and nco.code_rate[1] == ch.code_rate_chips_s[0]
    _untouched(nco)
