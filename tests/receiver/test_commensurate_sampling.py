"""A sample rate that is a ratio of small integers with the chip rate is warned about
(`receiver.channels.sampling`): the replica meets the samples at few alignments, and code
errors inside the dead band they leave are not seen (Akos and Pini 2006)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.channels.sampling import CommensurateSamplingWarning, code_alignments
from gnssframework.receiver.channels.tracker import SampleTracker
from gnssframework.receiver.frontend import open_recording
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA


@pytest.mark.parametrize(
    "sample_rate_hz, alignments",
    [
        (2.046e6, 2),  # 2 samples a chip
        (4.092e6, 4),
        (16.368e6, 16),
        (2.5575e6, 5),  # 5/2 samples a chip: the samples fall every 1/5 chip
        (2.6e6, None),  # 2600/1023: dense
        (2.2e6, None),
        (4e6, None),
    ],
)
def test_alignments_of_c_a_chips(sample_rate_hz, alignments):
    assert code_alignments(sample_rate_hz, GPS_L1CA) == alignments


def test_a_boc_replica_counts_its_sub_chips():
    # BOC(1,1): two sub-chips a chip, 2.046 MHz of them: 4.092 MHz is 2 samples a sub-chip.
    assert code_alignments(4.092e6, GALILEO_E1B_BOC11) == 2
    assert code_alignments(4e6, GALILEO_E1B_BOC11) is None


@pytest.mark.parametrize("sample_rate_hz, warned", [(2.046e6, True), (2.6e6, False)])
def test_the_tracker_warns_of_a_commensurate_rate(tmp_path, sample_rate_hz, warned):
    path = tmp_path / "zeros.bin"
    np.zeros(2 * 4096, np.int8).tofile(path)
    rec = open_recording(path, format="ci8", sample_rate_hz=sample_rate_hz, if_hz=0.0)
    acq = registry.create("acquisition", "pcps")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        SampleTracker(rec, tracking_config(), acq)
    found = [w for w in caught if issubclass(w.category, CommensurateSamplingWarning)]
    assert len(found) == int(warned)
    if warned:
        text = str(found[0].message)
        assert "2.046 MHz" in text and "2 phases" in text and "±0.25 chip" in text


def test_the_command_line_prints_it_as_one_warning_line(tmp_path, capsys):
    from gnssframework.cli import main
    from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples

    rng = np.random.default_rng(1)
    x = synthesize_samples([SatelliteSignal(7, 48.0, 1000.0, 100.0, 0.0, 0)], 0.1, 2.046e6, 0.0, rng)
    iq = np.empty(2 * x.size, np.int16)
    iq[0::2], iq[1::2] = np.round(100 * x.real), np.round(100 * x.imag)
    iq.tofile(tmp_path / "rec.bin")
    args = ["track", str(tmp_path / "rec.bin"), "--format", "ci16_le", "--fs", "2.046e6", "--if", "0"]
    assert main([*args, "--out", str(tmp_path / "out"), "--no-plots", "--quiet"]) == 0
    err = capsys.readouterr().err.splitlines()
    warned = [line for line in err if "2.046 MHz" in line]
    assert len(warned) == 1 and warned[0].startswith(
        "warning: sample rate 2.046 MHz meets gps-l1ca's chips at 2 phases"
    )
    assert not any("CommensurateSamplingWarning" in line or "cli.py" in line for line in err)
