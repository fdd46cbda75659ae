"""The deep-integration scenario's C/N0 lock detector (issue 42): its fields, its metrics, its per-run updates."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework.errors import ConfigError
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.experiments.scenarios.deep_integration_lock import lock_series
from gnssframework.experiments.scenarios.deep_integration_runs import weight_out
from gnssframework.receiver.deep.ins_navigator import REJECTED_FIX_VAR
from gnssframework.receiver.deep.loose import pv_fix, select_channels

BASE = {"kind": "deep-integration", "duration_s": 20.0, "channels": 8}


@pytest.mark.parametrize(
    "fields, field, words",
    [
        ({"lock_detector": "narrow-wid"}, "lock_detector", "narrow-wide"),  # the suggestion
        ({"lock_detector": "noise-channel"}, "lock_detector", "prompt only"),
        ({"lock_detector": "narrow-wide", "lock_cn0_threshold_dbhz": 12.0}, "lock_cn0_threshold_dbhz", "noise floor"),
        ({"lock_detector": "m2m4", "lock_cn0_threshold_dbhz": 25.0}, "lock_cn0_threshold_dbhz", "noise floor"),
        ({"lock_detector": "narrow-wide", "lock_window_s": 0.0105}, "lock_window_s", "whole multiple"),
        ({"lock_detector": "narrow-wide", "lock_window_s": 0.01}, "lock_window_s", "at least 20 intervals"),
        ({"lock_readmit": 2}, "lock_readmit", "no effect"),
        ({"lock_restart": False}, "lock_restart", "no effect"),
    ],
)
def test_lock_fields_are_checked_with_their_name(fields, field, words):
    with pytest.raises(ConfigError) as exc:
        get_scenario({**BASE, **fields})
    assert exc.value.field == f"scenario.{field}"
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_the_detector_metrics_come_with_the_detector_only():
    lock = {"false_exclusion_fraction", "missed_exclusion_fraction", "channels_used"}
    assert not lock & set(get_scenario(BASE).metrics)
    sc = get_scenario({**BASE, "lock_detector": "narrow-wide", "lock_cn0_threshold_dbhz": 25.0})
    assert lock <= set(sc.metrics)
    assert get_scenario({**BASE, "lock_detector": "m2m4", "lock_cn0_threshold_dbhz": 40.0}).metrics == sc.metrics


class _Verdicts:
    """A detector's verdicts, one per 0.1 s window."""

    def __init__(self, verdicts):
        self.verdicts = verdicts

    def excluded_at(self, t_s):
        n = int(np.floor(t_s / 0.1 + 1e-9))
        return self.verdicts[n - 1]


def test_lock_series_scores_each_update_against_the_signal_of_its_interval():
    # 2 runs, 4 channels, 3 updates of 10 intervals. Channel 0 of run 0 loses its signal in
    # the second interval group and the detector sees it one update late; channel 3 of run 1 is
    # left out while its signal is there; a partial interval group counts as neither.
    n_upd, batch = 10, (2, 4)
    gain = np.ones((30,) + batch)
    gain[10:, 0, 0] = 0.0
    gain[25:, 1, 1] = 0.0  # the last group: half gone (neither present nor absent)
    verdicts = [np.zeros(batch, bool) for _ in range(3)]
    verdicts[2][0, 0] = True
    verdicts[1][1, 3] = True
    s = lock_series(_Verdicts(verdicts), np.array([0.1, 0.2, 0.3]), gain, n_upd, batch)
    np.testing.assert_array_equal(s["missed_exclusion"], [[0, 0], [0.25, 0], [0, 0]])
    np.testing.assert_array_equal(s["false_exclusion"], [[0, 0], [0, 0.25], [0, 0]])
    np.testing.assert_array_equal(s["channels_in_update"], [[4, 4], [4, 3], [3, 4]])
    none = lock_series(_Verdicts(verdicts), np.array([0.1, 0.2, 0.3]), None, n_upd, batch)
    np.testing.assert_array_equal(none["missed_exclusion"], np.zeros((3, 2)))
    np.testing.assert_array_equal(none["false_exclusion"], [[0, 0], [0, 0.25], [0.25, 0]])


def test_weighting_a_channel_out_of_a_fix_gives_the_fix_without_it():
    # Runs keep different numbers of channels (a lock detector's verdicts): the fix on every
    # channel with the left-out ones' variances raised by 1e12 is the fix on the kept ones
    # (select_channels) to a micrometre; a run with fewer than 4 is refused.
    rng = np.random.default_rng(7)
    runs, ch = 3, 7
    los = rng.normal(size=(ch, 3))
    los[:, 2] = np.abs(los[:, 2]) + 0.3
    sat = 2.6e7 * los / np.linalg.norm(los, axis=-1, keepdims=True)
    vel = rng.normal(scale=3e3, size=(ch, 3))
    r0 = np.zeros((runs, 3))
    rho = np.linalg.norm(sat[None] - r0[:, None], axis=-1) + rng.normal(scale=3.0, size=(runs, ch)) + 50.0
    rate = rng.normal(scale=1e3, size=(runs, ch))
    var_r, var_v = np.full((runs, ch), 4.0), np.full((runs, ch), 0.01)
    s_pos, s_vel = np.broadcast_to(sat, (runs, ch, 3)), np.broadcast_to(vel, (runs, ch, 3))
    cn0 = np.tile(np.linspace(40, 46, ch), (runs, 1))
    usable = np.ones((runs, ch), bool)
    usable[0, [1, 4]] = False  # 5 kept
    usable[1, :5] = False  # 2 kept: refused
    chans, refused = weight_out(usable, 4, rho, rate, var_r, var_v, s_pos, s_vel, cn0)
    assert refused.tolist() == [False, True, False]
    assert np.all(np.isneginf(chans[6][0, [1, 4]])) and np.isfinite(chans[6][1]).all()  # a refused run keeps its C/N0
    np.testing.assert_array_equal(chans[2][1], 4.0 + REJECTED_FIX_VAR)
    fp, fv, _ = pv_fix(*chans[:4], *chans[4:6], r0, np.zeros((runs, 3)))
    for run in (0, 2):
        sel = select_channels(usable[run : run + 1], rho[run : run + 1], rate[run : run + 1], var_r[run : run + 1],
                              var_v[run : run + 1], s_pos[run : run + 1], s_vel[run : run + 1])  # fmt: skip
        p, v, _ = pv_fix(*sel[:4], *sel[4:6], r0[:1], np.zeros((1, 3)))
        np.testing.assert_allclose(fp[run], p[0], rtol=0, atol=1e-6)
        np.testing.assert_allclose(fv[run], v[0], rtol=0, atol=1e-6)


@pytest.mark.parametrize("coupling", ["loose", "tight"])
def test_a_runs_numbers_do_not_depend_on_its_batch_mates_verdicts(coupling):
    # 2 s of the level flight at 30 dB-Hz with a 28 dB-Hz threshold: the scalar loops' windows
    # read near it, so the test leaves out different channels in different runs. Run 0 alone and
    # run 0 in a batch of 3 (the same streams: as_run_streams of one seed) give the same numbers,
    # to the rounding of batched linear algebra (measured: 2e-16 relative; a run updated by the
    # batch's rule instead of its own, selected channels against weighted-out ones or a
    # propagation against a nil-gain update, moved them by 1e-12 to 5e-10).
    sc = get_scenario(
        {
            **BASE,
            "duration_s": 2.0,
            "settle_s": 0.5,
            "lock_detector": "narrow-wide",
            "lock_cn0_threshold_dbhz": 28.0,
            "loose_rate_window": "trailing",
        }
    )
    case = {"name": "weak", "cn0_dbhz": 30.0}

    def run(runs):
        from gnssframework.registry import create

        plugins = {
            "channel_filter": create("channel_filter", "scalar", pll_bandwidth_hz=20.7, dll_bandwidth_hz=0.21),
            "nav_filter": create("nav_filter", "ins-ekf", coupling=coupling),
        }
        return sc.run_batch(case, plugins, runs, 2222)

    three, one = run(3), run(1)
    used = np.asarray(three.metrics["channels_used"])
    assert np.all(used < 8) and np.ptp(used) > 0  # verdicts that differ from run to run
    for name in ("horizontal_position_error_rmse", "horizontal_velocity_error_rmse", "nees", "channels_used"):
        np.testing.assert_allclose(np.asarray(one.metrics[name])[0], np.asarray(three.metrics[name])[0], rtol=1e-14)
