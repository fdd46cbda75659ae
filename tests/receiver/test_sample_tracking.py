"""Sample-driven tracking: every channel filter plugin locks on the project's generated
recordings with the code phase and Doppler of the generator's truth; C/N0 estimators,
bit synchronisation, loss of lock and re-acquisition; the real PocketSDR slice; the
``track`` command."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import SampleTracker, tracking_config
from gnssframework.receiver.channels.records import RECORD_FIELDS
from gnssframework.receiver.frontend import SatelliteSignal, open_recording, synthesize_samples, write_recording
from gnssframework.signal.constants import CA_CHIP_RATE_HZ, CA_CODE_LENGTH, L1_FREQ_HZ

DATA = Path(__file__).parents[1] / "data"
FS = 2.6e6
SAT = SatelliteSignal(11, 44.0, -1730.0, 517.2, 1.1, first_bit_code_period=9)


def _recording(tmp_path, sats, duration_s, seed, name="gen"):
    rng = np.random.default_rng(seed)
    x = synthesize_samples(sats, duration_s, FS, 0.0, rng)
    return open_recording(write_recording(tmp_path / f"{name}.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0))


def _track(rec, duration_s=None, **settings):
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(rec, acq) if r.detected]
    return SampleTracker(rec, tracking_config(**settings), acq).run(found, duration_s)


def _code_error_chips(sat, ch):
    """Truth minus replica code phase at each row's first sample, wrapped to +-511.5 chips."""
    t = ch.column("time_s")
    truth = sat.code_phase_chips + CA_CHIP_RATE_HZ * (1 + sat.doppler_hz / L1_FREQ_HZ) * t
    return (truth - ch.column("code_phase_chips") + CA_CODE_LENGTH / 2) % CA_CODE_LENGTH - CA_CODE_LENGTH / 2


@pytest.fixture(scope="module")
def one_sat(tmp_path_factory):
    return _recording(tmp_path_factory.mktemp("one"), [SAT], 1.5, 21)


@pytest.mark.parametrize(
    "name, params, coherent_ms, phase_lock",
    [
        ("scalar", {}, 10, True),
        # Its q and r are per interval, tuned (Xia et al.) for 1 ms: keep 1 ms integrations.
        ("kf-carrier-loop", {}, 1, True),
        ("kf-carrier-loop", {"states": 3, "q": [0.01, 0.1, 1.0]}, 1, True),
        ("iq-filter", {}, 10, False),
        ("iq-filter", {"estimator": "ukf", "adapter": None}, 10, False),
        ("discriminator", {}, 10, False),
    ],
)
def test_every_channel_filter_plugin_tracks_generated_samples(one_sat, name, params, coherent_ms, phase_lock):
    result = _track(one_sat, channel_filter=name, channel_params=params, coherent_ms=coherent_ms)
    ch = result.channels[SAT.prn]
    last = ch.column("time_s") > 1.0  # the last half second
    assert ch.events[0][1].startswith(f"locked: tracking with {name}")
    assert not any("lost" in e for _, e in ch.events)
    assert ch.column("lock")[last].all()
    # Thermal jitter at 44 dB-Hz: a 1-2 Hz DLL keeps the code within a few hundredths of a
    # chip; 0.1 chip is a tenth of the pull-in range and fails for a drifting code loop.
    assert np.all(np.abs(_code_error_chips(SAT, ch)[last]) < 0.1)
    # PLLs hold the frequency to a few Hz; the FLL closures to the FLL's jitter.
    assert np.all(np.abs(ch.column("doppler_hz")[last] - SAT.doppler_hz) < (5.0 if phase_lock else 15.0))
    if phase_lock:
        assert np.median(ch.column("pli")[last]) > 0.8


# snv: a cn0_estimator plugin, on the whole window (docs/receiver/cn0-estimators.md).
@pytest.mark.slow
@pytest.mark.parametrize("estimator", ["nwpr", "moments", "snv"])
def test_cn0_estimates_are_within_1_db_of_the_generated_cn0(tmp_path, estimator):
    sats = [
        SatelliteSignal(5, 46.0, 850.0, 12.5, first_bit_code_period=3),
        SatelliteSignal(23, 38.0, -2150.0, 730.0, first_bit_code_period=15),
    ]
    result = _track(_recording(tmp_path, sats, 2.0, 22), cn0_estimator=estimator)
    for sat in sats:
        ch = result.channels[sat.prn]
        late = ch.column("time_s") > 1.0
        assert abs(np.median(ch.column("cn0_dbhz")[late]) - sat.cn0_dbhz) < 1.0


def test_bit_synchronisation_finds_the_generated_bit_edge_and_extends_the_integration(one_sat):
    ch = _track(one_sat, coherent_ms=20, channel_params={"pll_bandwidth_hz": 8.0}).channels[SAT.prn]
    # The channel's millisecond 1 is the code period that starts at the first code epoch,
    # which the generator numbers 0: its bit starting at period 9 starts at our ms 10.
    sync = [e for _, e in ch.events if e.startswith("bit sync")]
    assert sync == [f"bit sync (edge at ms {(SAT.first_bit_code_period + 1) % 20} mod 20)"]
    extended = ch.column("coherent_ms") == 20
    assert extended.any() and ch.column("lock")[extended][-10:].all()
    # Extended integrations start on bit edges: a whole number of bits from the first edge.
    rate = CA_CHIP_RATE_HZ * (1 + SAT.doppler_hz / L1_FREQ_HZ)
    bits = (ch.column("time_s")[extended] - SAT.first_bit_edge_s()) / (20 * CA_CODE_LENGTH / rate)
    assert np.all(np.abs(bits - np.round(bits)) < 1e-3)


@pytest.mark.slow
def test_a_signal_that_fades_is_lost_and_re_acquired(tmp_path):
    rng = np.random.default_rng(23)
    sat = SatelliteSignal(19, 45.0, 400.0, 100.0)
    x = synthesize_samples([sat], 2.4, FS, 0.0, rng)
    gap = slice(int(0.8 * FS), int(1.4 * FS))
    x[gap] = rng.standard_normal(gap.stop - gap.start) + 1j * rng.standard_normal(gap.stop - gap.start)
    rec = open_recording(write_recording(tmp_path / "fade.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0))
    ch = _track(rec, reacquire_every_ms=200).channels[sat.prn]
    times = {text.split(":")[0]: t for t, text in reversed(ch.events)}  # first time of each kind
    # Re-acquisition searches the samples that start at its attempt: none before the gap ends.
    assert 0.8 < times["lost"] < 1.4 and times["re-acquired"] >= 1.4 - 1 / FS
    assert ch.events[-1][1].startswith("locked") and ch.column("lock")[-20:].all()


def test_the_real_4mhz_slice_locks_its_strong_satellites_with_the_inverted_q_branch():
    rec = open_recording(
        DATA / "pocketsdr_L1_4MHz_IQ_100ms.bin", format="ci8", sample_rate_hz=4e6, if_hz=0.0, q_sign=-1
    )
    result = _track(rec)
    strong = [p for p, ch in result.channels.items() if ch.column("lock")[-10:].all()]
    # The acquisition test finds 5 satellites far above the threshold in this slice.
    assert len(strong) >= 5
    for p in strong:
        assert result.channels[p].column("cn0_dbhz")[-1] > 38


def test_tracking_refuses_a_filter_that_cannot_close_a_loop_and_bad_settings(one_sat):
    acq = registry.create("acquisition", "pcps")
    with pytest.raises(ConfigError, match="cannot track on samples"):
        SampleTracker(one_sat, tracking_config(channel_filter="hatch"), acq)
    with pytest.raises(ConfigError, match="tracking.coherent_ms"):
        tracking_config(coherent_ms=3)


def test_track_command_writes_the_csv_summary_and_plots(one_sat, tmp_path, capsys):
    from gnssframework.cli import main

    out = tmp_path / "trk"
    assert main(["track", str(one_sat.path), "--out", str(out), "--duration", "0.3"]) == 0
    header = (out / "tracking.csv").read_text().splitlines()[0].split(",")
    assert header[:8] == ["time_s", "prn", "cn0_dbhz", "doppler_hz", "code_phase_chips", "lock", "prompt_i", "prompt_q"]
    assert (out / "summary.csv").read_text().splitlines()[1].startswith(f"{SAT.prn},")
    assert (out / "plots" / "cn0_lock_doppler.png").stat().st_size > 0
    assert "locked" in (out / "events.txt").read_text()
    assert main(["track", str(one_sat.path), "--out", str(out), "--channel-params", "{bad"]) == 2
    assert main(["track", str(one_sat.path), "--out", str(out), "--early-late-spacing", "3"]) == 2
    assert "tracking.early_late_spacing_chips" in capsys.readouterr().err


def test_real_if_samples_track_like_complex_ones(tmp_path):
    """Real samples at an IF (the 12 MHz PocketSDR front end's kind): the same channel,
    the carrier NCO at IF + Doppler."""
    fs, if_hz = 4e6, 1.25e6
    sat = SatelliteSignal(14, 45.0, 2210.0, 333.3, first_bit_code_period=4)
    x = synthesize_samples([sat], 1.2, fs, if_hz, np.random.default_rng(24), complex_samples=False)
    rec = open_recording(write_recording(tmp_path / "real.sigmf-data", x, "ri8", fs, if_hz, scale=20.0))
    assert rec.info.if_hz == if_hz and not rec.is_complex
    ch = _track(rec).channels[sat.prn]
    last = ch.column("time_s") > 0.8
    assert ch.column("lock")[last].all()
    assert np.all(np.abs(_code_error_chips(sat, ch)[last]) < 0.1)
    assert np.all(np.abs(ch.column("doppler_hz")[last] - sat.doppler_hz) < 5.0)
    assert abs(np.median(ch.column("cn0_dbhz")[last]) - sat.cn0_dbhz) < 1.0


@pytest.mark.slow
def test_the_real_12mhz_if_slice_gives_strong_satellites_15_ms_apart():
    """Real samples at a 3 MHz IF: the strong detections of the first 10 ms (statistic over
    3 times the threshold) are detected again 15 ms later at the same Doppler (no truth comes
    with the recording)."""
    fs = 12e6
    rec = open_recording(DATA / "pocketsdr_L1_12MHz_I_30ms.bin", format="ri8", sample_rate_hz=fs, if_hz=3e6)
    acq = registry.create("acquisition", "pcps", noncoherent=10)
    n = acq.samples_needed(fs)
    first, later = (
        {r.prn: r for r in acq.acquire(rec.read(start, n), fs, 3e6) if r.detected} for start in (0, int(0.015 * fs))
    )
    strong = {p: r for p, r in first.items() if r.test_statistic > 3 * r.threshold}
    assert len(strong) >= 6 and set(strong) <= set(later)
    for prn, r in strong.items():
        assert abs(later[prn].doppler_hz - r.doppler_hz) <= 250.0


def test_the_numpy_reference_path_tracks_like_the_compiled_one(one_sat):
    """The whole tracker on the NumPy reference correlator: the same stages and, within
    the carrier table's effect on the loops, the same code phases and Doppler."""
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(one_sat, acq) if r.detected]
    runs = {
        b: SampleTracker(one_sat, tracking_config(), acq, backend=b).run(found, 0.3).channels[SAT.prn]
        for b in ("numba", "numpy")
    }
    fast, ref = runs["numba"], runs["numpy"]
    assert [e for _, e in fast.events] == [e for _, e in ref.events]
    np.testing.assert_array_equal(fast.column("stage"), ref.column("stage"))
    # Same code epochs to a sample; the loops' states differ by the table's rounding only.
    assert np.max(np.abs(fast.column("time_s") - ref.column("time_s"))) <= 1 / FS
    assert np.max(np.abs(fast.column("doppler_hz") - ref.column("doppler_hz"))) < 0.5


def test_track_command_refuses_a_recording_shorter_than_the_acquisition(tmp_path, capsys):
    from gnssframework.cli import main

    path = tmp_path / "short.bin"
    path.write_bytes(bytes(2 * 4000))  # 1 ms of ci8 at 4 MHz; the search needs 8 ms
    code = main(["track", str(path), "--format", "ci8", "--fs", "4e6", "--out", str(tmp_path / "t")])
    err = capsys.readouterr().err
    assert code == 2 and "acquisition needs 32000 samples" in err and err.count("\n") == 1


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, params, coherent_ms",
    [
        ("scalar", {}, 10),
        ("kf-carrier-loop", {}, 1),
        ("iq-filter", {}, 10),
        ("discriminator", {}, 10),
    ],
)
def test_batched_filter_stepping_gives_the_per_channel_stepping_outputs(tmp_path, name, params, coherent_ms):
    # Channels in one stage step as one batch of their filter; stepping each channel's filter
    # alone (batch=False, the way the tracker stepped them before) must give the same records.
    sats = [
        SatelliteSignal(3, 45.0, 1200.0, 100.5, first_bit_code_period=2),
        SatelliteSignal(8, 43.0, -2500.0, 800.25, first_bit_code_period=11),
        SatelliteSignal(17, 46.0, 300.0, 33.0, first_bit_code_period=17),
        SatelliteSignal(26, 41.0, -400.0, 640.0, first_bit_code_period=5),
    ]
    rec = _recording(tmp_path, sats, 1.2, 23)
    acq = registry.create("acquisition", "pcps")
    found = [r for r in acquire_recording(rec, acq) if r.detected]
    assert {r.prn for r in found} >= {s.prn for s in sats}
    config = tracking_config(channel_filter=name, channel_params=params, coherent_ms=coherent_ms)
    batched = SampleTracker(rec, config, acq)
    ours = batched.run(found)
    if name == "scalar":
        assert batched.largest_batch == len(sats)  # it did batch
    alone = SampleTracker(rec, config, acq, batch=False)
    reference = alone.run(found)
    assert not alone.batches and alone.largest_batch == 0
    for prn, ch in reference.channels.items():
        mine = ours.channels[prn]
        assert mine.events == ch.events
        # Each channel runs to its own last whole interval and its sums are scaled by the
        # power of the block-grid block its interval starts in, whichever channels run with
        # it; the batch steps each channel's filter element by element: the same records,
        # to the bit.
        assert len(mine.rows) == len(ch.rows) > 100
        for field in ("time_s", "lock", "stage", "coherent_ms"):
            np.testing.assert_array_equal(mine.column(field), ch.column(field))
        for field in RECORD_FIELDS:
            np.testing.assert_array_equal(mine.column(field), ch.column(field), err_msg=field)


@pytest.mark.parametrize("name", ["scalar", "kf-carrier-loop", "discriminator"])
def test_a_filter_batch_steps_like_its_channels_filters_stepped_alone(name):
    import copy

    from gnssframework.interfaces import RunContext
    from gnssframework.receiver.channels.batch import FilterBatch, batch_layout
    from gnssframework.signal.correlators import Correlators

    rng = np.random.default_rng(5)
    closure = name == "discriminator"

    def make(shape, doppler=0.0):
        f = registry.create("channel_filter", name)
        f.reset(
            shape,
            RunContext(
                coherent_time_s=1e-3,
                early_late_spacing_chips=1.0,
                epoch_interval_s=1e-3,
                cn0_dbhz=42.0,
                doppler_hz=doppler,
            ),
        )
        return f

    def inputs(k):
        e, p, l = (rng.normal(size=(3, k)) + 1j * rng.normal(size=(3, k))) + np.array([[4], [12], [5]])
        out = {"correlators": Correlators.trusted(e, p, l)}
        if closure:
            out.update(nco_shift_chips=rng.normal(size=k) * 0.01, nco_shift_hz=rng.normal(size=k))
        return out

    def step(f, k):
        f.checked_step(inputs(k))

    paths = batch_layout(make, step)
    assert paths
    alone = [make((1,), d) for d in (-1500.0, 200.0, 3100.0)]  # channels 0, 1, 2

    def step_both(batch):
        # Every channel's filter alone and the batch on the same inputs: the same outputs.
        x = inputs(len(alone))
        c = x["correlators"]

        def part(rows):
            out = {"correlators": Correlators.trusted(c.early[rows], c.prompt[rows], c.late[rows])}
            out.update({k: v[rows] for k, v in x.items() if k != "correlators"})
            return out

        singles = [f.checked_step(part([j])) for j, f in enumerate(alone)]
        if batch is None:
            return
        together = batch.filter.checked_step(part(batch.slots))
        for r, j in enumerate(batch.slots):
            for key, v in together.items():
                np.testing.assert_allclose(
                    np.asarray(v)[r], np.asarray(singles[j][key])[0], rtol=1e-12, atol=1e-12, err_msg=key
                )

    step_both(None)
    batch = FilterBatch(copy.deepcopy(alone[0]), 0, paths)
    for k in (1, 2):  # the others join one step later each, as channels do
        step_both(batch)
        assert batch.join(copy.deepcopy(alone[k]), k)
    assert batch.slots == [0, 1, 2]
    for _ in range(20):
        step_both(batch)
    batch.leave(1)
    assert batch.slots == [0, 2]
    for _ in range(5):
        step_both(batch)
