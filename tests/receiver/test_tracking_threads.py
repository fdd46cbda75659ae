"""Channels correlated on several threads (`backend.set_threads`, `receive --threads`):
the correlators' sums and a tracking run's records are bit-identical to one thread's,
whatever the number, and the kernel pool runs every chunk once with any helper count.

Bitwise by construction: each channel group runs the serial kernel on slices of the same
arrays, so no channel's arithmetic or its order depends on the split; the tests check it
with the split forced on every call (`channel_groups.SPLIT_SAMPLES` 0)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from gnssframework import backend, registry
from gnssframework.errors import ConfigError
from gnssframework.estimation.compiled import pool
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import SampleTracker, channel_groups, correlator, tracking_config
from gnssframework.receiver.channels.correlator import correlate_channels, correlate_numpy, correlate_periods
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples, write_recording
from gnssframework.signal.codes import ca_code

FS = 2.6e6


@pytest.fixture
def always_split(monkeypatch):
    """Every call split into channel groups, and the groups run counted."""
    monkeypatch.setattr(channel_groups, "SPLIT_SAMPLES", 0)
    calls = []
    real = pool.run_chunks

    def counted(n, run_chunk, threads=2):
        calls.append((n, threads))
        real(n, run_chunk, threads)

    monkeypatch.setattr(pool, "run_chunks", counted)
    yield calls
    backend.set_threads(None)


@pytest.mark.parametrize("threads", [2, 3, 5])
def test_the_pool_runs_every_chunk_once_on_up_to_the_threads_asked(threads):
    ran, names = [], set()
    lock = threading.Lock()

    def chunk(i):
        with lock:
            ran.append(i)
            names.add(threading.current_thread().name)

    for _ in range(20):
        pool.run_chunks(7, chunk, threads)
    assert sorted(ran) == sorted(list(range(7)) * 20)
    assert len(names) <= threads


def test_correlators_give_the_same_bits_on_1_2_and_3_threads(always_split):
    rng = np.random.default_rng(5)
    comps = rng.integers(-90, 90, 2 * int(FS * 12e-3)).astype(np.int16)
    n_ch = 7
    codes = np.stack([ca_code(p) for p in range(3, 3 + n_ch)]).astype(np.float32)
    steps = 1.023e6 / FS * (1 + rng.uniform(-3e-6, 3e-6, n_ch))
    rest = (
        rng.uniform(-0.5, 0.5, n_ch),
        steps,
        rng.uniform(0, 1, n_ch),
        rng.uniform(-2e-3, 2e-3, n_ch),
        codes,
        np.array([-0.5, 0.0, 0.5]),
    )
    starts, periods, counts = rng.integers(0, 300, n_ch), rng.integers(1, 11, n_ch), rng.integers(2000, 5000, n_ch)
    one_p = correlate_periods(comps, starts, periods, *rest, iq=True, threads=1)
    one_c = correlate_channels(comps, starts, counts, *rest, iq=True, threads=1)
    assert not always_split  # one thread: no pool
    for threads in (2, 3):
        sums, n = correlate_periods(comps, starts, periods, *rest, iq=True, threads=threads)
        np.testing.assert_array_equal(n, one_p[1])
        np.testing.assert_array_equal(sums, one_p[0])
        np.testing.assert_array_equal(correlate_channels(comps, starts, counts, *rest, iq=True, threads=threads), one_c)
    assert [t for _, t in always_split] == [2, 2, 3, 3] and all(n > 1 for n, _ in always_split)
    # and the split sums are the correlations (the reference, within the kernel's rounding)
    z = comps[0::2] + 1j * comps[1::2].astype(float)
    ref = correlate_numpy(z, starts, counts, *rest)
    bound = np.array([correlator.correlation_error_bound(z, s, c) for s, c in zip(starts, counts)])
    assert np.all(np.abs(one_c - ref) <= bound[:, None])


def test_tracking_records_are_bit_identical_on_1_and_2_threads(tmp_path, always_split):
    sats = [
        SatelliteSignal(3, 45.0, 1200.0, 100.5, first_bit_code_period=2),
        SatelliteSignal(8, 43.0, -2500.0, 800.25, first_bit_code_period=11),
        SatelliteSignal(17, 46.0, 300.0, 33.0, first_bit_code_period=17),
    ]
    x = synthesize_samples(sats, 0.5, FS, 0.0, np.random.default_rng(7))
    rec = open_recording(write_recording(tmp_path / "three.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0))
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(rec, acq) if r.detected]
    assert {r.prn for r in found} >= {s.prn for s in sats}
    runs = []
    for threads in (1, 2):
        backend.set_threads(threads)
        runs.append(SampleTracker(rec, tracking_config(coherent_ms=10), acq).run(found))
    assert always_split and {t for _, t in always_split} == {2}  # the 2-thread run split its calls
    one, two = runs
    assert one.channels.keys() == two.channels.keys()
    for prn, ch in one.channels.items():
        assert len(ch.rows) > 100 and ch.rows == two.channels[prn].rows  # every field, to the bit
        assert ch.events == two.channels[prn].events


def test_a_thread_count_below_one_is_refused():
    for bad in (0, -2, 1.5, True):
        with pytest.raises(ConfigError, match="threads"):
            backend.set_threads(bad)
    backend.set_threads(None)
    assert backend.get_threads() == backend.available_cores() >= 1


@pytest.mark.parametrize("command", ["receive", "track"])
def test_the_threads_option_sets_the_thread_count_and_refuses_zero(tmp_path, capsys, command, monkeypatch):
    from gnssframework import cli

    seen = []
    # the command stops at opening the recording (missing): the thread count is set before
    monkeypatch.setattr(cli, "_open_recording_from_args", lambda args: seen.append(backend.get_threads()) or 1 / 0)
    with pytest.raises(ZeroDivisionError):
        cli.main([command, str(tmp_path / "rec.bin"), "--out", str(tmp_path / "o"), "--threads", "3"])
    assert seen == [3]
    backend.set_threads(None)
    assert cli.main([command, str(tmp_path / "rec.bin"), "--out", str(tmp_path / "o"), "--threads", "0"]) == 2
    err = capsys.readouterr().err
    assert "--threads" in err and "at least 1" in err and err.strip().count("\n") == 0
    assert backend.get_threads() == backend.available_cores()
