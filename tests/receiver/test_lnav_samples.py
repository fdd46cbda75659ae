"""A generated recording that carries real LNAV (the project's IF generator with
`lnav.lnav_symbols` as its data bits) tracks, decodes its subframe and gives, through
`observables`, the transmit time the generator put on the signal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.navigation import lnav
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.navigation.observables import SPEED_OF_LIGHT_MPS, channel_timing, observables
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import SampleTracker, tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.signal.constants import CA_CHIP_RATE_HZ, L1_FREQ_HZ
from gnssframework.signal.if_samples import generate_if_samples
from noisy_recording import write_noisy_recording

NAV = Path(__file__).parents[1] / "data" / "07590920.05n"
FS = 2.046e6
PRN, CN0, DOPPLER = 20, 45.0, 700.0
# Subframe 2 (start count 5001: 5001 mod 5 + 1) starts 2 s into the recording.
TOW0 = 6.0 * 5001 - 2.0
DURATION_S = 8.5


def _write_lnav_recording(path: Path, record, rng) -> Path:
    """TOW0 is the transmit time of the first sample: the code phase is its millisecond
    fraction and the bits those in force; the file is written in 0.5 s chunks."""
    rate = CA_CHIP_RATE_HZ * (1 + DOPPLER / L1_FREQ_HZ)
    symbols, into = lnav.lnav_symbols(record, 1316, TOW0, int(DURATION_S * 50) + 2)
    chunk = int(0.5 * FS)
    n_total = int(DURATION_S * FS) // chunk * chunk

    def chunks():
        for start in range(0, n_total, chunk):
            t0 = start / FS
            sig = generate_if_samples(
                PRN,
                chunk / FS,
                FS,
                0.0,
                CN0,
                rng,
                doppler_hz=DOPPLER,
                code_phase_chips=(TOW0 * 1e3 % 1.0) * 1023 + rate * t0,
                carrier_phase_rad=0.4 + 2 * np.pi * DOPPLER * t0,
                complex_samples=True,
                data_bits=symbols,
                first_bit_edge_s=-into - t0,
                noise=True,
            )
            yield sig.samples

    return write_noisy_recording(path, chunks(), FS)


@pytest.fixture(scope="module")
def tracked(tmp_path_factory):
    record = read_rinex_nav(NAV)
    record = record.subset(np.flatnonzero(record.sv == f"G{PRN:02d}")[:1])
    path = _write_lnav_recording(
        tmp_path_factory.mktemp("lnav") / "lnav.sigmf-data", record, np.random.default_rng(2025)
    )
    rec = open_recording(path)
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(rec, acq) if r.detected]
    result = SampleTracker(rec, tracking_config(), acq).run(found)
    return record, result


@pytest.mark.slow
def test_the_generated_subframe_decodes_with_its_tow_and_fields(tracked):
    record, result = tracked
    timing = channel_timing(result.channels[PRN])
    assert timing is not None
    (sub,) = timing.message.subframes
    assert sub.subframe_id == 2 and sub.tow_s == TOW0 + 2.0
    # Causal timing dates only the rows after that subframe has arrived (2 s + 6 s in).
    assert timing.time_s[0] == pytest.approx(8.0, abs=0.02)
    assert channel_timing(result.channels[PRN], causal=False).time_s[0] < 2.0
    _, sf2, _ = lnav.ephemeris_to_fields(record, 1316)
    for name in ("crs_m", "m0_sc", "e", "sqrt_a_sqrtm", "toe_s", "iode"):
        assert sub.fields[name] == pytest.approx(sf2[name], abs=lnav.SUBFRAME2[name][1] / 2)


def test_observables_give_the_generated_transmit_time(tracked):
    _, result = tracked
    # Dated from the decoded TOW backwards too (causal=False): the recording holds one subframe.
    obs = observables([channel_timing(result.channels[PRN], causal=False)], rate_hz=10.0)
    ok = np.isfinite(obs.transmit_s[:, 0])
    assert ok.sum() >= 40  # epochs over the decoded span (>= 6 s at 10 Hz)
    rate = CA_CHIP_RATE_HZ * (1 + DOPPLER / L1_FREQ_HZ)
    truth = TOW0 + obs.sample_time_s[ok] * rate / CA_CHIP_RATE_HZ
    err_chips = (obs.transmit_s[ok, 0] - truth) * CA_CHIP_RATE_HZ
    assert np.max(np.abs(err_chips)) < 0.1  # the code tracking bound of the gps-sdr-sim validation
    # The pseudorange is the receiver clock minus that time (about 75 ms with the chosen offset).
    pr = obs.pseudorange_m[ok, 0]
    assert np.allclose(pr, SPEED_OF_LIGHT_MPS * (obs.rx_time_s[ok] - obs.transmit_s[ok, 0]))
    assert 0.05 < pr.mean() / SPEED_OF_LIGHT_MPS < 0.1
    # Doppler and carrier phase: the NCO's Doppler, and the phase advancing by -Doppler.
    assert np.all(np.abs(obs.doppler_hz[ok, 0] - DOPPLER) < 5.0)
    dphi = np.diff(obs.carrier_cycles[ok, 0]) / 0.1
    assert np.all(np.abs(dphi + DOPPLER) < 5.0)
