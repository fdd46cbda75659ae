"""An assisted start whose start time is wrong (issue 40: "time within 2 s"), on the project's
generator: `test_vector_assisted`'s five satellites at 32 dB-Hz, here at 2.6 MHz (2.046 MHz
meets the chips at two phases only, and its discriminator's dead band hides the code errors
the time check reads).

Before, a start time off by less than the pull-in's coarse-time check could see gave fixes
hundreds of metres off that passed every test, and one off by more was refused. Now the
pull-in's estimate corrects the start time (its sigma from the pull-in code phases' noise,
`vector_handover.pull_in_code_sigma_m`: 0.13 s here, so from about 0.5 s), and the loop
(`vector_time`) corrects what is left from the vector channels' code errors. Truths: the
generator's start time and station."""

from __future__ import annotations

import re

import numpy as np
import pytest

import test_receiver_fix as fix
import test_vector_assisted as assisted
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.navigation import vector_tracking
from gnssframework.receiver.navigation.vector_tracking import assistance, vector_config
from lnav_recordings import WEEK, write_lnav_recording


FS = 2.6e6
CN0_DBHZ = 32.0


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("start_time") / "weak_2m6.sigmf-data"
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    write_lnav_recording(path, sats, fix.TOW0, fix.DURATION_S, 3, cn0_dbhz=CN0_DBHZ, sample_rate_hz=FS)
    return path


def _run(path, start_error_s: float, window_s: float = 2.0):
    return assisted._receive(
        path,
        vector=vector_config(solution_rate_hz=5.0, time_window_s=window_s),
        duration_s=fix.DURATION_S,
        assist=assistance(assisted.approximate_position(), WEEK, fix.TOW0 + start_error_s),
    )


def _corrections(result, where: str) -> list[float]:
    return [
        float(re.search(r"corrected by ([-+.\d]+) s", text).group(1))
        for _, text in result.vector.events
        if "start time corrected" in text and where in text
    ]


def _errors_m(result) -> np.ndarray:
    return np.linalg.norm(result.positions.ecef_m - fix.STATION, axis=1)


def _pull_in_estimates(result) -> list[tuple[float, float]]:
    """(offset, sigma) of each pull-in correction's coarse-time fix."""
    found = (re.search(r"satellites: ([-+.\d]+) ± ([.\d]+) s", text) for _, text in result.vector.events)
    return [(float(m.group(1)), float(m.group(2))) for m in found if m]


@pytest.mark.slow  # end to end (the fast lane leaves these out)
def test_a_start_time_a_fifth_of_a_second_off_is_corrected_in_the_loop(recording):
    """0.2 s off (below the pull-in's four sigmas): without the loop's check every fix is more
    than 120 m off (measured 174-231 m); with it the corrections add up to the error within
    30 ms (measured 22 ms), and the last fixes are within 40 m (30 ms is up to 24 m of a
    satellite's motion; measured 17-26 m)."""
    unchecked = _run(recording, 0.2, window_s=0.0)
    assert np.all(_errors_m(unchecked) > 120.0)
    result = _run(recording, 0.2)
    loop = _corrections(result, "code errors")
    assert len(loop) >= 2 and not _corrections(result, "pull-in")
    assert abs(sum(loop) - (-0.2)) < 0.030, loop
    assert np.all(_errors_m(result)[-5:] < 40.0), _errors_m(result)


@pytest.mark.slow  # end to end (the fast lane leaves these out)
@pytest.mark.parametrize("error_s", [2.0, 1.0])
def test_a_start_time_seconds_off_is_corrected_at_the_pull_in(recording, error_s):
    """2 s off (refused before), and 1 s (in the former gap: below four sigmas of the pull-in's
    check at its former fixed 100 m, and too far off for the loop, whose channels lost the code:
    every fix 1.07 km off): the pull-in's coarse-time fix, its sigma from the pull-in code
    phases (under 0.15 s here: measured 0.131 s), corrects it to the millisecond of its
    estimate, within four sigmas of the error (measured 18 ms off). What is left is the loop's:
    the corrections add up to the error within 30 ms, and the last fixes are within 40 m
    (measured 15 m)."""
    result = _run(recording, error_s)
    (offset, sigma), *more = _pull_in_estimates(result)
    assert not more and sigma < 0.15 and abs(offset - (-error_s)) < 4 * sigma
    total = sum(_corrections(result, ""))
    assert abs(total - (-error_s)) < 0.030, total
    assert result.vector.handover_s is not None
    assert np.all(_errors_m(result)[-5:] < 40.0), _errors_m(result)


@pytest.mark.slow  # end to end (the fast lane leaves these out)
def test_the_right_start_time_is_left_alone(recording):
    """No correction of a right start time: the fixes as good as before (under 10 m at the end)."""
    result = _run(recording, 0.0)
    assert not [text for _, text in result.vector.events if "start time corrected" in text or "not confirmed" in text]
    assert np.all(_errors_m(result)[-10:] < 10.0), _errors_m(result)


@pytest.mark.slow  # end to end (the fast lane leaves these out)
def test_a_start_time_still_off_after_its_correction_is_refused(recording, monkeypatch):
    """The pull-in corrects once; a start time its coarse-time fix finds off after that is
    refused for good (a later try on four satellites could not check it). Made to happen
    here by marking the start time corrected already."""
    bind = vector_tracking.VectorSampleCloser.bind

    def corrected_already(self, tracker):
        bind(self, tracker)
        self.time_corrected = True

    monkeypatch.setattr(vector_tracking.VectorSampleCloser, "bind", corrected_already)
    result = _run(recording, 2.0)
    refused = [text for _, text in result.vector.events if "assisted start refused" in text]
    assert len(refused) == 1 and result.vector.handover_s is None
    offset, sigma = (float(v) for v in re.search(r"off by ([-+.\d]+) s \(± ([.\d]+) s", refused[0]).groups())
    assert abs(offset - (-2.0)) < 4 * sigma and abs(offset) > 4 * sigma


def test_a_correction_across_a_weeks_end_moves_the_week():
    from gnssframework.receiver.navigation.vector_handover import shifted_start

    a = assistance((45.0, 0.0, 0.0), 2200, 604_799.5)
    later = shifted_start(a, 1.25)
    assert (later.week, later.start_tow_s) == (2201, pytest.approx(0.75))
    earlier = shifted_start(assistance((45.0, 0.0, 0.0), 2200, 0.5), -1.982)
    assert (earlier.week, earlier.start_tow_s) == (2199, pytest.approx(604_798.518))
    assert shifted_start(a, -0.5).week == 2200
