"""The sample tracker's extension points (`receiver.channels.closers`), its replica NCO
steering (`receiver.channels.nco`) and its signal description (`SignalSpec`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import ReplicaNCOs, SampleTracker, ScalarSampleCloser, tracking_config
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples, write_recording
from gnssframework.signal.codes import ca_code
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.spec import Component

FS = 2.6e6
SAT = SatelliteSignal(11, 44.0, -1730.0, 517.2, 1.1, first_bit_code_period=9)
# IS-GPS-200 values, written out here (not read from the library).
C_M_S, L1_HZ, CHIP_HZ = 299_792_458.0, 1575.42e6, 1.023e6


@pytest.fixture(scope="module")
def tracked(tmp_path_factory):
    rng = np.random.default_rng(21)
    x = synthesize_samples([SAT], 0.6, FS, 0.0, rng)
    path = tmp_path_factory.mktemp("closers") / "one.sigmf-data"
    rec = open_recording(write_recording(path, x, "ci16_le", FS, 0.0, scale=300.0))
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(rec, acq) if r.detected]
    assert [r.prn for r in found] == [SAT.prn]
    return rec, acq, found


class _Counting(ScalarSampleCloser):
    """The scalar closer, counting the tracker's calls."""

    def __init__(self) -> None:
        self.calls: list[str] = []

    def bind(self, tracker):
        self.calls.append("bind")
        super().bind(tracker)

    def added(self, c, acq):
        self.calls.append("added")

    def step(self, *args):
        self.calls.append("step")
        super().step(*args)

    def advance(self, c, t0):
        self.calls.append("advance")
        super().advance(c, t0)

    def after_interval(self, idx):
        self.calls.append("after_interval")

    def finish(self, result):
        self.calls.append("finish")


def test_the_tracker_calls_its_closer_at_every_extension_point(tracked):
    rec, acq, found = tracked
    default = SampleTracker(rec, tracking_config(), acq).run(found, 0.5)
    closer = _Counting()
    result = SampleTracker(rec, tracking_config(), acq, closer=closer).run(found, 0.5)
    ch = result.channels[SAT.prn]
    # The closer is the whole of the channel's closing: the default's records, exactly.
    assert ch.rows == default.channels[SAT.prn].rows and ch.events == default.channels[SAT.prn].events
    calls = closer.calls
    assert calls[0] == "bind" and calls[1] == "added" and calls[-1] == "finish"
    # One filter step, one state-machine advance and one end-of-interval call per recorded interval.
    assert calls.count("step") == calls.count("advance") == calls.count("after_interval") == len(ch.rows) > 100
    assert any("locked" in text for _, text in ch.events)


def test_a_signal_description_sets_the_slots_and_the_bit_length(tracked):
    rec, acq, found = tracked
    # Only PRNs 9-12: PRN 11 in slot 2 instead of slot 10; the same channel, the same numbers.
    few = dataclasses.replace(GPS_L1CA, prns=(9, 10, 11, 12))
    tracker = SampleTracker(rec, tracking_config(), acq, signal=few)
    assert tracker.codes.shape == (4, 1023) and tracker.slot(11) == 2
    np.testing.assert_array_equal(tracker.codes[2], ca_code(11))
    result = tracker.run(found, 0.5)
    assert tracker.votes.shape == (4, 20) and tracker.channels[11].slot == 2
    reference = SampleTracker(rec, tracking_config(), acq).run(found, 0.5)
    assert result.channels[11].rows == reference.channels[11].rows
    # A 10-period symbol: the bit-sync histograms are 10 long.
    short = dataclasses.replace(GPS_L1CA, components=(Component("data", ca_code, symbol_period_s=0.01),))
    tracker = SampleTracker(rec, tracking_config(), acq, signal=short)
    tracker._reset_state()
    assert tracker.votes.shape == (32, 10)


def _ncos(n: int) -> ReplicaNCOs:
    rng = np.random.default_rng(3)
    dop = rng.uniform(-4e3, 4e3, n)
    return ReplicaNCOs(
        GPS_L1CA, rng.uniform(0, 1023, n), CHIP_HZ * (1 + dop / L1_HZ), dop, np.zeros(n), np.zeros(n), np.zeros(n)
    )


def test_a_range_command_moves_the_replica_by_the_range_difference():
    nco = _ncos(4)
    slots = np.array([0, 2, 3])
    before = {k: getattr(nco, k).copy() for k in ("code_phase", "doppler", "code_rate")}
    replica_m = np.array([2.1e7, 2.3e7, 2.5e7])
    range_m = replica_m + np.array([150.0, -40.0, 0.3])
    rate_m_s = np.array([-600.0, 120.0, 710.0])
    t_s = np.array([9.81, 9.812, 9.815])
    nco.steer_range(slots, replica_m, range_m, rate_m_s, t_s)
    chip_m = C_M_S / CHIP_HZ
    # More range is fewer chips generated; the carrier at the rate's Doppler, the code rate carrier-aided.
    moved = (replica_m - range_m) / chip_m
    np.testing.assert_allclose(nco.code_phase[slots] - before["code_phase"][slots], moved, rtol=0, atol=1e-7)
    np.testing.assert_allclose(nco.shift_chips[slots], moved, rtol=0, atol=1e-7)
    doppler = -rate_m_s * L1_HZ / C_M_S
    np.testing.assert_allclose(nco.doppler[slots], doppler, rtol=1e-12)
    np.testing.assert_allclose(nco.shift_hz[slots], doppler - before["doppler"][slots], rtol=1e-9)
    np.testing.assert_allclose(nco.code_rate[slots], CHIP_HZ * (1 + doppler / L1_HZ), rtol=1e-13)
    for k, v in before.items():  # slot 1 untouched
        assert getattr(nco, k)[1] == v[1]


def test_error_feedback_and_the_navigation_filters_code_error_share_the_sign():
    # A code error of +0.2 chip (truth ahead of the replica): the scalar closure advances
    # the replica; the same error is a range error of -0.2 chip for a navigation filter.
    nco = _ncos(2)
    phase0 = nco.code_phase.copy()
    nco.at(np.array([1])).steer_by_errors(np.array([0.5 * 0.2]), np.array([2.0]))
    assert nco.code_phase[1] - phase0[1] == pytest.approx(0.1) and nco.code_phase[0] == phase0[0]
    assert nco.code_rate[1] == pytest.approx(CHIP_HZ * (1 + nco.doppler[1] / L1_HZ), rel=1e-14)
    assert ReplicaNCOs.range_error_chips(0.2) == -0.2
