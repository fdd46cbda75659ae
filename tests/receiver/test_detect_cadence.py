"""The sample tracker's lock-detector cadence is its signal's symbol (issue 36: no C/A
20 ms of its own)."""

from __future__ import annotations

import pytest

from gnssframework.receiver.channels.detection import detect_periods
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11, GALILEO_E1C_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C


@pytest.mark.parametrize(
    "signal, periods",
    [
        (GPS_L1CA, 20),  # 50 bit/s LNAV over 1 ms codes (IS-GPS-200 3.3.2)
        (GALILEO_E1B_BOC11, 1),  # 250 sym/s I/NAV over 4 ms codes (Galileo OS SIS ICD 2.3)
        (GALILEO_E1C_BOC11, 25),  # pilot: its CS25 overlay, 25 codes of 4 ms
        (GPS_L2C, 1),  # 50 sym/s CNAV over the 20 ms CM code (IS-GPS-200 3.3.3.1)
    ],
)
def test_lock_detectors_run_once_a_symbol_or_overlay_period(signal, periods):
    assert detect_periods(signal) == periods
