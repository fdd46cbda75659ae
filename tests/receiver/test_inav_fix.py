"""A Galileo-only position from generated E1-B samples: five satellites of real broadcast
records seen from VILL (`inav_recordings`), each carrying its I/NAV with the geometry's
code phase, Doppler and symbol timing; acquisition, tracking, the I/NAV GST dating every
row (`inav_stream.inav_channel_timing`), observables and fixes (`receive`, with the RINEX
records as ``--ephemeris`` gives them) put the receiver within a few metres of the station
and its clock on the generator's time."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.navigation.vector_tracking import vector_config

from inav_recordings import GPS_WEEK, SIGNAL, STATION, galileo_records, highest, write_inav_recording

TOW0 = 18024.5  # the page of word type 5 (GST 18025 s) starts about 0.43 s in and has arrived 2.43 s in
DURATION_S = 3.0


@pytest.mark.slow
def test_receive_positions_generated_galileo_e1b_samples_at_the_station(tmp_path):
    nav = galileo_records()
    sats = highest(nav, TOW0, 5)
    path = write_inav_recording(tmp_path / "gal.sigmf-data", sats, TOW0, DURATION_S, seed=7)
    result = receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        tracking_config(coherent_ms=1, early_late_spacing_chips=0.2),
        rate_hz=5.0,
        rinex=nav,
        ionosphere=False,
        reference_week=GPS_WEEK,
        signal=SIGNAL,
    )
    table = result.positions
    assert table is not None and len(table) >= 10
    assert np.all(table.columns["n_sats"] == 5)
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    # The GPS receiver's test's bound (4 x (HDOP + VDOP) x 1.7 m, 1.7 m its code noise at
    # 45 dB-Hz, 1 chip, BPSK); the E1 tracking (BOC(1,1), 0.2 chip, 1 Hz DLL: 0.0021 chip
    # = 0.6 m, docs/receiver/galileo-e1.md) is no noisier. Measured: 2.7 m RMS over 14 epochs.
    assert np.sqrt(np.mean(err**2)) < 4 * np.max(table.columns["hdop"] + table.columns["vdop"]) * 1.7
    # The receiver clock: the generator's time (GST = GPS time here) at each epoch's sample.
    assert np.allclose(table.columns["tow_s"], TOW0 + table.sample_time_s, atol=30e-9)
    assert table.columns["gps_week"][0] == GPS_WEEK


def test_receive_refuses_vector_tracking_on_inav_in_one_line():
    with pytest.raises(ConfigError, match="galileo-e1b-boc11: vector tracking"):
        receive(None, None, None, vector=vector_config(), signal=SIGNAL)
    with pytest.raises(ConfigError, match=r"I/NAV positions are the scalar receiver's$") as exc:
        receive(None, None, None, vector=vector_config(), signal=SIGNAL)
    assert len(str(exc.value).splitlines()) == 1


def test_receive_refuses_a_signal_whose_message_it_does_not_decode():
    from gnssframework.signal.beidou_b1c import BEIDOU_B1C

    # B1C carries B-CNAV1, which no receiver message (`decoded.MESSAGES`) dates: refused before
    # any work. (L2C's CNAV dates its channels: tests/receiver/test_l2c_receive.py.)
    with pytest.raises(ConfigError, match=r"^signal: beidou-b1c: LNAV dating and positioning take GPS LNAV"):
        receive(None, None, None, signal=BEIDOU_B1C)
