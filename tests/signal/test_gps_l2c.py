"""GPS L2C (IS-GPS-200) and QZSS L2C CM (IS-QZSS-PNT): the codes against the ICD's end
states, the time-multiplexed description (CM and CL chip by chip), a synthetic recording, and
PocketSDR's real L2 recording: the L2C satellites it finds (GPS 18 26 29 31, QZSS 194 195
199; ../shared/data/README.md) are found at 1227.6/1575.42 times their L1 Doppler and at
their L1 C/A code epoch (both codes start together at the satellite, IS-GPS-200 sec. 3.3.3)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition.assisted import SearchWindow, window_search
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C, QZSS_L2C
from gnssframework.signal.gps_l2c_codes import (
    L2CL_INITIAL_STATE,
    L2CL_LENGTH,
    L2CM_INITIAL_STATE,
    L2CM_LENGTH,
    QZSS_L2CM_INITIAL_STATE,
    l2c_register_chips,
)
from gnssframework.signal.qzss_l1ca import QZSS_L1CA

DATA = Path(__file__).parents[1] / "data"

#: IS-GPS-200 Table 3-IIa, "End state" (octal) of L2 CM, PRN 1-32: the register at the
#: period's last chip (10230th) from the table's initial state.
CM_END_STATE = (
    0o552566002,
    0o034445034,
    0o723443711,
    0o511222013,
    0o463055213,
    0o667044524,
    0o652322653,
    0o505703344,
    0o520302775,
    0o244205506,
    0o236174002,
    0o654305531,
    0o435070571,
    0o630431251,
    0o234043417,
    0o535540745,
    0o043056734,
    0o731304103,
    0o412120105,
    0o365636111,
    0o143324657,
    0o110766462,
    0o602405203,
    0o177735650,
    0o630177560,
    0o653467107,
    0o406576630,
    0o221777100,
    0o773266673,
    0o100010710,
    0o431037132,
    0o624127475,
)
#: The same table's L2 CL end states of PRN 1, 18 and 32 (767250th chip).
CL_END_STATE = {1: 0o267724236, 18: 0o713543613, 32: 0o615373171}
#: IS-QZSS-PNT's L2 CM end states of QZSS PRN 193-202 (octal).
QZSS_CM_END_STATE = (
    0o415505547,
    0o705146647,
    0o006215430,
    0o371216176,
    0o645502771,
    0o455175106,
    0o127161032,
    0o470332401,
    0o252026355,
    0o113771472,
)


def test_cm_codes_end_in_the_icds_end_states():
    for prn, end in zip(range(1, 33), CM_END_STATE):
        assert l2c_register_chips(L2CM_INITIAL_STATE[prn], L2CM_LENGTH)[1] == end, f"PRN {prn}"
    for prn, end in zip(range(193, 203), QZSS_CM_END_STATE):
        assert l2c_register_chips(QZSS_L2CM_INITIAL_STATE[prn], L2CM_LENGTH)[1] == end, f"PRN {prn}"


def test_cl_codes_end_in_the_icds_end_states():
    for prn, end in CL_END_STATE.items():
        assert l2c_register_chips(L2CL_INITIAL_STATE[prn], L2CL_LENGTH)[1] == end, f"PRN {prn}"


def test_the_description_alternates_cm_and_cl_chip_by_chip():
    assert registry.signal_spec("gps-l2c") is GPS_L2C and registry.signal_spec("qzss-l2c") is QZSS_L2C
    assert GPS_L2C.code_period_s == pytest.approx(0.02) and GPS_L2C.code_periods_per_symbol == 1
    assert GPS_L2C.component_code_length(1) == 767250 and GPS_L2C.code(1, 1).shape == (767250,)
    assert GPS_L2C.subchips_per_chip == 2 and not GPS_L2C.is_bpsk
    cm, cl = GPS_L2C.spreading_table(7, 0), GPS_L2C.spreading_table(7, 1)
    np.testing.assert_array_equal(cm[0::2], GPS_L2C.code(7))
    np.testing.assert_array_equal(cm[1::2], 0)
    np.testing.assert_array_equal(cl[1::2], GPS_L2C.code(7, 1))
    np.testing.assert_array_equal(cl[0::2], 0)
    # At 1.023 Mchip/s the two slots make one chip stream CM0 CL0 CM1 CL1 ...
    stream = cm[: 2 * 100] + cl[: 2 * 100]
    np.testing.assert_array_equal(np.abs(stream), 1)
    # The CM replica's autocorrelation: a triangle of half a 511.5 kHz chip (the pulse is
    # half a chip long), by direct correlation of the sampled waveform.
    tau = np.array([0.0, 0.1, 0.25, 0.4, 0.5, 0.75])
    chips = np.arange(0, L2CM_LENGTH, 1 / 40)
    w = GPS_L2C.spreading_at(cm, chips)
    direct = [np.dot(w, GPS_L2C.spreading_at(cm, chips + t)) / np.dot(w, w) for t in tau]
    np.testing.assert_allclose(GPS_L2C.autocorrelation(tau), np.maximum(0, 1 - 2 * tau), atol=1e-12)
    np.testing.assert_allclose(direct, np.maximum(0, 1 - 2 * tau), atol=0.01)
    with pytest.raises(ConfigError, match="1-32"):
        GPS_L2C.code(33)
    with pytest.raises(ConfigError, match="193-202"):
        QZSS_L2C.code(1)


def test_a_synthetic_l2c_satellite_is_acquired_at_its_doppler_code_phase_and_cn0():
    fs = 2.5e6
    sat = SatelliteSignal(12, 44.0, 615.0, 4321.3, signal=GPS_L2C)
    acq = registry.create("acquisition", "pcps", noncoherent=1, doppler_max_hz=700.0)
    x = synthesize_samples([sat], acq.samples_needed(fs, GPS_L2C) / fs, fs, 0.0, np.random.default_rng(4))
    found = {r.prn: r for r in acq.acquire(x, fs, 0.0, (3, 12), signal=GPS_L2C) if r.detected}
    assert set(found) == {12}
    r = found[12]
    d = (r.code_phase_chips - sat.code_phase_chips) % L2CM_LENGTH
    assert min(d, L2CM_LENGTH - d) <= GPS_L2C.chip_rate_hz / fs and abs(r.doppler_hz - 615.0) <= 12.5
    # The generator sends the tracked component (CM) at 44 dB-Hz in its slot: the search's
    # C/N0 is CM's (its replica's duty, 1/2, counted), within the grid's losses.
    assert 41.0 <= r.cn0_dbhz <= 44.5
    # The assisted window search around it counts the duty too.
    w = window_search(
        x,
        fs,
        0.0,
        12,
        SearchWindow(r.code_phase_samples, 615.0, 2.0, 30.0),
        coherent_ms=1,
        noncoherent=1,
        alternate=False,
        signal=GPS_L2C,
    )
    assert w.detected and 41.0 <= w.cn0_dbhz <= 44.5


def _read(name):
    return open_recording(DATA / name, format="ci8", sample_rate_hz=4e6, if_hz=0.0, q_sign=-1).read(0, 400_000)


@pytest.mark.parametrize(
    "l1, l2, prns", [(GPS_L1CA, GPS_L2C, (18, 26, 29, 31)), (QZSS_L1CA, QZSS_L2C, (194, 195, 199))]
)
def test_pocketsdrs_l2c_satellites_are_at_their_l1_code_epoch_and_scaled_doppler(l1, l2, prns):
    """L1 C/A first (100 ms of the L1 file), then L2 CM in a Doppler window around
    1227.6/1575.42 times the L1 Doppler (40 ms of the L2 file, the same capture's second
    channel): detected, at that Doppler within the bins' resolution, and with its 20 ms code
    period starting on a sample where the L1 C/A code starts (modulo 1 ms)."""
    fs = 4e6
    x1, x2 = _read("pocketsdr_L1_4MHz_IQ_100ms.bin"), _read("pocketsdr_L2_4MHz_IQ_40ms.bin")[:160_000]
    ratio = l2.carrier_freq_hz / l1.carrier_freq_hz
    acq = registry.create("acquisition", "pcps", noncoherent=10, xcorr_margin_db=None)
    for a in acq.acquire(x1, fs, 0.0, prns, signal=l1):
        assert a.detected
        # The L1 Doppler to 10 ms coherent (bins of 50 Hz) around the 1 ms search's.
        f1 = window_search(
            x1,
            fs,
            0.0,
            a.prn,
            SearchWindow(a.code_phase_samples, a.doppler_hz, 1.0, 150.0),
            coherent_ms=10,
            noncoherent=8,
            signal=l1,
        ).doppler_hz
        r = window_search(
            x2,
            fs,
            0.0,
            a.prn,
            SearchWindow(0.0, ratio * f1, 40_000.0, 150.0),
            coherent_ms=1,
            noncoherent=2,
            alternate=False,
            signal=l2,
        )
        assert r.detected, a.prn
        assert abs(r.doppler_hz - ratio * f1) <= ratio * 25.0 + 12.5 + 5.0, a.prn  # half of each bin, and 5 Hz
        assert (r.code_phase_samples - a.code_phase_samples) % 4000 in (0, 1, 3999), a.prn


def test_a_satellite_without_l2c_is_not_found_on_l2():
    """GPS PRN 16 (SVN 56, block IIR: no L2C) is strong on L1 and absent from the L2 search."""
    fs = 4e6
    x1, x2 = _read("pocketsdr_L1_4MHz_IQ_100ms.bin"), _read("pocketsdr_L2_4MHz_IQ_40ms.bin")[:160_000]
    a = registry.create("acquisition", "pcps", noncoherent=10).acquire(x1, fs, 0.0, (16,))[0]
    assert a.detected
    r = window_search(
        x2,
        fs,
        0.0,
        16,
        SearchWindow(0.0, a.doppler_hz * 1227.6 / 1575.42, 40_000.0, 300.0),
        coherent_ms=1,
        noncoherent=2,
        alternate=False,
        signal=GPS_L2C,
    )
    assert not r.detected
