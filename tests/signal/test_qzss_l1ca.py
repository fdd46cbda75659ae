"""QZSS L1 C/A, the worked example of docs/receiver/new-signal.md: its codes (G2 delays of
IS-QZSS-PNT on the C/A Gold generator, the delay convention checked on GPS's own table),
its registration, and a synthetic recording of a QZSS satellite acquired by the generic
frontend generator and the generic acquisition at its Doppler and code phase."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples
from gnssframework.signal.codes import ca_code
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.qzss_codes import gold_code_by_g2_delay, qzss_l1ca_code
from gnssframework.signal.qzss_l1ca import QZSS_L1CA

#: IS-GPS-200 Table 3-Ia, "G2 delay (chips)" of PRN 1-32: the same generator rule must give
#: GPS C/A (whose first chips the project checks against the same table, test_codes.py).
GPS_G2_DELAY = (
    5,
    6,
    7,
    8,
    17,
    18,
    139,
    140,
    141,
    251,
    252,
    254,
    255,
    256,
    257,
    258,
    469,
    470,
    471,
    472,
    473,
    474,
    509,
    512,
    513,
    514,
    515,
    516,
    859,
    860,
    861,
    862,
)


def test_the_g2_delay_rule_gives_the_gps_ca_codes():
    for prn, delay in enumerate(GPS_G2_DELAY, start=1):
        np.testing.assert_array_equal(gold_code_by_g2_delay(delay), ca_code(prn), err_msg=f"PRN {prn}")


def test_qzss_codes_are_members_of_the_ca_gold_family_distinct_from_gps():
    """Every QZSS code against itself and every GPS and QZSS code: the three Gold values
    {-65, -1, 63} (a code outside the family, or a repeated one, breaks them)."""
    qzss = np.array([QZSS_L1CA.code(p) for p in QZSS_L1CA.prns], float)
    everyone = np.vstack([qzss, np.array([GPS_L1CA.code(p) for p in GPS_L1CA.prns], float)])
    fq, fa = np.fft.fft(qzss, axis=1), np.fft.fft(everyone, axis=1)
    for i in range(len(qzss)):
        cc = np.rint(np.fft.ifft(fq[i] * fa.conj(), axis=1).real).astype(int)
        assert cc[i, 0] == 1023 and set(cc[i, 1:]) <= {-65, -1, 63}
        assert set(np.delete(cc, i, axis=0).ravel()) <= {-65, -1, 63}


def test_the_description_and_its_registration():
    assert registry.signal_spec("qzss-l1ca") is QZSS_L1CA
    assert QZSS_L1CA.prns == tuple(range(193, 203)) and QZSS_L1CA.system == "J"
    assert QZSS_L1CA.code_period_s == GPS_L1CA.code_period_s and QZSS_L1CA.code_periods_per_symbol == 20
    with pytest.raises(ConfigError, match="193-202"):
        QZSS_L1CA.code(1)
    with pytest.raises(ConfigError, match="193-202"):
        qzss_l1ca_code(203)


@pytest.mark.parametrize("fs, if_hz, cplx", [(4e6, 0.0, True), (4e6, 1.25e6, False)])
def test_a_synthetic_qzss_satellite_is_acquired_at_its_doppler_and_code_phase(fs, if_hz, cplx):
    sats = [
        SatelliteSignal(195, 46.0, 1730.0, 612.4, signal=QZSS_L1CA),
        SatelliteSignal(199, 45.0, -2240.0, 87.8, signal=QZSS_L1CA),
        SatelliteSignal(5, 46.0, 410.0, 300.0),
    ]  # a GPS satellite in the same recording
    acq = registry.create("acquisition", "pcps")
    x = synthesize_samples(
        sats, acq.samples_needed(fs, QZSS_L1CA) / fs, fs, if_hz, np.random.default_rng(5), complex_samples=cplx
    )
    found = {r.prn: r for r in acq.acquire(x, fs, if_hz, signal=QZSS_L1CA) if r.detected}
    assert set(found) == {195, 199}
    for s in sats[:2]:
        r = found[s.prn]
        assert abs(r.doppler_hz - s.doppler_hz) <= 1 / (2 * 1e-3) / 2  # within half a coarse bin
        d = (r.code_phase_chips - s.code_phase_chips) % 1023
        assert min(d, 1023 - d) <= QZSS_L1CA.chip_rate_hz / fs  # the nearest sample
    # The GPS search of the same samples finds the GPS satellite and none of the QZSS codes.
    gps = {r.prn for r in acq.acquire(x, fs, if_hz) if r.detected}
    assert gps == {5}


def test_a_prn_outside_the_signal_is_refused_by_the_acquisition():
    acq = registry.create("acquisition", "pcps")
    with pytest.raises(ConfigError, match="qzss-l1ca PRN must be an integer 193-202"):
        acq.acquire(np.zeros(acq.samples_needed(4e6), complex), 4e6, 0.0, (1,), signal=QZSS_L1CA)


def test_a_written_qzss_recording_is_acquired_through_the_recording_path(tmp_path):
    """The same, through a file: cf32 samples read back by open_recording, searched by
    acquire_recording for the QZSS signal."""
    from gnssframework.receiver.acquisition.report import acquire_recording
    from gnssframework.receiver.frontend import open_recording

    fs = 4e6
    sat = SatelliteSignal(201, 46.0, -930.0, 777.7, signal=QZSS_L1CA)
    acq = registry.create("acquisition", "pcps")
    x = synthesize_samples([sat], acq.samples_needed(fs, QZSS_L1CA) / fs, fs, 0.0, np.random.default_rng(9))
    path = tmp_path / "qzss.cf32"
    path.write_bytes(registry.create("sample_source", "cf32_le").encode(x))
    rec = open_recording(path, format="cf32_le", sample_rate_hz=fs, if_hz=0.0)
    found = [r for r in acquire_recording(rec, acq, signal=QZSS_L1CA) if r.detected]
    assert [r.prn for r in found] == [201]
    d = (found[0].code_phase_chips - sat.code_phase_chips) % 1023
    assert min(d, 1023 - d) <= QZSS_L1CA.chip_rate_hz / fs and abs(found[0].doppler_hz - sat.doppler_hz) <= 250


def test_the_assisted_window_search_finds_a_qzss_satellite_in_its_window():
    from gnssframework.receiver.acquisition.assisted import SearchWindow, window_search

    fs = 4e6
    sat = SatelliteSignal(196, 40.0, 1210.0, 300.0, signal=QZSS_L1CA)
    x = synthesize_samples([sat], 0.08, fs, 0.0, np.random.default_rng(12))
    start = (-sat.code_phase_chips % 1023) / QZSS_L1CA.chip_rate_hz * fs  # first code epoch, samples
    r = window_search(x, fs, 0.0, 196, SearchWindow(start + 3.0, 1150.0, 10.0, 150.0), signal=QZSS_L1CA)
    per_code = QZSS_L1CA.samples_per_code(fs)  # the lag is a code epoch in the 10 ms block: modulo one period
    d = (r.code_phase_samples - start) % per_code
    assert r.detected and min(d, per_code - d) <= 1.0 and abs(r.doppler_hz - sat.doppler_hz) <= 25.0
    with pytest.raises(ConfigError, match="193-202"):
        window_search(x, fs, 0.0, 5, SearchWindow(start, 1150.0, 10.0, 150.0), signal=QZSS_L1CA)
