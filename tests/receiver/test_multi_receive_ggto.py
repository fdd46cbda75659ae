"""The two-signal receive with the broadcast GGTO taken as known (`multi_receive.broadcast_time_offsets`,
`fixes.solve_epochs` ``time_offsets_s``).

Truth built here: the GPS and Galileo records of tests/data/VILL00ESP_R_20181700000_06H_MN.rnx
above 5 degrees at a receiver near VILL at 01:30 on 2018-06-19 (two of each), flight times by
the tests' light-time iteration (`light_time.signal_flight`), one receiver clock, and the
Galileo satellites' transmit times in GST = GPST + GGTO, GGTO from the file header's
broadcast polynomial (read by the project's `rinex_nav_header`, checked against the ICD's
formula by hand in test_pvt_multignss). Four satellites: with GGTO known the fix has four
unknowns and must land on the receiver (the solver's 1 mm); estimating a Galileo clock it
has five and no fix. A wrong-signed GGTO must miss by metres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pymap3d
import pytest

from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.inav_params import Ggto, InavIonoTime
from gnssframework.navigation.rinex_nav_header import read_nav_file_info
from gnssframework.receiver.navigation.fixes import solve_epochs
from gnssframework.receiver.navigation.multi_receive import KEY_STEP, SignalSet, broadcast_time_offsets
from gnssframework.receiver.navigation.observables import Observables
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from light_time import C, signal_flight

NAV = Path(__file__).resolve().parents[1] / "data" / "VILL00ESP_R_20181700000_06H_MN.rnx"
RECEIVER = np.array(pymap3d.geodetic2ecef(40.4433, -3.9522, 647.0))
WEEK, T_RX = 2006, 2 * 86400.0 + 1.5 * 3600.0
BIAS_M = 1234.5
# The header's GPGA line: A0G, A1G, t0G, WN0G (full week; 6 bits sent in word type 10).
GGTO = Ggto(2.2322637960e-08, -1.021405183e-14, 259200.0, 2006 % 64)
SIGNALS = SignalSet((GPS_L1CA, GALILEO_E1B_BOC11))


def _observables(ggto_s: float, galileo: InavIonoTime | None) -> tuple[Observables, object]:
    nav = read_rinex_nav(NAV, systems="GE")
    sel = nav.select(np.unique(nav.sv), T_RX)
    sel = sel.subset(np.flatnonzero(sel.health == 0))
    t = T_RX + np.arange(3.0)
    rows_pr, rows_tx = [], []
    up = RECEIVER / np.linalg.norm(RECEIVER)
    _, _, pos = signal_flight(sel, T_RX, RECEIVER)
    el = np.degrees(np.arcsin(((pos - RECEIVER) / np.linalg.norm(pos - RECEIVER, axis=1)[:, None]) @ up))
    sel = sel.subset(np.flatnonzero(el > 5.0))
    letters = sel.sv.astype("U1")
    assert sorted(letters.tolist()) == ["E", "E", "G", "G"]
    keys = np.array([(KEY_STEP if s[0] == "E" else 0) + int(s[1:]) for s in sel.sv])
    for tk in t:
        tau, clock_s, _ = signal_flight(sel, tk, RECEIVER)
        in_gst = np.where(letters == "E", ggto_s, 0.0)
        rows_tx.append(tk - tau + clock_s + in_gst)  # each in its system's time
        # C (rx - tx) written out: the difference of two times of week would lose millimetres
        rows_pr.append(C * (tau - clock_s - in_gst) + BIAS_M)
    pr, tx = np.array(rows_pr), np.array(rows_tx)
    shape = pr.shape
    obs = Observables(
        t + BIAS_M / C,
        t - T_RX,
        keys,
        tx,
        pr,
        np.zeros(shape),
        np.zeros(shape),
        np.full(shape, 45.0),
        {},
        None,
        WEEK % 1024,
        galileo=galileo,
    )
    return obs, nav


def test_the_decoded_ggto_is_the_headers_polynomial_at_the_middle_epoch():
    obs, _ = _observables(0.0, InavIonoTime(None, None, GGTO))
    offsets = broadcast_time_offsets(obs, reference_week=WEEK)
    want = read_nav_file_info(NAV).ggto_s(WEEK, float(obs.rx_time_s[1]))
    assert set(offsets) == {"E"} and offsets["E"] == pytest.approx(want, rel=1e-12, abs=1e-18)
    assert broadcast_time_offsets(obs, reference_week=None) is not None  # the observables' own 10-bit week
    obs_none, _ = _observables(0.0, InavIonoTime((1.0, 0.0, 0.0), None, None))
    assert broadcast_time_offsets(obs_none, reference_week=WEEK) is None  # no word type 10


def test_a_known_ggto_fixes_four_satellites_an_estimated_one_cannot():
    ggto_s = GGTO.offset_s(WEEK, T_RX)
    assert ggto_s == pytest.approx(2.2322637960e-08 - 1.021405183e-14 * (T_RX - 259200.0), rel=1e-12)
    obs, nav = _observables(ggto_s, InavIonoTime(None, None, GGTO))
    common = dict(ionosphere=False, reference_week=WEEK, signal=SIGNALS, elevation_mask_deg=0.0)
    known = solve_epochs(obs, nav, time_offsets_s=broadcast_time_offsets(obs, WEEK), **common)
    assert known.ecef_m.shape == (3, 3)
    assert np.max(np.linalg.norm(known.ecef_m - RECEIVER, axis=1)) < 1e-3
    np.testing.assert_allclose(known.columns["clock_bias_m"], BIAS_M, atol=1e-3)
    estimated = solve_epochs(obs, nav, **common)
    assert estimated.ecef_m.shape[0] == 0  # five unknowns, four satellites
    wrong = solve_epochs(obs, nav, time_offsets_s={"E": -ggto_s}, **common)
    assert np.min(np.linalg.norm(wrong.ecef_m - RECEIVER, axis=1)) > 1.0
