"""Loss of lock on the project's own generated recording: five satellites of real
broadcast records (`test_receiver_fix`'s generator and station), one of them blanked for a
second and then back. The receiver loses it, re-acquires it and dates its new run from
the old one (`observables`, the bridge across a gap); the observables carry the RINEX
3.04 loss-of-lock bits (5.3): bit 0 on the first epoch after the gap, of that satellite
only, bit 1 (half cycle) while the new run's preamble has not arrived; the RINEX file
carries them (georinex reads them back), and the re-acquired satellite's pseudoranges
agree with the generator's geometry as well as before the gap."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.observables import LLI_HALF_CYCLE, LLI_LOST_LOCK
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.navigation.rinex_obs import write_rinex_obs
from lnav_recordings import C, NAV, TOW0, WEEK, _satellite_time, _strongest, write_lnav_recording

DURATION_S = 15.0
BLANK_S = (9.0, 10.0)  # after the first subframe has arrived (8.6 s in)
RATE_HZ = 5.0


@pytest.fixture(scope="module")
def blanked(tmp_path_factory):
    nav = read_rinex_nav(NAV)
    sats = _strongest(nav, TOW0, 5)
    gone = 2  # index of the blanked satellite
    path = write_lnav_recording(
        tmp_path_factory.mktemp("lli") / "blanked.sigmf-data", sats, TOW0, DURATION_S, 77, blank=(gone, *BLANK_S)
    )
    result = receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        tracking_config(),
        rate_hz=RATE_HZ,
        rinex=nav,
        reference_week=WEEK,
    )
    return result, sats, gone


@pytest.mark.slow
def test_the_blanked_satellite_is_flagged_on_its_first_epoch_after_the_gap_and_no_other(blanked):
    result, sats, gone = blanked
    obs = result.observables
    prn = int(sats.sv[gone][1:])
    j = int(np.flatnonzero(obs.prn == prn)[0])
    valid = np.isfinite(obs.pseudorange_m[:, j])
    events = result.tracking.channels[prn].events
    lost_s = next(t for t, text in events if text.startswith("lost"))
    back_s = next(t for t, text in events if text == "re-acquired")
    assert BLANK_S[0] < lost_s < back_s
    assert not valid[(obs.sample_time_s >= lost_s) & (obs.sample_time_s <= back_s)].any()
    after = np.flatnonzero(valid & (obs.sample_time_s >= back_s))
    assert after.size >= 5, "the satellite was not re-acquired and dated after the gap"
    lost = (obs.lli & LLI_LOST_LOCK) != 0
    assert np.flatnonzero(lost[:, j]).tolist() == [after[0]]
    assert not np.delete(lost, j, axis=1).any()
    # No preamble of the new run arrives in the seconds left: its carrier keeps the half-cycle flag.
    half = (obs.lli & LLI_HALF_CYCLE) != 0
    assert half[after, j].all() and not half[valid & (obs.sample_time_s < BLANK_S[0]), j].any()
    assert not np.delete(half, j, axis=1).any()


@pytest.mark.slow
def test_the_bridged_pseudoranges_agree_with_the_geometry_as_before_the_gap(blanked):
    """Pseudorange minus the generator's range (light time, satellite clock) is the
    receiver clock bias, the same for every satellite: the re-acquired satellite's spread
    about the others' after the gap is code noise, as before it (a wrong bit would be
    6000 km, a wrong code period 300 km)."""
    result, sats, gone = blanked
    obs = result.observables
    order = [int(np.flatnonzero(obs.prn == int(s[1:]))[0]) for s in sats.sv]
    # The generator's t_SV at each epoch's true receive time (TOW0 + sample time).
    t_sv = np.array([_satellite_time(sats, np.array(TOW0 + t)) for t in obs.sample_time_s])
    offset = obs.pseudorange_m[:, order] / C - (TOW0 + obs.sample_time_s[:, None] - t_sv)
    bias = offset * C - np.nanmedian(np.delete(offset, gone, axis=1) * C, axis=1)[:, None]
    g = bias[:, gone]
    before = g[np.isfinite(g) & (obs.sample_time_s < BLANK_S[0])]
    after = g[np.isfinite(g) & (obs.sample_time_s >= BLANK_S[1])]
    assert before.size >= 2 and after.size >= 5
    # Code noise at 45 dB-Hz: about 1.7 m per satellite and epoch (`test_receiver_fix`),
    # so about 2.4 m for the difference with the others' median; 4 of those.
    for side in (before, after):
        assert np.all(np.abs(side) < 4 * np.sqrt(2) * 1.7)


@pytest.mark.slow
def test_the_rinex_file_carries_the_flags(blanked, tmp_path):
    import georinex

    result, sats, gone = blanked
    obs = result.observables
    path = write_rinex_obs(tmp_path / "observations.rnx", obs, WEEK)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        data = georinex.load(path, useindicators=True)
    rows = np.flatnonzero(np.isfinite(obs.pseudorange_m).any(axis=1))
    for j, prn in enumerate(obs.prn):
        got = np.nan_to_num(data["L1Clli"].sel(sv=f"G{int(prn):02d}").values, nan=0.0)
        want = np.where(np.isfinite(obs.pseudorange_m[rows, j]), obs.lli[rows, j], 0)
        assert np.array_equal(got, want)
    assert np.nan_to_num(data["L1Clli"].sel(sv=sats.sv[gone]).values).max() == LLI_LOST_LOCK | LLI_HALF_CYCLE
