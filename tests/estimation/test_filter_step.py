"""The one public filter step (FilterStep), the frozen run context, and the adapter's hold."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import gnssframework as gf
from conftest import ca_matrices, create, simulate_linear
from gnssframework.estimation import FilterStep
from gnssframework.signal.correlator_model import simulate_correlators


# -- FilterStep --------------------------------------------------------------------------


def test_filter_step_equals_the_kalman_filter_written_out(rng):
    """Independent truth: the KF recursion of Kalman (1960) in plain numpy."""
    F, H, Q = ca_matrices(q=0.05)
    R = np.array([[2.0]])
    _, zs = simulate_linear(rng, F, H, Q, R, np.zeros(3), 20, (3,))
    fs = FilterStep(create("estimator", "kf"))
    model = gf.LinearModel(F, H, Q, R)
    state = fs.start(gf.Gaussian(np.zeros(3), 5 * np.eye(3)), model)
    x, P = np.zeros((3, 3)), np.broadcast_to(5 * np.eye(3), (3, 3, 3))
    for z in zs:
        state = fs(state, z, model).posterior
        x, P = x @ F.T, F @ P @ F.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T / S
        x = x + (K * (z - x @ H.T)[:, None, :])[..., 0]
        P = P - K @ H @ P
        np.testing.assert_allclose(state.mean, x, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(state.cov, P, rtol=1e-9, atol=1e-12)
    assert fs.step_index == 20 and sum(fs.recoveries.values()) == 0


def test_plugin_failures_name_the_plugin_the_batch_element_and_the_step():
    f = create("channel_filter", "kf-smoother")
    f.reset((3,), gf.RunContext(epoch_interval_s=1.0))
    rho = 2e7 + np.arange(3.0)
    for k in range(3):
        f.step({"pseudorange_m": rho + k, "carrier_m": rho + k})
    r = rho + 3
    r[1] = np.nan
    with pytest.raises(gf.InvalidMeasurementError) as err:
        f.step({"pseudorange_m": r, "carrier_m": rho + 3})
    assert err.value.filter_name == "kf-smoother (kf)" and err.value.batch_indices == [(1,)]
    assert err.value.step == 3  # the epoch: the first epoch only initialises


def test_plugin_refuses_a_bad_initial_state_from_the_harness_by_name():
    nav = create("nav_filter", "ekf-pv")
    x0 = np.zeros((2, 8))
    x0[1, 6] = np.nan
    with pytest.raises(gf.InvalidInitialStateError, match=r"ekf-pv \(ekf\): .*batch element \(1,\): initial mean"):
        nav.reset((2,), gf.RunContext(coherent_time_s=0.01, initial_state=x0, initial_cov=np.eye(8)))


def _costas_atan(corr):
    return create("discriminator", "costas-atan", coherent_time_s=0.001)(corr)


@pytest.mark.other_machines
def test_kf_carrier_loop_through_the_kf_estimator_equals_the_hand_written_recursion():
    """The loop used to hand-roll its KF (update, feedback, then P = F P F^T + Q); it now
    runs the ``kf`` estimator through FilterStep. Fed the same correlators (open loop),
    both give the same NCO commands to rounding."""
    rng = np.random.default_rng(3)
    T, n_ep, batch = 0.001, 300, (5,)
    q, r, std, unit = [1e-4, 1e-2, 1.0], 0.05, [0.5, 5.0, 1.0], np.pi / 180  # angle_unit deg
    loop = create("channel_filter", "kf-carrier-loop", states=3, q=q, r=r, angle_unit="deg", initial_std=std)
    f0 = np.array([100.0, -50.0, 0.0, 10.0, 300.0])
    loop.reset(batch, gf.RunContext(coherent_time_s=T, early_late_spacing_chips=1.0, doppler_hz=f0))
    phase = np.cumsum(rng.normal(0, 0.05, (n_ep,) + batch), axis=0)
    F = np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]])
    H = np.array([1.0, T / 2, T * T / 6])
    P = np.broadcast_to(np.diag(np.square(std)), batch + (3, 3)).copy()
    freq, rate = 2 * np.pi * f0 / unit, np.zeros(batch)
    for k in range(n_ep):
        corr = simulate_correlators(np.zeros(batch), phase[k], np.zeros(batch), 40.0, T, rng)
        out = loop.step({"correlators": corr})
        z = _costas_atan(corr) / unit
        PH = P @ H
        K = PH / (PH @ H + r)[..., None]
        dx = K * z[..., None]
        P = P - K[..., :, None] * PH[..., None, :]
        step = dx[..., 0] + T * dx[..., 1] + 0.5 * T * T * dx[..., 2]
        rate = rate + dx[..., 2]
        freq = freq + dx[..., 1] + T * dx[..., 2] + T * rate
        P = F @ P @ F.T + np.diag(q)
        np.testing.assert_allclose(out["carrier_phase_step_rad"], step * unit, rtol=1e-9, atol=1e-13)
        np.testing.assert_allclose(out["carrier_freq_hz"], freq * unit / (2 * np.pi), rtol=1e-12)


# -- the adapter's hold on skipped updates ------------------------------------------------


@pytest.mark.parametrize("adapter, which", [("innovation", "R"), ("ml-q", "Q")])
def test_adapter_holds_its_estimate_on_elements_whose_update_was_skipped(rng, adapter, which):
    """A skipped update carries no information: where element 1 misses its measurements,
    the adapted R (or Q) in force must not move, while the other elements keep adapting.
    Removing the hold in AdapterRun.step lets a skipped step's zero innovation pull the
    estimate down and fails this test (checked by removing it)."""
    F, H, Q = ca_matrices(q=0.01)
    _, zs = simulate_linear(rng, F, H, 4 * Q, np.array([[4.0]]), np.zeros(3), 60, (3,))
    zs[30:45, 1] = np.nan
    res = gf.filter_sequence(
        create("estimator", "kf"),
        gf.LinearModel(F, H, Q, [[1.0]]),
        zs,
        gf.Gaussian(np.zeros(3), 10 * np.eye(3)),
        adapter=create("noise_adapter", adapter, window=5, warmup=3),
        missing="skip",
    )
    assert res.skipped[30:45, 1].all() and res.recoveries["missing"] == 15
    used = getattr(res, which)[..., 0, 0]
    np.testing.assert_array_equal(used[31:46, 1], used[30, 1])  # in force after each skipped step
    assert np.ptp(used[31:46, 0]) > 0 and np.ptp(used[31:46, 2]) > 0


def test_iq_filter_gets_the_adapter_and_its_recovery_counts_from_the_step():
    f = create("channel_filter", "iq-filter", warmup=2, window=4)
    batch = (4,)
    f.reset(batch, gf.RunContext(coherent_time_s=0.001, early_late_spacing_chips=1.0, cn0_dbhz=45.0))
    rng = np.random.default_rng(0)
    zero = np.zeros(batch)
    for _ in range(8):
        corr = simulate_correlators(zero, 0.2 + zero, zero, 45.0, 0.001, rng)
        f.step({"correlators": corr, "nco_shift_chips": zero, "nco_shift_hz": zero, "data_bit": 1.0})
    assert f.filter_step.step_index == 8 and f.filter_step.recoveries["skip_update"] == 0
    R = f.filter_step.in_force(f.model).R
    assert R.shape == batch + (6, 6) and not np.allclose(R, f.model.R)  # adapted after the warm-up


# -- the run context ----------------------------------------------------------------------


def test_run_context_is_frozen_and_its_arrays_are_read_only_copies():
    cn0 = np.array([45.0, 40.0])
    ctx = gf.RunContext(coherent_time_s=0.01, cn0_dbhz=cn0)
    cn0[0] = 0.0
    assert ctx.cn0_dbhz[0] == 45.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        ctx.coherent_time_s = 0.02
    with pytest.raises(ValueError):
        ctx.cn0_dbhz[0] = 1.0
    with pytest.raises(gf.ConfigError, match="run context.coherent_time_s: must be a finite number > 0"):
        gf.RunContext(coherent_time_s=-1.0)


def test_a_plugin_needing_a_value_the_harness_lacks_fails_at_reset_naming_both():
    ch = create("channel_filter", "discriminator")
    with pytest.raises(
        gf.ConfigError,
        match=r"run context.cn0_dbhz: channel_filter 'discriminator' needs it.*"
        r"provides: coherent_time_s",
    ):
        ch.reset((2,), gf.RunContext(coherent_time_s=0.01))


def test_the_loops_take_the_harness_interval_and_spacing_and_have_no_own():
    # 0.2 removed the loops' own coherent_time_s / early_late_spacing_chips: a config
    # repeating them is refused by name, and the loop runs at the harness's T.
    for name in ("scalar", "kf-carrier-loop"):
        for field in ("coherent_time_s", "early_late_spacing_chips"):
            with pytest.raises(gf.ConfigError, match=field):
                create("channel_filter", name, **{field: 0.01})
    loop = create("channel_filter", "kf-carrier-loop")
    loop.reset((1,), gf.RunContext(coherent_time_s=0.02, early_late_spacing_chips=1.0))
    assert loop.T == 0.02
    with pytest.raises(gf.ConfigError, match=r"run context.early_late_spacing_chips: channel_filter 'scalar' needs it"):
        create("channel_filter", "scalar").reset((1,), gf.RunContext(coherent_time_s=0.01))


def test_the_pre_0_2_reset_signature_is_refused_when_the_class_is_defined():
    with pytest.raises(
        TypeError,
        match=r"Old.reset\(self, batch_shape, \*\*context\) is the signature before 0.2; "
        r"write reset\(self, batch_shape, context\)",
    ):

        class Old(gf.ChannelFilter):
            name = "old-style"
            provides = ("code_error_chips",)

            def reset(self, batch_shape, **context):
                self.seen = context

            def step(self, inputs):
                return {"code_error_chips": np.zeros(1)}


def test_position_ca_takes_its_epoch_interval_from_the_harness():
    f = create("nav_filter", "position-ca", dt_s=1.0)
    with pytest.raises(gf.ConfigError, match=r"position-ca'.epoch_interval_s: is 1.0 but the harness runs with 0.5"):
        f.reset((2,), gf.RunContext(epoch_interval_s=0.5))
    f.reset((2,), gf.RunContext(epoch_interval_s=1.0))
    z = np.array([[1.0, 2.0], [1.5, 2.5], [2.0, 3.0]])
    outs = [f.checked_step({"position_m": zk})["position_m"] for zk in z]
    # Streaming equals filter_sequence from the first fix (the same FilterStep underneath).
    model = f.model(1.0)
    mean0 = np.zeros((2, 3))
    mean0[:, 0] = z[0]
    state = gf.Gaussian(mean0, np.diag(f.params.p0))
    ref = gf.filter_sequence(create("estimator", "kf"), model, z[1:, :, None], state)
    np.testing.assert_allclose(np.stack(outs[1:]), ref.mean[..., 0], rtol=1e-12)
    assert f.filter_step.step_index == 3  # epochs 1 and 2 were filter steps; epoch 0 initialised


def test_restarting_the_adapter_keeps_the_estimate_in_force_and_restarts_its_warmup(rng):
    F, H, Q = ca_matrices(q=0.01)
    _, zs = simulate_linear(rng, F, H, Q, np.array([[4.0]]), np.zeros(3), 30, (2,))
    model = gf.LinearModel(F, H, Q, [[1.0]])
    fs = FilterStep(create("estimator", "kf"), create("noise_adapter", "innovation", window=5, warmup=3))
    state = fs.start(gf.Gaussian(np.zeros(3), 10 * np.eye(3)), model)
    for z in zs[:20]:
        state = fs(state, z, model).posterior
    adapted = fs.in_force(model).R.copy()
    assert not np.allclose(adapted, 1.0)
    fs.restart_adapter(model)
    for z in zs[20:23]:  # inside the new warm-up: the estimate in force does not move
        state = fs(state, z, model).posterior
        np.testing.assert_array_equal(fs.in_force(model).R, adapted)
    state = fs(state, zs[23], model).posterior
    assert not np.array_equal(fs.in_force(model).R, adapted)


# -- every built-in sequential filter with a Gaussian filter runs it through FilterStep ----


def _nan_at(arr, index):
    arr = np.array(arr, dtype=complex if np.iscomplexobj(arr) else float)
    arr[index] = np.nan
    return arr


def _carrier_loop_epochs(name, batch=(3,), bad=1, **params):
    f = create("channel_filter", name, **params)
    f.reset(batch, gf.RunContext(coherent_time_s=0.001, early_late_spacing_chips=1.0, cn0_dbhz=45.0))
    rng, zero = np.random.default_rng(0), np.zeros(batch)
    for k in range(4):
        corr = simulate_correlators(zero, 0.1 + zero, zero, 45.0, 0.001, rng)
        if k == 3:  # the fourth interval: element `bad`'s prompt is lost
            corr = type(corr)(corr.early, _nan_at(corr.prompt, bad), corr.late)
        f.step({"correlators": corr, "nco_shift_chips": zero, "nco_shift_hz": zero, "data_bit": 1.0})


def _position_ca_epochs():
    f = create("nav_filter", "position-ca")
    f.reset((3,), gf.RunContext(epoch_interval_s=1.0))
    for k in range(4):
        z = np.full((3, 2), float(k))
        f.step({"position_m": _nan_at(z, (1, 0)) if k == 3 else z})


def _smoother_epochs():
    f = create("channel_filter", "kf-smoother")
    f.reset((3,), gf.RunContext(epoch_interval_s=1.0))
    rho = 2e7 + np.arange(3.0)
    for k in range(4):
        f.step({"pseudorange_m": _nan_at(rho + k, 1) if k == 3 else rho + k, "carrier_m": rho + k})


def _ekf_pv_epochs():
    from gnssframework.experiments import get_scenario
    from gnssframework.receiver.tracking.vector import run_vector_loop

    base = gf.registry.get("channel_filter", "discriminator")

    class LosesOneChannel(base):
        name = "loses-one-channel"

        def reset(self, batch_shape, context):
            super().reset(batch_shape, context)
            self.k = 0

        def step(self, inputs):
            out = dict(super().step(inputs))
            if self.k == 3:  # the fourth interval: run 1, channel 2 gives NaN
                out["code_error_chips"] = _nan_at(out["code_error_chips"], (1, 2))
            self.k += 1
            return out

    scen = get_scenario({"kind": "vector-tracking", "duration_s": 0.05, "channels": 5, "settle_s": 0.01})
    rng = np.random.default_rng(1)
    truth, x0, P0 = scen.truth(45.0, 3, rng)
    run_vector_loop(LosesOneChannel(), create("nav_filter", "ekf-pv"), truth, x0, P0, rng)


@pytest.mark.parametrize(
    "run, filter_name, element",
    [
        (lambda: _carrier_loop_epochs("kf-carrier-loop"), "kf-carrier-loop (kf)", (1,)),
        (lambda: _carrier_loop_epochs("iq-filter"), "iq-filter (svd-ckf)", (1,)),
        # iq-filter keeps its batch flat inside; the failure is named in the harness's (runs, channels).
        (lambda: _carrier_loop_epochs("iq-filter", batch=(2, 3), bad=(1, 2)), "iq-filter (svd-ckf)", (1, 2)),
        (_smoother_epochs, "kf-smoother (kf)", (1,)),
        (_position_ca_epochs, "position-ca (kf)", (1, 0)),  # batch (runs, coordinate)
        (_ekf_pv_epochs, "ekf-pv (ekf)", (1,)),
    ],
    ids=["kf-carrier-loop", "iq-filter", "iq-filter-2d", "kf-smoother", "position-ca", "ekf-pv"],
)
def test_every_gaussian_plugin_names_a_bad_measurement_through_the_filter_step(run, filter_name, element):
    """A NaN in batch element 1 at the fourth epoch: each plugin's FilterStep refuses it by
    name (the plugin and its engine), element and step, with no NumPy warning on the way."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(gf.InvalidMeasurementError) as err:
            run()
    assert err.value.filter_name == filter_name
    assert err.value.batch_indices == [element] and err.value.step == 3


def test_the_deep_integration_navigator_updates_through_the_filter_step(monkeypatch):
    """PvaNavigator's navigation and clock updates (deep_measurements.linear_update) are
    FilterStep updates: they are seen there, by name, and a NaN residual is refused by it."""
    from gnssframework.receiver.deep.navigators import PvaNavigator

    rng = np.random.default_rng(21)
    runs, n = 3, 6
    los = rng.normal(size=(runs, n, 3))
    los /= np.linalg.norm(los, axis=-1, keepdims=True)
    res = rng.normal(size=(runs, n, 2)) * [3.0, 0.2]
    cov = np.broadcast_to(np.diag([4.0, 0.04]), (runs, n, 2, 2)).copy()
    cn0 = rng.uniform(35, 50, (runs, n))
    P0 = np.diag([25.0] * 3 + [1.0] * 3 + [4.0] * 3)
    x0 = rng.normal(size=(runs, 9)) * 1e3
    seen = []
    real = FilterStep.update

    def spy(self, *args, **kwargs):
        seen.append((self.name, self.step_index))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(FilterStep, "update", spy)
    nav = PvaNavigator(x0[:, :3], x0[:, 3:6], x0[:, 6:], P0, np.zeros((runs, 2)), np.eye(2))
    nav.update(0.1, res, cov, los, cn0)
    assert seen == [("pva-navigator", 0), ("clock filter", 0)]
    res[2, 4, 0] = np.nan
    with pytest.raises(gf.InvalidMeasurementError, match=r"pva-navigator: .*batch element \(2,\), step 1"):
        nav.update(0.2, res, cov, los, cn0)


def _iq_filter_outputs(batch, draws, output, shape_of):
    """Run iq-filter on ``draws`` (correlators of batch (3,) or ()) given at ``shape_of(corr)``."""
    f = create("channel_filter", "iq-filter", output=output, warmup=2, window=3)
    f.reset(batch, gf.RunContext(coherent_time_s=0.001, early_late_spacing_chips=1.0, cn0_dbhz=45.0))
    outs = []
    for corr in draws:
        corr = type(corr)(*(shape_of(a) for a in (corr.early, corr.prompt, corr.late)))
        out = f.step({"correlators": corr, "nco_shift_chips": 0.0, "nco_shift_hz": 0.0, "data_bit": 1.0})
        outs.append({k: np.broadcast_to(v, batch) for k, v in out.items()})
    return outs


@pytest.mark.parametrize("output", ["split", "equivalent", "filtered", "reset"])
def test_iq_filter_flat_batch_takes_scalar_and_shared_correlators_as_before(output):
    # iq-filter flattens its batch inside. A batch () (complex 0-d prompt) must give what
    # batch (1,) gives, and correlators shared across runs ((3,) for batch (2, 3)) what the
    # same correlators repeated for each run give; a float cast of the complex first
    # prompt (amplitude |Re p|, phase 0 or pi) fails both.
    rng = np.random.default_rng(4)
    zero = np.zeros(3)
    draws = [simulate_correlators(zero + 0.05, 0.3 + zero, zero + 2.0, 45.0, 0.001, rng) for _ in range(8)]
    single = [type(c)(c.early[0], c.prompt[0], c.late[0]) for c in draws]
    scalar = _iq_filter_outputs((), single, output, lambda a: a)
    one = _iq_filter_outputs((1,), single, output, lambda a: np.reshape(a, (1,)))
    shared = _iq_filter_outputs((2, 3), draws, output, lambda a: a)
    repeated = _iq_filter_outputs((2, 3), draws, output, lambda a: np.repeat(a[None], 2, axis=0))
    for k in one[0]:
        for s_out, o_out, sh, rep in zip(scalar, one, shared, repeated):
            np.testing.assert_array_equal(s_out[k], o_out[k][0], err_msg=k)
            np.testing.assert_array_equal(sh[k], rep[k], err_msg=k)
    assert abs(float(scalar[0]["phase_error_rad"]) - 0.3) < 0.5  # the first prompt's phase, not 0 or pi
