"""GPS L5 (IS-GPS-705) and Galileo E5a (OS SIS ICD): the codes against the ICDs' own numbers
and the register properties the ICDs state, the descriptions, and generated recordings
acquired, overlay-synchronised and tracked through the generic blocks.

Truths: IS-GPS-705 Table 3-Ia's *initial XB code state* of I5 PRN 1 and 2 (a second column
of the table whose *advance* column the generator reads), the registers' periods
(XA short-cycled to 8190, XB maximal: 8191), and the first and last 24 chips of E5a codes
from the OS SIS ICD's hexadecimal listing of the primary codes (octal here, first chip the
most significant bit)."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples
from gnssframework.signal.galileo_e5a import GALILEO_E5AI, GALILEO_E5AQ
from gnssframework.signal.galileo_e5a_codes import (
    E5AI_SECONDARY_CS20,
    galileo_e5ai_code,
    galileo_e5aq_code,
    galileo_e5aq_secondary_code,
)
from gnssframework.signal.gps_l5 import GPS_L5I, GPS_L5Q, L5_FREQ_HZ, QZSS_L5Q
from gnssframework.signal.overlay import overlay_sync
from gnssframework.signal.gps_l5_codes import (
    L5I_XB_ADVANCE,
    gps_l5i_code,
    gps_l5q_code,
    l5_xa_chips,
    l5_xb_chips,
    l5_xb_state,
)
from pilot_tracking import pilot_sync_and_track

#: IS-GPS-705 Table 3-Ia, "Initial XB Code State" of I5 (stages 1-13), PRN 1 and 2.
I5_INITIAL_XB_STATE = {1: "0101011100100", 2: "1100000110101"}

#: OS SIS ICD, the primary codes in hexadecimal: first and last 24 chips (octal) of E5a-I
#: and E5a-Q, PRN 1, 2, 37 and 50.
E5A_FIRST_LAST_24 = {
    ("I", 1): (0o17165235, 0o07344277),
    ("Q", 1): (0o24252467, 0o71367772),
    ("I", 2): (0o47306361, 0o27612702),
    ("Q", 2): (0o65472471, 0o71166301),
    ("I", 37): (0o35142333, 0o02334643),
    ("Q", 37): (0o06004135, 0o37011066),
    ("I", 50): (0o51201234, 0o60241573),
    ("Q", 50): (0o24755016, 0o35646131),
}


def _octal24(chips: np.ndarray) -> int:
    bits = (np.asarray(chips) < 0).astype(int)  # +1 is logic 0
    return int("".join(map(str, bits)), 2)


def test_the_l5_registers_have_the_icds_periods():
    """XA is short-cycled: its 10230 chips are 8190 and the first 2040 again; XB is maximal
    (8191 chips, then again; 4096 ones a period, as an m-sequence of 13 stages has)."""
    xa, xb = l5_xa_chips(), l5_xb_chips()
    assert xa.size == xb.size == 10230
    np.testing.assert_array_equal(xa[8190:], xa[:2040])
    assert not np.array_equal(xa[8191 : 8191 + 100], xa[:100])
    np.testing.assert_array_equal(xb[8191:], xb[:2039])
    assert int(xb[:8191].sum()) == 4096
    assert not any(np.array_equal(xb[p : p + 500], xb[:500]) for p in range(1, 8191))


@pytest.mark.parametrize("prn", [1, 2])
def test_the_xb_advance_puts_the_register_in_the_icds_initial_state(prn):
    """Two columns of Table 3-Ia agree: the state after the *advance* is the *initial state*,
    and the code's first 13 chips (XA all ones there) are that state read from stage 13."""
    state = I5_INITIAL_XB_STATE[prn]
    assert l5_xb_state(L5I_XB_ADVANCE[prn - 1]) == state
    code_bits = (gps_l5i_code(prn)[:13] < 0).astype(int)
    assert "".join(str(1 - b) for b in code_bits[::-1]) == state


def test_the_l5_codes_are_distinct_balanced_and_nearly_orthogonal():
    """I5 and Q5 of PRN 1-32: every code's periodic autocorrelation off its peak, and every
    pair's cross-correlation at every lag, stay under 0.06 of the peak (a random 10230-chip
    code reaches about 4.5/sqrt(10230) = 0.045 somewhere); each code is balanced within 2 %."""
    codes = [gps_l5i_code(p) for p in range(1, 33)] + [gps_l5q_code(p) for p in range(1, 33)]
    f = np.fft.fft(np.array(codes, float), axis=1)
    worst_auto = max(np.abs(np.fft.ifft(fk * fk.conj()).real[1:]).max() for fk in f) / 10230
    worst_cross = 0.0
    for i in range(len(codes)):
        cross = np.abs(np.fft.ifft(f[i + 1 :] * f[i].conj(), axis=1).real).max() if i + 1 < len(codes) else 0.0
        worst_cross = max(worst_cross, cross / 10230)
    assert worst_auto < 0.06 and worst_cross < 0.06, (worst_auto, worst_cross)
    assert max(abs(int(c.sum())) for c in codes) < 0.02 * 10230


@pytest.mark.parametrize(("component", "prn"), sorted(E5A_FIRST_LAST_24))
def test_the_e5a_codes_begin_and_end_as_the_icds_listing(component, prn):
    code = (galileo_e5ai_code if component == "I" else galileo_e5aq_code)(prn)
    assert code.shape == (10230,)
    assert (_octal24(code[:24]), _octal24(code[-24:])) == E5A_FIRST_LAST_24[component, prn]


def test_the_e5a_secondary_codes_read_msb_first_and_differ_by_prn():
    """CS20_1 is ``842E9`` read most significant bit first; E5a-Q's CS100 differ from PRN to
    PRN (the description's per-PRN overlay: `SignalSpec.overlay`)."""
    assert E5AI_SECONDARY_CS20 == tuple(1 - 2 * int(b) for b in "10000100001011101001")
    assert galileo_e5aq_secondary_code(1)[:8] == tuple(1 - 2 * int(b) for b in "10000011")  # 0x83...
    overlays = {GALILEO_E5AQ.overlay(p) for p in range(1, 51)}
    assert len(overlays) == 50 and {len(o) for o in overlays} == {100}
    assert GALILEO_E5AQ.longest_coherent_s == pytest.approx(0.1)
    with pytest.raises(ConfigError, match="1-50"):
        GALILEO_E5AQ.overlay(51)


def test_the_descriptions_are_registered_with_the_icds_numbers():
    """1176.45 MHz = 115 x 10.23 MHz; 10.23 Mchip/s, 1 ms codes; I5 100 sps under NH10, Q5
    under NH20; E5a-I 50 sps under CS20; RINEX codes 5I and 5Q; QZSS PRN 193 is J01."""
    assert L5_FREQ_HZ == 115 * 10.23e6
    for spec in (GPS_L5I, GPS_L5Q, QZSS_L5Q, GALILEO_E5AI, GALILEO_E5AQ):
        assert registry.signal_spec(spec.name) is spec
        assert spec.code_period_s == pytest.approx(1e-3) and spec.is_bpsk
    assert GPS_L5I.code_periods_per_symbol == 10 and GPS_L5I.overlay_length() == 10
    assert GPS_L5Q.tracked.symbol_period_s is None and GPS_L5Q.overlay_length() == 20
    assert GALILEO_E5AI.code_periods_per_symbol == 20 and GALILEO_E5AI.overlay_length() == 20
    assert (GPS_L5I.rinex_code, GPS_L5Q.rinex_code, GALILEO_E5AQ.rinex_code) == ("5I", "5Q", "5Q")
    assert QZSS_L5Q.rinex_satellite(193) == "J01"
    np.testing.assert_array_equal(QZSS_L5Q.code(193), gps_l5q_code(193))
    with pytest.raises(ConfigError, match="1-63"):
        GPS_L5Q.code(64)


#: Complex samples at 25 MHz, 2.44 a chip (at 1.22, the peak's sampling costs up to 4.6 dB).
FS = 25e6


@pytest.mark.parametrize(
    ("spec", "prn", "doppler_hz", "code_phase_chips"),
    [(GPS_L5Q, 24, -1730.0, 7 * 10230 + 10230 - 3000.0), (GALILEO_E5AQ, 11, 2210.0, 40 * 10230 + 10230 - 5000.0)],
)
def test_a_generated_pilot_is_acquired_synchronised_and_tracked(spec, prn, doppler_hz, code_phase_chips):
    """The project's generator writes the pilot with its overlay (chip 7 of NH20, chip 40 of
    CS100_11 over the first primary period); the acquisition finds it at its Doppler and code
    phase, the overlay synchronisation finds the next chip where the first whole period
    starts, and with it wiped off the engine's scalar loop holds phase lock (one sign on I
    and a mean phase error under 20 degrees once pulled in). 45 dB-Hz. The Doppler is within
    one search bin (500 Hz at 1 ms): a 1 ms search resolves no better, and the overlay
    synchronisation measures the rest. The loop needs the channel's signal: with L1 C/A's
    chip rate in its carrier aiding (the closers' default before) the replica ran at a tenth
    of the code's rate and the lock was gone after the first interval."""
    sat = SatelliteSignal(prn, 45.0, doppler_hz=doppler_hz, code_phase_chips=code_phase_chips, signal=spec)
    n_sync = spec.overlay_length()
    duration_s = (n_sync + 81) * 1e-3
    x = synthesize_samples([sat], duration_s, FS, 0.0, np.random.default_rng(prn)).astype(np.complex64)
    acq = registry.create("acquisition", "pcps", noncoherent=4, doppler_max_hz=5000.0)
    found = {r.prn: r for r in acq.acquire(x, FS, 0.0, (prn, prn + 1), signal=spec) if r.detected}
    assert set(found) == {prn}
    r = found[prn]
    offset_chips = 10230 - code_phase_chips % 10230  # where chip 0 of the next period is
    expected_sample = offset_chips / spec.chip_rate_hz * FS
    assert (
        abs(r.code_phase_samples - expected_sample) <= 2 and abs(r.doppler_hz - doppler_hz) <= 500 and r.cn0_dbhz > 42.0
    )
    first_chip = int(code_phase_chips // 10230) + 1  # the overlay chip of that period
    shift, margin, prompts = pilot_sync_and_track(
        x, FS, spec, prn, r.doppler_hz, r.code_phase_samples, 80, sync_prompts=n_sync
    )
    # The match's margin over the runner-up, noise-free, from the overlay alone (1.46 for
    # NH20 over 20 prompts, 3.41 for CS100_11 over 100): the noisy one keeps most of it.
    overlay = np.array(spec.overlay(prn), float)
    clean = min(
        overlay_sync(overlay[(np.arange(n_sync) + k) % n_sync].astype(complex), overlay, 1e-3).margin
        for k in range(n_sync)
    )
    assert shift == first_chip % n_sync and margin > 0.75 * clean > 1
    after = prompts[40:]  # the loop's pull-in (its default 2nd-order PLL) is over by 40 ms
    assert np.all(np.sign(after.real) == np.sign(after.real[0]))
    assert abs(np.angle(np.mean(after * np.sign(after.real[0])))) < 0.35  # phase error under 20 deg
