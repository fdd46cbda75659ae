"""Issue 40: the code-and-frequency lock test, the vector loop's per-channel lock series, and
channel filters closed by their own estimates (`EstimateCloser`) in the threshold scenario."""

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.experiments.metric_components import evaluate
from gnssframework.experiments.scenarios import get_scenario
from gnssframework.experiments.scenarios.tracking_threshold import code_freq_lock_loss
from gnssframework.experiments.scenarios.vector_threshold import LOCK_METRICS, channel_lock_series
from gnssframework.receiver.engine import Channel
from gnssframework.signal.gps_l1ca import GPS_L1CA


def test_code_freq_lock_loss_finds_the_first_bad_block_per_channel():
    K = 100
    freq = np.zeros((K, 2, 2))
    code = np.zeros((K, 2, 2))
    # scored from interval 10 in blocks of 10 (block j: 10 + 10 j .. 19 + 10 j), limit 25 Hz
    freq[35:, 0, 0] = 40.0  # block 2 (30..39): mean |df| = 5 x 40 / 10 = 20 <= 25; block 3: 40 > 25
    freq[20:30, 0, 1] = -30.0  # block 1 entirely at |df| = 30 > 25 (the sign does not matter)
    code[70:, 1, 0] = 0.55  # block 6 (70..79): mean |dtau| 0.55 > d/2 = 0.5
    code[:, 1, 1] = 0.45  # within the DLL's range everywhere: in lock
    lost, end, blocks = code_freq_lock_loss(freq, code, 10, 10, 25.0, 0.5)
    assert blocks == 9
    np.testing.assert_array_equal(lost, [[True, True], [True, False]])
    np.testing.assert_array_equal(end, [[40, 20], [70, 90]])


def test_channel_lock_series_and_the_vector_lock_metrics():
    """Two runs of three channels, T = 10 ms, settle 0.1 s, 0.1 s blocks: run 0 loses channel
    0 in block 1 (interval 29) and channel 2 in block 3 (interval 49); run 1 loses none."""
    T, K = 0.01, 60
    p = get_scenario(
        {"kind": "vector-threshold", "duration_s": K * T, "settle_s": 0.1, "channels": 4, "pcrb": False}
    ).params
    freq = np.zeros((K, 2, 3))
    code = np.zeros((K, 2, 3))
    freq[20:, 0, 0] = 100.0  # block 1 (20..29): out of frequency lock (1/(4T) = 25 Hz)
    code[40:, 0, 2] = 1.0  # block 3 (40..49): out of code lock
    x = channel_lock_series(freq, code, T, p)
    expected = np.zeros((K, 2))
    expected[29:, 0] = 1 / 3
    expected[49:, 0] = 2 / 3
    np.testing.assert_allclose(x, expected)
    time_s = (np.arange(K) + 0.5) * T

    class _Scenario:
        params = p

    m = evaluate(LOCK_METRICS, {"channels_out_of_lock": x}, time_s, _Scenario()).metrics
    np.testing.assert_allclose(m["loss_of_code_freq_lock"], [2 / 3, 0.0])
    np.testing.assert_array_equal(m["loss_of_code_freq_lock_any"], [1.0, 0.0])
    # the first loss ends with block 1, 0.2 s after settling; the other run is censored at 0.5 s
    np.testing.assert_allclose(m["time_to_code_freq_loss_s"], [0.2, 0.5])


def test_steer_by_errors_jumps_the_code_and_moves_the_frequency():
    T = 0.01
    ch = Channel.start((2,), np.array([0.0, 10.0]), np.array([1000.0, -500.0]))
    code_end, carrier_end = ch.run_interval(T)
    ch.steer_by_errors(np.array([0.1, -0.2]), np.array([5.0, -3.0]))
    np.testing.assert_allclose(ch.code_phase_chips, code_end + [0.1, -0.2])
    np.testing.assert_allclose(ch.carrier_phase_rad, carrier_end)  # no phase jump
    np.testing.assert_allclose(ch.carrier_freq_hz, [1005.0, -503.0])
    np.testing.assert_allclose(ch.shift_chips, [0.1, -0.2])
    np.testing.assert_allclose(ch.shift_hz, [5.0, -3.0])
    f_chip, f_l = GPS_L1CA.chip_rate_hz, GPS_L1CA.carrier_freq_hz
    np.testing.assert_allclose(ch.code_rate_chips_s, f_chip * (1 + np.array([1005.0, -503.0]) / f_l))


def test_iq_filter_closed_by_its_estimates_holds_lock_at_40_dbhz():
    """At 40 dB-Hz (T = 10 ms) the CKF closed by its own estimates never loses lock or slips,
    and its carrier phase estimate is better than one interval's prompt phase, whose
    thermal standard deviation is sqrt(1/(2 C/N0 T)) = 0.0707 rad."""
    sc = get_scenario({"kind": "tracking-threshold", "duration_s": 2.0, "settle_s": 0.5})
    ckf = registry.create("channel_filter", "iq-filter", estimator="svd-ckf", adaptive=False, output="filtered")
    sc.check_composition({"channel_filter": ckf}, "candidates[0]")
    m = sc.run_batch({"cn0_dbhz": 40.0}, {"channel_filter": ckf}, 8, 5).metrics
    assert m["loss_of_lock"].sum() == 0 and m["loss_of_code_freq_lock"].sum() == 0
    assert m["half_cycle_slip_rate"].sum() == 0
    assert np.all(m["phase_jitter_rad"] < np.sqrt(1 / (2 * 1e4 * 0.01)))
    assert np.all(m["code_jitter_chips"] < 0.05)


def test_a_filter_that_neither_commands_ncos_nor_estimates_the_phase_is_refused():
    sc = get_scenario({"kind": "tracking-threshold"})
    disc = registry.create("channel_filter", "discriminator")
    with pytest.raises(ConfigError, match="phase_error_rad"):
        sc.check_composition({"channel_filter": disc}, "candidates[0]")
