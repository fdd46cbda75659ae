"""A Galileo receiver's NeQuick, GST-UTC and GGTO: from E1-B symbols through the channel
(`inav_stream`) and the observables to the RINEX navigation header (`rinex_nav`).

Truth: the broadcast values of a real sbf2rin header (``galileo_inav_20feb2022_05h.rnx``):
pages carrying them (`inav.encode_inav`, word types 5, 6 and 10) must come out of the
receiver's path unchanged, and the header lines the writer makes of them must be sbf2rin's
lines (but for ``D`` exponents), read back to the same values by the project's reader
(`rinex_nav_header`) and by georinex.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from gnssframework.navigation import inav
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.navigation.inav_params import Ggto, GstUtc, InavIonoTime
from gnssframework.navigation.rinex_nav_header import read_nav_file_info
from gnssframework.receiver.channels import ChannelRecord
from gnssframework.receiver.channels.records import RECORD_FIELDS
from gnssframework.receiver.navigation.inav_stream import channel_inav, inav_channel_timing
from gnssframework.receiver.navigation.observables import observables
from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11

NAV = Path(__file__).parents[1] / "data" / "galileo_inav_20feb2022_05h.rnx"
WN_GST = 2198 - 1024
# The header's values in the ICD's LSBs (test_inav_params checks they are whole LSBs).
TRUTH = InavIonoTime(
    (325 * 2.0**-2, -63 * 2.0**-8, 123 * 2.0**-15),
    GstUtc(-1 * 2.0**-30, 1 * 2.0**-50, 18, 0.0, 2198 % 256, 1929 % 256, 7, 18),
    Ggto(203 * 2.0**-35, 8 * 2.0**-51, 86400.0, 2198 % 64),
)


def _record(prn: int, time_s, prompt_i) -> ChannelRecord:
    fixed = dict(cn0_dbhz=45.0, pli=1.0, doppler_hz=0.0, code_phase_chips=0.1, carrier_phase_cycles=0.0)
    fixed.update(lock=1, stage=1, prompt_q=0.0, coherent_ms=1)
    rows = [tuple({**fixed, "time_s": t, "prompt_i": p}[f] for f in RECORD_FIELDS) for t, p in zip(time_s, prompt_i)]
    return ChannelRecord(prn, rows)


def _sbf2rin_lines() -> list[str]:
    lines = NAV.read_text().splitlines()
    return [ln[:60].rstrip() for ln in lines[2:6]]  # GAL, GAGP, GAUT, LEAP SECONDS


@pytest.fixture(scope="module")
def rec():
    return read_rinex_nav(NAV, systems="E").subset(np.array([0]))


def test_the_channel_and_observables_keep_words_5_6_10(rec):
    # One 30 s sub-frame of pages from GST 18001 s: words 6 (at 18005 s) and 10 (18009 s) in it.
    sym = inav.encode_inav(rec, WN_GST, 18001, 15, iono_time=TRUTH).astype(float)
    t = 1.0 + np.arange(sym.size) * 0.004
    record = _record(11, t, 4.0 * sym)
    timing = channel_inav(record, GALILEO_E1B_BOC11)
    assert timing.iono_time == TRUTH
    ct = inav_channel_timing(record, GALILEO_E1B_BOC11)
    assert ct.inav_iono_time == TRUTH
    assert observables([ct]).galileo == TRUTH
    # A channel without word 10 keeps the others and takes no GGTO from nowhere.
    part = inav.encode_inav(rec, WN_GST, 18001, 4, iono_time=TRUTH).astype(float)
    t4 = 1.0 + np.arange(part.size) * 0.004
    assert channel_inav(_record(12, t4, part), GALILEO_E1B_BOC11).iono_time == InavIonoTime(None, TRUTH.utc, None)


def test_the_header_lines_are_sbf2rins_and_read_back(rec, tmp_path):
    nav = NavRecord(int(str(rec.sv[0])[1:]), rec, 2198, float(rec.toc_s[0]) + 30.0)
    path = write_rinex_nav(tmp_path / "navigation.rnx", [nav], signal=GALILEO_E1B_BOC11, galileo=TRUTH)
    lines = path.read_text().splitlines()
    got = [ln for ln in lines if ln[60:].strip() in ("IONOSPHERIC CORR", "TIME SYSTEM CORR", "LEAP SECONDS")]
    assert all(len(ln) == 80 for ln in got)
    assert [ln[60:].rstrip() for ln in got] == [
        "IONOSPHERIC CORR",
        "TIME SYSTEM CORR",
        "TIME SYSTEM CORR",
        "LEAP SECONDS",
    ]
    # Same bytes as sbf2rin but for the exponent letter; its order is GAL, GAGP, GAUT, ours GAL, GAUT, GAGP.
    want = _sbf2rin_lines()
    mine = [ln[:60].rstrip().replace("D", "E") for ln in got]
    assert sorted(mine) == sorted(want)
    # Read back: the project's reader (GAGP) and georinex (GAL, GAUT, GAGP).
    info = read_nav_file_info(path)
    g = TRUTH.ggto
    assert info.ggto == pytest.approx((g.a0g_s, g.a1g_s_s, 86400.0, 2198), rel=5e-11)
    import georinex

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hdr = georinex.rinexheader(path)
        data = georinex.load(path)
    np.testing.assert_allclose(hdr["IONOSPHERIC CORR"]["GAL"], TRUTH.ai_sfu, rtol=5e-5)
    u = TRUTH.utc
    assert hdr["TIME SYSTEM CORR"]["GAUT"][2:] == [0, 2198]
    np.testing.assert_allclose(hdr["TIME SYSTEM CORR"]["GAUT"][:2], (u.a0_s, u.a1_s_s), rtol=5e-10)
    assert hdr["TIME SYSTEM CORR"]["GAGP"][2:] == [86400, 2198]
    np.testing.assert_allclose(data.attrs["ionospheric_corr_GAL"], TRUTH.ai_sfu, rtol=5e-5)
    assert str(data.sv.values[0]) == str(rec.sv[0])


def test_only_what_arrived_is_written_and_not_in_a_gps_file(rec, tmp_path):
    nav = NavRecord(int(str(rec.sv[0])[1:]), rec, 2198, float(rec.toc_s[0]))
    only_ai = InavIonoTime(TRUTH.ai_sfu, None, None)
    text = write_rinex_nav(tmp_path / "a.rnx", [nav], signal=GALILEO_E1B_BOC11, galileo=only_ai).read_text()
    assert "GAL  " in text and "TIME SYSTEM CORR" not in text and "LEAP SECONDS" not in text
    text = write_rinex_nav(tmp_path / "b.rnx", [nav], signal=GALILEO_E1B_BOC11).read_text()
    assert "IONOSPHERIC CORR" not in text and "TIME SYSTEM CORR" not in text
    # WN0G's 6 bits placed near the records' week: a record 40 weeks on still names 2198 + 64 k nearest.
    later = NavRecord(nav.prn, rec, 2198 + 40, nav.tow_s)
    text = write_rinex_nav(tmp_path / "c.rnx", [later], signal=GALILEO_E1B_BOC11, galileo=TRUTH).read_text()
    gagp = next(ln for ln in text.splitlines() if ln.startswith("GAGP"))
    assert int(gagp[45:50]) == 2198 + 64
