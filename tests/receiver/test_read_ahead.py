"""Read-ahead of the recording (`gnssframework.receiver.channels.prefetch`): the blocks and
their power are those of a plain read whatever is asked, and tracking with it gives the
same records, bit for bit, as tracking that reads every block when it needs it."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import SampleTracker, tracking_config
from gnssframework.receiver.channels.prefetch import BlockReader
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples, write_recording

FS = 2.6e6
SATS = [
    SatelliteSignal(3, 45.0, 1200.0, 100.5, first_bit_code_period=2),
    SatelliteSignal(8, 43.0, -2500.0, 800.25, first_bit_code_period=11),
    SatelliteSignal(17, 46.0, 300.0, 33.0, first_bit_code_period=17),
]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    x = synthesize_samples(SATS, 1.0, FS, 0.0, np.random.default_rng(5))
    path = tmp_path_factory.mktemp("ahead") / "gen.sigmf-data"
    return open_recording(write_recording(path, x, "ci16_le", FS, 0.0, scale=300.0))


def test_blocks_are_those_of_a_plain_read_whatever_is_asked(recording):
    reader = BlockReader(recording, 1000)
    # In sequence (read ahead), out of sequence (read there), a longer block, the end.
    n = recording.n_samples
    for first, count in [(0, 700), (700, 1000), (1700, 1000), (5000, 1000), (6000, 2500), (n - 300, 1000)]:
        block, squares = reader.read(first, count)
        plain = recording.read_components(first, count)
        np.testing.assert_array_equal(block, plain)
        assert block.dtype == plain.dtype
        assert squares == float(np.sum(plain.astype(np.int64) ** 2))  # exact for int16 components
    assert reader.hits == 2  # (700, 1000) and (1700, 1000) came from the read-ahead
    reader.close()
    assert reader.read(n, 10)[0].size == 0


def test_tracking_with_read_ahead_gives_the_same_records(recording):
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(recording, acq) if r.detected]
    assert {r.prn for r in found} >= {s.prn for s in SATS}
    config = tracking_config(coherent_ms=10, block_ms=10)  # many blocks: many hand-overs
    ahead = SampleTracker(recording, config, acq)
    ours = ahead.run(found)
    assert ahead.reader.hits > 50
    reference = SampleTracker(recording, config, acq, read_ahead=False).run(found)
    assert ours.channels.keys() == reference.channels.keys()
    for prn, ch in reference.channels.items():
        assert ours.channels[prn].rows == ch.rows, prn
        assert ours.channels[prn].events == ch.events, prn
