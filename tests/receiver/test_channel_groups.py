"""Scalar channels tracked in forked worker processes (`channels.groups`): the records of
any grouping are those of one process, to the bit, with a lost and re-acquired satellite
among them; a failing worker's error reaches the caller."""

from __future__ import annotations

import os

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import SampleTracker, tracking_config
from gnssframework.receiver.channels.groups import can_fork, resolve_workers, split_acquisitions, track_in_groups
from gnssframework.receiver.channels.records import RECORD_FIELDS
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples, write_recording
from gnssframework.receiver.navigation.receive import receive
from gnssframework.signal.if_samples import generate_if_samples

pytestmark = pytest.mark.skipif(not can_fork(), reason="worker processes are forked")

FS = 2.6e6
FADING = SatelliteSignal(19, 45.0, 400.0, 100.0)
SATS = [
    SatelliteSignal(3, 45.0, 1200.0, 100.5, first_bit_code_period=2),
    SatelliteSignal(8, 43.0, -2500.0, 800.25, first_bit_code_period=11),
    SatelliteSignal(17, 46.0, 300.0, 33.0, first_bit_code_period=17),
    FADING,
]
GAP_S = (0.8, 1.4)


@pytest.fixture(scope="module")
def fading(tmp_path_factory):
    """Four satellites for 2.4 s; PRN 19's signal is taken out between 0.8 and 1.4 s."""
    rng = np.random.default_rng(31)
    x = synthesize_samples(SATS, 2.4, FS, 0.0, rng)
    own = generate_if_samples(
        FADING.prn,
        2.4,
        FS,
        0.0,
        FADING.cn0_dbhz,
        np.random.default_rng(0),
        doppler_hz=FADING.doppler_hz,
        code_phase_chips=FADING.code_phase_chips,
        complex_samples=True,
        noise=False,
    ).samples
    gap = slice(int(GAP_S[0] * FS), int(GAP_S[1] * FS))
    x[gap] -= own[gap]
    rec = open_recording(
        write_recording(tmp_path_factory.mktemp("groups") / "fade.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0)
    )
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(rec, acq) if r.detected]
    assert {r.prn for r in found} == {s.prn for s in SATS}
    config = tracking_config(reacquire_every_ms=200, coherent_ms=10)
    one = SampleTracker(rec, config, acq).run(found)
    return rec, acq, config, found, one


def _assert_same_records(ours, reference):
    assert sorted(ours.channels) == sorted(reference.channels)
    for prn, ch in reference.channels.items():
        mine = ours.channels[prn]
        assert mine.events == ch.events, prn
        assert len(mine.rows) == len(ch.rows) > 100
        for field in ("time_s", "lock", "stage", "coherent_ms"):
            np.testing.assert_array_equal(mine.column(field), ch.column(field), err_msg=f"PRN {prn} {field}")
        for field in RECORD_FIELDS:
            np.testing.assert_array_equal(mine.column(field), ch.column(field), err_msg=f"PRN {prn} {field}")


def test_the_fading_satellite_is_lost_and_re_acquired_in_one_process(fading):
    *_, one = fading
    kinds = [text.split(":")[0] for _, text in one.channels[FADING.prn].events]
    assert "lost" in kinds and "re-acquired" in kinds
    lost = next(t for t, text in one.channels[FADING.prn].events if text.startswith("lost"))
    assert GAP_S[0] < lost < GAP_S[1]
    for s in SATS[:3]:  # the others never let go
        assert not any(text.startswith("lost") for _, text in one.channels[s.prn].events)


@pytest.mark.parametrize("workers", [2, 3, 4])
def test_any_grouping_gives_the_one_process_records(fading, workers):
    rec, acq, config, found, one = fading
    seen = []
    grouped = track_in_groups(rec, config, acq, found, workers=workers, progress=seen.append)
    _assert_same_records(grouped, one)
    assert grouped.duration_s == one.duration_s and grouped.channel_filter == one.channel_filter
    assert seen and seen[-1] > 0.95 and all(b >= a for a, b in zip(seen, seen[1:]))  # the slowest group's share


def test_receive_tracks_in_worker_processes_when_asked(fading):
    rec, acq, config, found, one = fading
    result = receive(rec, acq, config, acquisitions=found, workers=2)
    _assert_same_records(result.tracking, one)


def test_a_worker_s_error_reaches_the_caller_with_its_type(fading, monkeypatch):
    rec, acq, config, found, _ = fading

    parent = os.getpid()
    update = SampleTracker._update

    def broken(self, *args, **kwargs):
        if os.getpid() != parent:  # only in a worker: so the run did fork
            raise ConfigError("channel_filter", f"broken in process {os.getpid()}")
        update(self, *args, **kwargs)

    monkeypatch.setattr(SampleTracker, "_update", broken)  # inherited by the forked processes
    with pytest.raises(ConfigError, match="channel_filter: broken in process [0-9]+") as raised:
        track_in_groups(rec, config, acq, found, workers=2)
    (note,) = raised.value.__notes__  # where it was raised, for a bug's traceback
    assert note.startswith("raised in the process of channel group ") and "in broken" in note
    assert SampleTracker(rec, config, acq).run(found[:1], 0.1).channels  # in this process: not broken


def test_groups_deal_the_satellites_by_strength_and_workers_are_checked(fading):
    *_, found, _ = fading
    groups = split_acquisitions(found, 3)
    assert sorted(len(g) for g in groups) == [1, 1, 2]
    assert sorted(r.prn for g in groups for r in g) == sorted(r.prn for r in found)
    strongest = max(found, key=lambda r: r.cn0_dbhz)
    assert groups[0][0] is strongest
    assert len(split_acquisitions(found, 10)) == len(found)
    assert resolve_workers(None, 5) == 1 and resolve_workers(8, 3) == 3 and resolve_workers("auto", 64) >= 1
    for bad in (0, -1, True, 1.5, "many"):
        with pytest.raises(ConfigError, match="^workers: "):
            resolve_workers(bad, 4)


def test_a_lost_channel_is_searched_at_the_next_tick_of_the_clock(fading):
    # Lost just after a tick or just before the next, it is searched at the next one (not a
    # whole period later); after failed pull-ins in a row, at the 2nd, 4th ... tick.
    rec, acq, config, found, _ = fading
    tracker = SampleTracker(rec, config, acq)
    tracker.run(found, 0.05)
    c = tracker.channels[found[0].prn]
    every = tracker.reacquire_every
    assert every == int(config.reacquire_every_ms * 1e-3 * FS)
    for start, stage, failures, ticks in (
        (5 * every + 1, "track", 0, 1),
        (6 * every - 1, "track", 0, 1),
        (5 * every, "track", 0, 1),
        (5 * every + 1, "pull-in", 2, 4),  # its third failed pull-in
    ):
        tracker.start_sample[c.slot] = start
        c.stage, c.failures = stage, failures
        tracker.closer.lose(c, start / FS, "a test")
        assert c.retry_at == (5 + ticks) * every, (start, stage, failures)
