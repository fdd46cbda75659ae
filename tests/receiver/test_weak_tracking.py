"""Tracking at 30 dB-Hz from a cold start (`channels.weak_signal_tracking`, ``--weak``).

On the project's generator (five satellites of real broadcast records seen from a station,
each carrying its LNAV, at 30 dB-Hz, 2.6 MHz), the weak search finds the five, and the
weak-signal settings lock, synchronise bits by energy, decode the TOW and position the
station, within the code noise the loops' bandwidths give at 30 dB-Hz; the default settings
on the same file and acquisitions never synchronise a bit (their histogram of 1 ms sign
changes does not decide there) and give no position: the test fails without the preset.
"""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.cli import WEAK_SEARCH
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import tracking_config, weak_signal_tracking
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.receive import receive
from lnav_recordings import NAV, STATION, TOW0, _strongest, write_lnav_recording

FS = 2.6e6
DURATION_S = 10.5  # subframe 2 starts 2.6 s in and has arrived 8.6 s in (lnav_recordings)
CN0 = 30.0


@pytest.fixture(scope="module")
def weak_file(tmp_path_factory):
    sats = _strongest(read_rinex_nav(NAV), TOW0, 5)
    path = write_lnav_recording(
        tmp_path_factory.mktemp("weak") / "weak.sigmf-data",
        sats,
        TOW0,
        DURATION_S,
        seed=40,
        cn0_dbhz=CN0,
        sample_rate_hz=FS,
    )
    rec = open_recording(path)
    prns = tuple(sorted(int(s[1:]) for s in sats.sv))
    acq = registry.create("acquisition", "pcps", **WEAK_SEARCH)
    return rec, acq, prns, acquire_recording(rec, acq, prns=prns)


def _bit_syncs(result) -> int:
    return sum(any("bit sync" in text for _, text in ch.events) for ch in result.tracking.channels.values())


@pytest.mark.slow
def test_the_weak_search_finds_the_five_at_30_dbhz(weak_file):
    _, _, prns, found = weak_file
    assert sorted(r.prn for r in found if r.detected) == list(prns)


@pytest.mark.slow
def test_weak_settings_position_the_station_and_the_defaults_do_not(weak_file):
    """Position error RMS under 4 x PDOP x the DLL's thermal code noise at 30 dB-Hz (B_L 0.5
    Hz, 1-chip spacing, 10 ms: sqrt(B d / (2 c) (1 + 2 / (T c (2 - d)))) = 0.017 chip, 5.1 m;
    Kaplan & Hegarty, 3rd ed., sec. 8.7)."""
    rec, acq, prns, found = weak_file
    nav = read_rinex_nav(NAV)
    weak = receive(rec, acq, weak_signal_tracking(), rinex=nav, acquisitions=found, rate_hz=2.0)
    assert _bit_syncs(weak) == 5
    table = weak.positions
    assert table is not None and len(table) >= 3 and np.all(table.columns["n_sats"] == 5)
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    pdop = np.max(np.hypot(table.columns["hdop"], table.columns["vdop"]))
    assert np.sqrt(np.mean(err**2)) < 4 * pdop * 5.1, (np.sqrt(np.mean(err**2)), pdop)
    default = receive(rec, acq, tracking_config(), rinex=nav, acquisitions=found, rate_hz=2.0)
    assert _bit_syncs(default) == 0 and default.positions is None


def test_the_weak_option_sets_the_search_and_the_tracking_under_every_option_given():
    """``--weak`` alone: `WEAK_SEARCH` and `WEAK_SIGNAL_SETTINGS`; an option given with it
    wins (``--noncoherent``, ``--channel-params``), and another channel filter keeps its own
    parameters, not the scalar loop's."""
    from gnssframework.cli import _acquisition_from_args, _tracking_config_from_args, build_parser
    from gnssframework.receiver.channels import WEAK_SIGNAL_SETTINGS

    parse = build_parser().parse_args
    args = parse(["track", "x.bin", "--weak", "--out", "o"])
    acq = _acquisition_from_args(args).params
    assert (acq.coherent_ms, acq.noncoherent, acq.alternate_blocks, acq.code_doppler) == (10, 18, True, True)
    cfg = _tracking_config_from_args(args)
    assert cfg.bit_sync == "energy" and cfg.channel_params == WEAK_SIGNAL_SETTINGS["channel_params"]
    assert cfg.pull_in_params == WEAK_SIGNAL_SETTINGS["pull_in_params"] and cfg.pli_threshold == 0.3
    args = parse(
        ["track", "x.bin", "--weak", "--noncoherent", "30", "--channel-params", '{"pll_bandwidth_hz": 8}', "--out", "o"]
    )
    assert _acquisition_from_args(args).params.noncoherent == 30
    assert _tracking_config_from_args(args).channel_params == {"pll_bandwidth_hz": 8}
    args = parse(["track", "x.bin", "--weak", "--channel-filter", "kf-carrier-loop", "--out", "o"])
    cfg = _tracking_config_from_args(args)
    assert cfg.channel_params == {} and cfg.bit_sync == "energy"
    assert tracking_config().bit_sync == "histogram"  # the default is unchanged
