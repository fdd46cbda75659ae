"""``--signal``: the acquire, track and receive commands search and track the registered
signal named (QZSS L1 C/A here) on a recording the generic generator wrote from its
description; ``--prns`` is checked against that signal's PRNs. And the sample receiver's
channel filters are built once per task (one construction per stage configuration,
whatever the number of channels), each channel stepping a copy."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.interfaces import RunContext
from gnssframework.plugin import Plugin
from gnssframework.receiver.channels.factory import FilterFactory, StageFilters, supports
from gnssframework.receiver.engine.closers import NCO_COMMANDS
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples, write_recording
from gnssframework.signal.correlators import Correlators
from gnssframework.signal.qzss_l1ca import QZSS_L1CA

FS = 2.6e6
SATS = [
    SatelliteSignal(195, 45.0, 1730.0, 612.4, first_bit_code_period=4, signal=QZSS_L1CA),
    SatelliteSignal(199, 45.0, -2240.0, 87.8, first_bit_code_period=11, signal=QZSS_L1CA),
]


@pytest.fixture(scope="module")
def qzss_recording(tmp_path_factory):
    x = synthesize_samples(SATS, 0.7, FS, 0.0, np.random.default_rng(36))
    return write_recording(tmp_path_factory.mktemp("qzss") / "qzss.sigmf-data", x, "ci16_le", FS, 0.0, scale=300.0)


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_acquire_with_signal_finds_the_qzss_satellites(qzss_recording, tmp_path):
    out = tmp_path / "acq.csv"
    assert main(["acquire", str(qzss_recording), "--signal", "qzss-l1ca", "--out", str(out)]) == 0
    found = {int(r["prn"]): r for r in _rows(out)}
    assert set(found) == {195, 199}
    for s in SATS:
        r = found[s.prn]
        assert abs(float(r["doppler_hz"]) - s.doppler_hz) <= 250.0  # half a 1 ms search's bin
        d = (float(r["code_phase_chips"]) - s.code_phase_chips) % 1023
        assert min(d, 1023 - d) <= QZSS_L1CA.chip_rate_hz / FS  # the nearest sample
    # The same recording searched for GPS L1 C/A (the default): none of its codes is there.
    assert main(["acquire", str(qzss_recording), "--out", str(tmp_path / "gps.csv")]) == 1


def test_track_with_signal_tracks_the_qzss_satellites_with_one_filter_per_stage(
    qzss_recording, tmp_path, monkeypatch, capsys
):
    """Two channels through pull-in, track and extended: the channel filter plugin is
    constructed once per stage configuration (3: pull-in's, track's, extended's PLL-only),
    not per channel, stage start or layout probe (14 before)."""
    built = []
    init = Plugin.__init__

    def counting(self, **params):
        if self.kind == "channel_filter":
            built.append((self.name, tuple(sorted(params.items()))))
        init(self, **params)

    monkeypatch.setattr(Plugin, "__init__", counting)
    out = tmp_path / "trk"
    assert (
        main(
            [
                "track",
                str(qzss_recording),
                "--signal",
                "qzss-l1ca",
                "--out",
                str(out),
                "--duration",
                "0.6",
                "--no-plots",
            ]
        )
        == 0
    )
    assert len(built) == len(set(built)) == 3, built
    # captured stderr is no terminal: a line per tenth of the recording, the last at 100 %
    assert f"{qzss_recording.name}: 100/100 % (100 %)" in capsys.readouterr().err
    summary = {int(r["prn"]): r for r in _rows(out / "summary.csv")}
    assert set(summary) == {195, 199}
    rows = _rows(out / "tracking.csv")
    for s in SATS:
        assert summary[s.prn]["final_stage"] == "extended"
        mine = [r for r in rows if int(r["prn"]) == s.prn and float(r["time_s"]) > 0.4]
        t = np.array([float(r["time_s"]) for r in mine])
        assert mine and all(int(r["lock"]) for r in mine)
        assert np.all(np.abs(np.array([float(r["doppler_hz"]) for r in mine]) - s.doppler_hz) < 5.0)
        truth = s.code_phase_chips + QZSS_L1CA.code_freq_hz(s.doppler_hz) * t
        err = (truth - np.array([float(r["code_phase_chips"]) for r in mine]) + 511.5) % 1023 - 511.5
        assert np.all(np.abs(err) < 0.1)


@pytest.mark.parametrize("command", ["acquire", "track", "receive"])
def test_a_prn_outside_the_signal_is_a_one_line_error_naming_prns_and_the_signal(
    qzss_recording, tmp_path, capsys, command
):
    assert (
        main(
            [command, str(qzss_recording), "--signal", "qzss-l1ca", "--prns", "195", "5", "--out", str(tmp_path / "x")]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--prns" in err and "qzss-l1ca" in err and "193-202" in err, err
    assert main([command, str(qzss_recording), "--prns", "195", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert "--prns" in err and "GPS C/A PRNs are 1-32" in err, err


def test_an_unknown_signal_is_refused_with_the_registered_ones(qzss_recording, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["acquire", str(qzss_recording), "--signal", "gps-l5", "--out", str(tmp_path / "x.csv")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--signal" in err and "qzss-l1ca" in err and "gps-l1ca" in err


CHANNEL_FILTERS = [("scalar", {}), ("kf-carrier-loop", {}), ("iq-filter", {}), ("discriminator", {})]


@pytest.mark.parametrize("name, params", CHANNEL_FILTERS)
def test_a_factory_copy_steps_like_a_freshly_built_filter(name, params):
    """The copy a channel gets and a filter built by the registry, reset and stepped alike:
    the same outputs, bit for bit, and no state shared with the prototype or each other."""
    factory = FilterFactory("channel_filter", name, params)
    a, b, fresh = factory.new(), factory.new(), registry.create("channel_filter", name, **params)
    assert a is not b and a is not factory.prototype
    ctx = RunContext(
        coherent_time_s=1e-3, early_late_spacing_chips=1.0, epoch_interval_s=1e-3, cn0_dbhz=42.0, doppler_hz=300.0
    )
    for f in (a, b, fresh):
        f.reset((2,), ctx)
    rng = np.random.default_rng(3)
    for _ in range(5):
        taps = rng.normal(size=(3, 2)) + 1j * rng.normal(size=(3, 2)) + np.array([[4.0], [9.0], [4.5]])
        inputs = {"correlators": Correlators.trusted(*taps)}
        if not supports(type(fresh), *NCO_COMMANDS):  # an error-output filter: the closure's moves too
            inputs.update(nco_shift_chips=np.zeros(2), nco_shift_hz=np.zeros(2))
        out_a, out_b, out_f = (f.checked_step(dict(inputs)) for f in (a, b, fresh))
        for key, value in out_f.items():
            np.testing.assert_array_equal(np.asarray(out_a[key]), np.asarray(value), err_msg=key)
            np.testing.assert_array_equal(np.asarray(out_b[key]), np.asarray(value), err_msg=key)


def test_stage_filters_build_each_configuration_once_and_take_a_candidates_plugin():
    built = []
    init = Plugin.__init__

    def counting(self, **params):
        built.append(self.name)
        init(self, **params)

    candidate = registry.create("channel_filter", "discriminator")
    Plugin.__init__ = counting
    try:
        same = StageFilters(tracking_config(channel_filter="scalar", pull_in_params={}))  # pull-in = track
        took = StageFilters(tracking_config(channel_filter="discriminator"), candidate)
    finally:
        Plugin.__init__ = init
    assert same.pull_in is same.track and same.extended is not same.track
    assert took.track.prototype is candidate and took.extended is took.track  # no FLL to switch off
    assert built == ["scalar", "scalar", "scalar"], built  # scalar twice (track, PLL-only), pull-in's scalar


def test_an_acquisition_written_to_the_old_contract_is_named_in_one_line(
    qzss_recording, tmp_path, capsys, scratch_registry
):
    """A plugin whose acquire() takes (samples, sample_rate_hz, if_hz, prns), as before the
    signal was added: a one-line error naming it and the change, not a TypeError."""
    import types

    import gnssframework as gf
    from gnssframework.errors import ConfigError
    from gnssframework.receiver.acquisition.report import acquire_recording
    from gnssframework.receiver.acquisition.search import Acquisition
    from gnssframework.receiver.frontend import open_recording

    pcps = registry.get("acquisition", "pcps")

    class OldStyle(Acquisition):
        name = "old-style"
        description = "an acquisition written before the signal was passed"

        def samples_needed(self, sample_rate_hz):
            return pcps().samples_needed(sample_rate_hz)

        def acquire(self, samples, sample_rate_hz, if_hz, prns=None):
            return pcps().acquire(samples, sample_rate_hz, if_hz, prns)

    module = types.SimpleNamespace(register_acquisition=gf.hookimpl(lambda register: register(OldStyle)))
    registry.register_module(module, name="test-old-acquisition", distribution="test")
    with pytest.raises(ConfigError, match=r"'old-style' is written to the old contract: its samples_needed\(\)"):
        acquire_recording(open_recording(qzss_recording), registry.create("acquisition", "old-style"))
    assert main(["acquire", str(qzss_recording), "--acquisition", "old-style", "--out", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--acquisition" in err and "'old-style'" in err and "signal" in err, err

    class HalfOld(OldStyle):  # samples_needed updated, acquire not yet
        name = "half-old"

        def samples_needed(self, sample_rate_hz, signal=None):
            return pcps().samples_needed(sample_rate_hz)

    with pytest.raises(
        ConfigError,
        match=r"'half-old' .*its acquire\(\) does not take \(samples, sample_rate_hz, "
        r"if_hz, prns, signal\)",
    ):
        acquire_recording(open_recording(qzss_recording), HalfOld())


def test_the_trackers_full_search_is_the_signals(qzss_recording):
    """Re-acquisition (`SampleTracker.search`) searches the tracker's signal: a lost QZSS
    channel is found again at its Doppler (the GPS search refused PRN 195 before)."""
    from gnssframework.receiver.channels import SampleTracker
    from gnssframework.receiver.channels.records import ChannelRecord
    from gnssframework.receiver.frontend import open_recording

    rec = open_recording(qzss_recording)
    t = SampleTracker(rec, tracking_config(), registry.create("acquisition", "pcps"), signal=QZSS_L1CA)
    t.channels, t.records = {}, {195: ChannelRecord(195)}
    t._reset_state()
    t.closer.bind(t)
    t.search((195,), 0, rec.n_samples)
    assert t.active[t.slot(195)] and t.channels[195].stage == "pull-in"
    assert abs(t.doppler[t.slot(195)] - SATS[0].doppler_hz) <= 250.0
    assert t.records[195].events == [(0.0, "re-acquired")]


def test_navigation_records_are_looked_up_by_the_signals_satellite_names():
    """QZSS PRN 193-202 are RINEX J01-J10: the fixes' and the vector hand-over's lookups."""
    from types import SimpleNamespace

    from gnssframework.receiver.navigation.fixes import _ephemeris_for
    from gnssframework.receiver.navigation.vector_handover import _ephemeris

    class Rinex:
        asked: list = []

        def select(self, names, t_s):
            self.asked.append(list(names))
            raise KeyError(names[0])  # no such record: the caller goes on without it

    rinex = Rinex()
    assert _ephemeris_for(np.array([193, 202]), None, rinex, 0.0, 0.0, QZSS_L1CA) == [None, None]
    v = SimpleNamespace(tracker=SimpleNamespace(signal=QZSS_L1CA), rinex=rinex)
    assert _ephemeris(v, 195, SimpleNamespace(ephemeris={}, rx_time_s=np.array([1.0])), 2.0) is None
    assert _ephemeris_for(np.array([7]), None, rinex, 0.0, 0.0) == [None]  # GPS by default
    assert rinex.asked == [["J01"], ["J10"], ["J03"], ["G07"]]
