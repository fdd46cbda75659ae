"""SBAS L1 (RTCA DO-229): its codes against DO-229's initial G2 settings, its description and
registration, a synthetic recording, and the two real L1 recordings of PocketSDR, where the
peer receiver finds SBAS 130 137 140 143 144 (128 weaker) (../shared/data/README.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples
from gnssframework.signal.codes import _g1_g2_states
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.qzss_l1ca import QZSS_L1CA
from gnssframework.signal.sbas_codes import SBAS_L1_G2_DELAY, sbas_l1_code
from gnssframework.signal.sbas_l1 import SBAS_L1

DATA = Path(__file__).parents[1] / "data"

#: RTCA DO-229 Appendix A, "Initial G2 setting (octal)" of PRN 120-138: the G2 register's
#: content (stage 10 the most significant bit) at the code's first chip.
DO229_INITIAL_G2_OCTAL = (
    "1106",
    "1241",
    "0267",
    "0232",
    "1617",
    "1076",
    "1764",
    "0717",
    "1532",
    "1250",
    "0341",
    "0551",
    "0520",
    "1731",
    "0706",
    "1216",
    "0740",
    "1007",
    "0450",
)

#: PocketSDR's SBAS satellites in both L1 files (../shared/data/README.md), 128 the weaker.
POCKETSDR_SBAS = {128, 130, 137, 140, 143, 144}


def test_the_g2_delays_give_do229s_initial_g2_settings():
    """A code started from DO-229's initial G2 setting is the delayed G2 sequence: the
    setting is the all-ones G2 register's state ``1023 - d`` shifts on."""
    _, g2 = _g1_g2_states()
    for prn, published in zip(range(120, 139), DO229_INITIAL_G2_OCTAL):
        state = g2[(1023 - SBAS_L1_G2_DELAY[prn]) % 1023]  # stages 1..10
        assert int("".join(str(b) for b in state[::-1]), 2) == int(published, 8), f"PRN {prn}"
    # ... and the generator is G1 xor that G2: the first chip is stage 10 of both registers.
    code = sbas_l1_code(120)
    g1_first, g2_first = 1, int(DO229_INITIAL_G2_OCTAL[0], 8) >> 9
    assert code[0] == 1 - 2 * (g1_first ^ g2_first)


def test_sbas_codes_are_distinct_members_of_the_ca_gold_family():
    sbas = np.array([SBAS_L1.code(p) for p in SBAS_L1.prns], float)
    others = np.array([s.code(p) for s in (GPS_L1CA, QZSS_L1CA) for p in s.prns], float)
    everyone = np.vstack([sbas, others])
    fs, fa = np.fft.fft(sbas, axis=1), np.fft.fft(everyone, axis=1)
    for i in range(len(sbas)):
        cc = np.rint(np.fft.ifft(fs[i] * fa.conj(), axis=1).real).astype(int)
        assert cc[i, 0] == 1023 and set(cc[i, 1:]) <= {-65, -1, 63}
        assert set(np.delete(cc, i, axis=0).ravel()) <= {-65, -1, 63}


def test_the_description_and_its_registration():
    assert registry.signal_spec("sbas-l1") is SBAS_L1
    assert SBAS_L1.prns == tuple(range(120, 159)) and SBAS_L1.system == "S"
    assert SBAS_L1.code_periods_per_symbol == 2  # 500 symbols/s of the rate-1/2 250 bit/s message
    assert SBAS_L1.rinex_satellite(120) == "S20" and SBAS_L1.rinex_satellite(158) == "S58"
    with pytest.raises(ConfigError, match="120-158"):
        SBAS_L1.code(119)
    with pytest.raises(ConfigError, match="120-158"):
        sbas_l1_code(159)


def test_a_synthetic_sbas_satellite_is_acquired_at_its_doppler_and_code_phase():
    fs = 4e6
    sats = [SatelliteSignal(133, 45.0, 310.0, 512.3, signal=SBAS_L1), SatelliteSignal(5, 46.0, -1410.0, 300.0)]
    acq = registry.create("acquisition", "pcps")
    x = synthesize_samples(sats, acq.samples_needed(fs, SBAS_L1) / fs, fs, 0.0, np.random.default_rng(3))
    found = {r.prn: r for r in acq.acquire(x, fs, 0.0, signal=SBAS_L1) if r.detected}
    assert set(found) == {133}
    d = (found[133].code_phase_chips - 512.3) % 1023
    assert min(d, 1023 - d) <= SBAS_L1.chip_rate_hz / fs and abs(found[133].doppler_hz - 310.0) <= 250.0


def _acquire(name, fmt, fs, if_hz, q_sign, signal, noncoherent, prns=None):
    rec = open_recording(DATA / name, format=fmt, sample_rate_hz=fs, if_hz=if_hz, q_sign=q_sign)
    acq = registry.create("acquisition", "pcps", noncoherent=noncoherent, xcorr_margin_db=None)
    samples = rec.read(0, acq.samples_needed(fs, signal))
    return {r.prn: r for r in acq.acquire(samples, fs, if_hz, prns, signal=signal)}


@pytest.mark.parametrize(
    "name, fmt, fs, if_hz, q_sign, noncoherent",
    [
        ("pocketsdr_L1_4MHz_IQ_100ms.bin", "ci8", 4e6, 0.0, -1, 10),
        ("pocketsdr_L1_12MHz_I_30ms.bin", "ri8", 12e6, 3e6, 1, 6),
    ],
)
def test_the_real_recordings_show_pocketsdrs_sbas_satellites(name, fmt, fs, if_hz, q_sign, noncoherent):
    """PocketSDR's six are detected and are the six strongest of the 39 PRNs; being
    geostationary, their Dopplers are one receiver-clock offset within one coarse bin
    (500 Hz) of each other; QZS-3 sends SBAS 137 and L1 C/A 199 at one code epoch
    (../shared/data/README.md), so both searches put them at one code phase."""
    res = _acquire(name, fmt, fs, if_hz, q_sign, SBAS_L1, noncoherent)
    assert all(res[p].detected for p in POCKETSDR_SBAS)
    ranked = sorted(res.values(), key=lambda r: -r.test_statistic)
    assert {r.prn for r in ranked[: len(POCKETSDR_SBAS)]} == POCKETSDR_SBAS
    dopplers = [res[p].doppler_hz for p in POCKETSDR_SBAS]
    assert max(dopplers) - min(dopplers) <= 500.0
    qzs3 = _acquire(name, fmt, fs, if_hz, q_sign, QZSS_L1CA, noncoherent, (199,))[199]
    d = (qzs3.code_phase_chips - res[137].code_phase_chips) % 1023
    assert qzs3.detected and min(d, 1023 - d) <= 1023e3 / fs
