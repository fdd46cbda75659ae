"""The sample tracker correlates a BOC signal with its spreading waveform (code times
sub-carrier), not with the bare code.

Truth: the generator's code phase. A BOC(1,1) signal correlated with its bare code has
no peak at zero lag (the sub-carrier's two halves cancel: the cross-correlation is
``1.5 |tau| - ...`` with zeros at 0 and maxima of 0.5 at +-0.25 chip), so a tracker on the
bare code loses 6 dB of prompt power at best and holds the code a quarter chip off, or
not at all; on the spreading waveform the prompt carries the full power and the DLL holds
the code within its thermal jitter.
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import SampleTracker, tracking_config
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples, write_recording
from gnssframework.signal.galileo_e1 import GALILEO_E1B, GALILEO_E1B_BOC11

FS = 4e6
SAT = SatelliteSignal(19, 46.0, 730.0, 1200.3, 0.4, first_bit_code_period=0, signal=GALILEO_E1B_BOC11)


@pytest.fixture(scope="module")
def boc_recording(tmp_path_factory):
    x = synthesize_samples([SAT], 0.6, FS, 0.0, np.random.default_rng(39))
    path = tmp_path_factory.mktemp("boc") / "e1b.sigmf-data"
    return open_recording(write_recording(path, x, "ci16_le", FS, 0.0, scale=300.0))


def _code_error_chips(ch):
    """Truth minus replica code phase at each row's first sample, wrapped to half a code."""
    spec = SAT.signal
    t = ch.column("time_s")
    truth = SAT.code_phase_chips + spec.chip_rate_hz * (1 + SAT.doppler_hz / spec.carrier_freq_hz) * t
    n = spec.code_length_chips
    return (truth - ch.column("code_phase_chips") + n / 2) % n - n / 2


@pytest.mark.slow
def test_sample_tracker_tracks_a_boc11_signal_on_its_spreading_waveform(boc_recording):
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(boc_recording, acq, prns=(SAT.prn,), signal=SAT.signal) if r.detected]
    assert [r.prn for r in found] == [SAT.prn]
    result = SampleTracker(
        boc_recording, tracking_config(early_late_spacing_chips=0.2, coherent_ms=1), acq, signal=SAT.signal
    ).run(found)
    ch = result.channels[SAT.prn]
    last = ch.column("time_s") > 0.3
    assert last.sum() > 20
    assert not any("lost" in e for _, e in ch.events)
    # A 1 Hz DLL at 46 dB-Hz: a few hundredths of a chip; the bare code's lock point is a
    # quarter chip off (or nowhere).
    assert np.all(np.abs(_code_error_chips(ch)[last]) < 0.06)
    # The full power on the prompt, |P|^2 = 2 c T + 2 in the analytic model's normalisation
    # (unit-variance I and Q noise): C/N0 from it within 1.5 dB of the generated one (the
    # bare code would give at most a quarter of the power, 6 dB less).
    power = ch.column("prompt_i")[last] ** 2 + ch.column("prompt_q")[last] ** 2
    T = SAT.signal.code_period_s
    assert abs(10 * np.log10((np.mean(power) - 2) / (2 * T)) - SAT.cn0_dbhz) < 1.5
    # The tracker's own C/N0 (moments: E1-B's symbol is one code period, `lock.nwpr_block`)
    # a number near the generated one (it was NaN).
    cn0 = ch.column("cn0_dbhz")[last]
    assert np.all(np.isfinite(cn0)) and abs(np.median(cn0) - SAT.cn0_dbhz) < 2.0


def test_sample_tracker_refuses_a_cboc_replica_naming_the_boc11_one(boc_recording):
    with pytest.raises(ConfigError, match="boc11"):
        SampleTracker(boc_recording, tracking_config(), registry.create("acquisition", "pcps"), signal=GALILEO_E1B)
