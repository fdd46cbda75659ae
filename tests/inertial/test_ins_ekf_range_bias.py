"""``ins-ekf`` with the range-error budget as states (issue 42): the differenced update against
a hand-built information form, its consistency by Monte Carlo, and its refusals."""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

from gnssframework.errors import ConfigError, InvalidInputError
from gnssframework.interfaces import RunContext
from gnssframework.registry import create
from gnssframework.simulation.constellation import nominal_constellation

LAT, LON, H = 34.23, 108.3576, 590.6
M = 15
BUDGET = {"sisre_std_m": 0.6, "iono_vertical_std_m": 2.0, "tropo_zenith_std_m": 0.05}


def _satellites(n):
    """Positions and velocities ``(n, 3)`` of the ``n`` highest satellites at the place."""
    const = nominal_constellation()
    sats = const.subset(const.visible(0.0, LAT, LON, H, 10.0, n))
    s, sv, _ = sats.state(np.asarray(0.0))
    return s, sv


def _geometry(n):
    """Unit lines of sight (receiver to satellite) and elevations (deg) of ``n`` satellites,
    the elevations from pymap3d (not from the library's own geometry)."""
    s, _ = _satellites(n)
    r = np.array(pymap3d.geodetic2ecef(LAT, LON, H))
    e = (s - r) / np.linalg.norm(s - r, axis=-1, keepdims=True)
    _, el, _ = pymap3d.ecef2aer(s[:, 0], s[:, 1], s[:, 2], LAT, LON, H)
    return r, e, np.asarray(el)


def _bias_columns(el):
    """How [I_v, T_z, eps_1..eps_n] enter each range, written out: the Klobuchar obliquity
    factor (IS-GPS-200 20.3.3.5.2.5), the DO-229 mapping function, one per satellite."""
    sc = el / 180.0
    obliq = 1.0 + 16.0 * (0.53 - sc) ** 3
    s = np.sin(np.radians(el))
    mapping = 1.001 / np.sqrt(0.002001 + s * s)
    return np.column_stack([obliq, mapping, np.eye(len(el))])


def _prior(n):
    ins = np.concatenate([np.full(3, 1e-4), np.full(3, 0.25), np.full(3, 25.0), np.full(3, 1e-8), np.full(3, 1e-4)])
    bias = np.concatenate([[2.0**2, 0.05**2], np.full(n, 0.6**2)])
    return np.diag(ins), np.diag(bias)


def _ekf(P0, runs, **params):
    ekf = create("nav_filter", "ins-ekf", **params)
    ekf.reset((runs,), RunContext(initial_cov=P0))
    return ekf


def _differenced_model(e, cols, var_r, var_v, ref):
    """H over [15 INS states, biases] and D R D^T of the single differences against ``ref``,
    built row by row (ranges, then rates) without the library's operators."""
    n = len(e)
    others = [i for i in range(n) if i != ref]
    nb = cols.shape[1]
    H = np.zeros((2 * (n - 1), M + nb))
    R = np.zeros((2 * (n - 1), 2 * (n - 1)))
    for a, i in enumerate(others):
        H[a, 6:9] = e[i] - e[ref]
        H[a, M:] = cols[i] - cols[ref]
        H[n - 1 + a, 3:6] = e[i] - e[ref]
        for b, j in enumerate(others):
            R[a, b] = var_r[ref] + (var_r[i] if i == j else 0.0)
            R[n - 1 + a, n - 1 + b] = var_v[ref] + (var_v[i] if i == j else 0.0)
    return H, R


def test_differenced_update_with_range_bias_states_equals_the_information_form_by_hand():
    n, steps = 6, 4
    r, e, el = _geometry(n)
    g = np.random.default_rng(8)
    P_ins, P_b = _prior(n)
    var_r, var_v = g.uniform(0.5, 2.0, n), g.uniform(0.01, 0.03, n)
    cn0 = g.uniform(35.0, 48.0, n)
    ref = int(np.argmax(cn0))
    cols = _bias_columns(el)
    Hd, Rd = _differenced_model(e, cols, var_r, var_v, ref)
    x_true = np.concatenate([g.normal(size=M) * np.sqrt(np.diag(P_ins)), g.normal(size=cols.shape[1]) * 3.0])
    ekf = _ekf(P_ins[None], 1, **BUDGET)
    applied = np.zeros(M)  # corrections handed to the INS: its remaining error is x_true - applied
    info = np.linalg.inv(np.block([[P_ins, np.zeros((M, P_b.shape[0]))], [np.zeros((P_b.shape[0], M)), P_b]]))
    info_vec = np.zeros(M + P_b.shape[0])
    for _ in range(steps):
        # Per channel: range residual e.(dr) - clock + M b + noise, rate residual e.(dv) - drift + noise.
        x_now = x_true.copy()
        x_now[:M] -= applied
        w_r, w_v = g.normal(size=n) * np.sqrt(var_r), g.normal(size=n) * np.sqrt(var_v)
        rng_res = e @ x_now[6:9] - 7.0 + cols @ x_true[M:] + w_r
        rate_res = e @ x_now[3:6] + 0.4 + w_v
        out = ekf.step(
            {
                "residual_m": np.stack([rng_res, rate_res], -1)[None],
                "residual_cov": np.stack([np.stack([var_r, 0 * var_r], -1), np.stack([0 * var_v, var_v], -1)], -2)[
                    None
                ],
                "los": e[None],
                "cn0_dbhz": cn0[None],
                "position_m": r[None],
            }
        )
        # The information form of the same differences, on the error before any correction
        # (the residuals with the corrections applied so far added back).
        others = [i for i in range(n) if i != ref]
        z_true = np.concatenate(
            [
                [(rng_res[i] + e[i] @ applied[6:9]) - (rng_res[ref] + e[ref] @ applied[6:9]) for i in others],
                [(rate_res[i] + e[i] @ applied[3:6]) - (rate_res[ref] + e[ref] @ applied[3:6]) for i in others],
            ]
        )
        applied = applied + out["error_state"][0]
        Rinv = np.linalg.inv(Rd)
        info = info + Hd.T @ Rinv @ Hd
        info_vec = info_vec + Hd.T @ Rinv @ z_true
    P_ref = np.linalg.inv(info)
    x_ref = P_ref @ info_vec
    # Tolerates: rounding of two different orders of the same linear algebra (a sequential
    # Kalman filter against one information-form solve) on covariances of about 1e-8 to 25.
    np.testing.assert_allclose(applied, x_ref[:M], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(ekf.state.mean[0, M:], x_ref[M:], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(ekf.state.cov[0], P_ref, rtol=1e-6, atol=1e-12)
    np.testing.assert_array_equal(ekf.state.mean[0, :M], 0.0)  # the INS part restarts at zero
    np.testing.assert_array_equal(ekf.cov, ekf.state.cov[:, :M, :M])  # the contract's cov: the INS error


def _position_nees(params, runs=3000, steps=5, seed=3):
    """Mean position NEES over ``runs`` Monte Carlo runs of the differenced update with the
    true INS errors and range biases drawn from the prior (a static receiver)."""
    n = 6
    r, e, el = _geometry(n)
    g = np.random.default_rng(seed)
    P_ins, P_b = _prior(n)
    cols = _bias_columns(el)
    var_r, var_v = np.full(n, 1.0), np.full(n, 0.02)
    cn0 = np.linspace(40.0, 46.0, n)
    dr = g.normal(size=(runs, 3)) * 5.0
    dv = g.normal(size=(runs, 3)) * 0.5
    b = g.normal(size=(runs, cols.shape[1])) * np.sqrt(np.diag(P_b))
    ekf = _ekf(P_ins, runs, **params)
    cov = np.zeros((runs, n, 2, 2))
    cov[..., 0, 0], cov[..., 1, 1] = var_r, var_v
    for _ in range(steps):
        res = np.stack(
            [
                dr @ e.T + b @ cols.T + g.normal(size=(runs, n)) * np.sqrt(var_r),
                dv @ e.T + g.normal(size=(runs, n)) * np.sqrt(var_v),
            ],
            -1,
        )
        out = ekf.step(
            {
                "residual_m": res,
                "residual_cov": cov,
                "los": np.broadcast_to(e, (runs, n, 3)),
                "cn0_dbhz": np.broadcast_to(cn0, (runs, n)),
                "position_m": np.broadcast_to(r, (runs, 3)),
            }
        )
        dr = dr - out["error_state"][:, 6:9]
        dv = dv - out["error_state"][:, 3:6]
    P = ekf.cov[:, 6:9, 6:9]
    return float(np.mean(np.einsum("ri,rij,rj->r", dr, np.linalg.inv(P), dr)))


def test_the_budget_as_states_makes_the_position_covariance_tell_the_truth():
    # Mean of 3,000 chi-square(3) NEES: 3 with a standard error of sqrt(6 / 3000) = 0.045;
    # 4.5 standard errors either side. Without the states the same runs are overconfident
    # by more than 5 times (the SISRE and ionospheric biases do not average out).
    with_states = _position_nees(BUDGET)
    assert 3.0 - 0.2 <= with_states <= 3.0 + 0.2
    assert _position_nees({}) > 15.0


def test_range_bias_states_are_refused_where_they_cannot_be_mapped():
    n = 5
    r, e, _ = _geometry(n)
    P_ins, _ = _prior(n)
    cov = np.zeros((1, n, 2, 2))
    cov[..., 0, 0], cov[..., 1, 1] = 1.0, 0.01
    step = {"residual_m": np.zeros((1, n, 2)), "residual_cov": cov, "los": e[None], "cn0_dbhz": np.full((1, n), 40.0)}
    ekf = _ekf(P_ins[None], 1, **BUDGET)
    assert ekf.fixed_channel_set()
    with pytest.raises(InvalidInputError, match="position_m"):
        ekf.step(step)
    ekf.step({**step, "position_m": r[None]})
    with pytest.raises(ConfigError) as exc:  # one channel fewer: its SISRE state has no channel
        ekf.step({**step, **{k: v[:, :-1] for k, v in step.items()}, "position_m": r[None]})
    assert exc.value.field == "nav_filter 'ins-ekf'.sisre_std_m" and "fixed channel set" in str(exc.value)
    with pytest.raises(InvalidInputError, match="fix_range_gain"):  # a loose fix without its gain
        ekf.step({"position_velocity_error": np.zeros((1, 6)), "position_velocity_cov": np.eye(6)[None]})
    with pytest.raises(ConfigError, match="epoch_interval_s"):  # Gauss-Markov states need the update interval
        _ekf(P_ins[None], 1, **BUDGET, range_bias_time_s=300.0)
    assert not create("nav_filter", "ins-ekf").fixed_channel_set()


def test_gauss_markov_bias_states_decay_over_the_update_interval():
    n = 5
    r, e, _ = _geometry(n)
    P_ins, _ = _prior(n)
    ekf = create("nav_filter", "ins-ekf", sisre_std_m=0.6, range_bias_time_s=10.0)
    ekf.reset((1,), RunContext(initial_cov=P_ins[None], epoch_interval_s=0.5))
    cov = np.zeros((1, n, 2, 2))
    cov[..., 0, 0], cov[..., 1, 1] = 1e6, 1e6  # no information: the step is a prediction
    ekf.step(
        {
            "residual_m": np.zeros((1, n, 2)),
            "residual_cov": cov,
            "los": e[None],
            "cn0_dbhz": np.full((1, n), 40.0),
            "position_m": r[None],
        }
    )
    # sigma^2 (psi^2 + 1 - psi^2) = sigma^2 stationary; the mean decays by psi = exp(-0.05).
    np.testing.assert_allclose(np.diag(ekf.state.cov[0])[M:], 0.36, rtol=1e-6)
    ekf.state.mean[0, M:] = 1.0
    ekf.propagate(np.eye(M), np.zeros((M, M)))
    np.testing.assert_allclose(ekf.state.mean[0, M:], np.exp(-0.05), rtol=1e-12)


def test_the_innovation_a_gate_tests_carries_the_bias_states():
    # After one update the bias estimate is non-zero and correlated with the INS error: the
    # innovation of the next measurement is z - H x^- and its covariance H P^- H^T + R over
    # all the states, here against the hand-built H and D R D^T.
    n = 6
    r, e, el = _geometry(n)
    g = np.random.default_rng(21)
    P_ins, _ = _prior(n)
    var_r, var_v = g.uniform(0.5, 2.0, n), g.uniform(0.01, 0.03, n)
    cn0 = g.uniform(35.0, 48.0, n)
    cov = np.zeros((1, n, 2, 2))
    cov[0, :, 0, 0], cov[0, :, 1, 1] = var_r, var_v
    ekf = _ekf(P_ins[None], 1, **BUDGET)

    def inputs():
        res = np.stack([g.normal(size=n) * 3.0, g.normal(size=n) * 0.2], -1)[None]
        return {"residual_m": res, "residual_cov": cov, "los": e[None], "cn0_dbhz": cn0[None], "position_m": r[None]}

    ekf.step(inputs())
    nxt = inputs()
    v, S = ekf.innovation(nxt)
    ref = int(np.argmax(cn0))
    Hd, Rd = _differenced_model(e, _bias_columns(el), var_r, var_v, ref)
    others = [i for i in range(n) if i != ref]
    res = nxt["residual_m"][0]
    z = np.concatenate([[res[i, 0] - res[ref, 0] for i in others], [res[i, 1] - res[ref, 1] for i in others]])
    x, P = ekf.state.mean[0], ekf.state.cov[0]
    assert np.any(x[M:] != 0.0)
    # Tolerates: the same few products summed in another order.
    np.testing.assert_allclose(v[0], z - Hd @ x, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(S[0], Hd @ P @ Hd.T + Rd, rtol=1e-10, atol=1e-10)
    # Without the budget the filter's innovation is the differences themselves (its mean is zero).
    plain = _ekf(P_ins[None], 1)
    v0, _ = plain.innovation({k: val for k, val in nxt.items() if k != "position_m"})
    np.testing.assert_array_equal(v0[0], z)


class _StaticIns:
    """An INS that does not move: identity transition, no process noise, corrections kept."""

    def __init__(self, p):
        self.p = np.array(p, float)
        self.v = np.zeros_like(self.p)

    def take_error_model(self):
        runs = len(self.p)
        return np.broadcast_to(np.eye(M), (runs, M, M)).copy(), np.zeros((runs, M, M))

    def kinematics(self):
        return self.p.copy(), self.v.copy(), np.zeros_like(self.p)

    def correct(self, dx):
        self.p = self.p - dx[:, 6:9]
        self.v = self.v - dx[:, 3:6]


def test_tight_coupling_gate_weighs_the_bias_states_it_carries():
    # Pseudoranges biased by a 3 m vertical ionosphere (slant by the obliquity factor) and
    # 1.2 m SISREs, measured to 0.1 m: differences of several metres. The 15-state filter's
    # gate sees them as 20-sigma faults and refuses the update (the INS keeps its error);
    # with the budget as states the innovation covariance holds them and the update is used.
    from gnssframework.receiver.deep.ins_navigator import tight_update

    n = 6
    r, e, el = _geometry(n)
    s, sv = _satellites(n)
    cols = _bias_columns(el)
    b = np.concatenate([[3.0, 0.05], 1.2 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)])
    rho = np.linalg.norm(s - r, axis=-1) + 40.0 + cols @ b  # clock 40 m, biases
    rate = np.einsum("ci,ci->c", e, sv)
    P_ins, _ = _prior(n)
    out = {}
    for name, params in (("plain", {}), ("budget", BUDGET)):
        ins = _StaticIns((r + np.array([2.0, -1.0, 1.5]))[None])
        dx = tight_update(
            ins,
            _ekf(P_ins[None], 1, **params),
            rho[None],
            rate[None],
            np.full((1, n), 0.01),
            np.full((1, n), 1e-4),
            s,
            sv,
            np.linspace(40.0, 46.0, n)[None],
            gate_probability=0.001,
        )
        out[name] = np.abs(dx[0, 6:9]).max()
    assert out["plain"] < 1e-6  # refused: nil gain (REJECTED_FIX_VAR)
    assert out["budget"] > 0.5  # used: the INS's 2 m error is corrected


def test_fix_range_gain_is_how_a_range_error_moves_the_least_squares_fix():
    # The oracle: pv_fix's own Gauss-Newton solution moved by a small range error on each channel.
    from gnssframework.receiver.deep.loose import fix_range_gain, pv_fix

    n = 6
    r, e, _ = _geometry(n)
    s, sv = _satellites(n)
    g = np.random.default_rng(2)
    var_r = g.uniform(0.5, 3.0, (1, n))
    rho = np.linalg.norm(s - r, axis=-1)[None] + 12.0
    rate = np.einsum("ci,ci->c", e, sv)[None]
    fix0, _, _ = pv_fix(rho, rate, var_r, np.full((1, n), 0.01), s, sv, r[None] + 30.0, np.zeros((1, 3)))
    K, los = fix_range_gain(var_r, s, fix0)
    np.testing.assert_allclose(los[0], e, atol=1e-6)  # the fix is the true position to rounding
    for i in range(n):
        bumped = rho.copy()
        bumped[0, i] += 1.0
        fix1, _, _ = pv_fix(bumped, rate, var_r, np.full((1, n), 0.01), s, sv, r[None] + 30.0, np.zeros((1, 3)))
        # Tolerates: the fix's nonlinearity over a 1 m step at 20,000 km (about 1e-7 m) and
        # Gauss-Newton's convergence after 4 iterations.
        np.testing.assert_allclose(fix1[0] - fix0[0], K[0, :, i], atol=1e-6)


def test_loose_update_with_range_bias_states_is_gaussian_conditioning_by_hand():
    # z = INS minus fix = [dr - K M b, dv] + n: one update against P H^T (H P H^T + R)^-1.
    n = 6
    r, e, el = _geometry(n)
    g = np.random.default_rng(9)
    P_ins, P_b = _prior(n)
    cols = _bias_columns(el)
    K = g.normal(size=(3, n)) * 0.5
    R = np.diag(g.uniform(0.5, 2.0, 6))
    z = g.normal(size=6)
    ekf = _ekf(P_ins[None], 1, **BUDGET)
    out = ekf.step(
        {
            "position_velocity_error": z[None],
            "position_velocity_cov": R[None],
            "fix_range_gain": K[None],
            "los": e[None],
            "position_m": r[None],
        }
    )
    nb = cols.shape[1]
    Hh = np.zeros((6, M + nb))
    Hh[0:3, 6:9] = np.eye(3)
    Hh[3:6, 3:6] = np.eye(3)
    Hh[0:3, M:] = -K @ cols
    P0 = np.block([[P_ins, np.zeros((M, nb))], [np.zeros((nb, M)), P_b]])
    S = Hh @ P0 @ Hh.T + R
    gain = P0 @ Hh.T @ np.linalg.inv(S)
    # Tolerates: the same few products in another order (S's condition number is about 1e4).
    np.testing.assert_allclose(out["error_state"][0], (gain @ z)[:M], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ekf.state.mean[0, M:], (gain @ z)[M:], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ekf.state.cov[0], P0 - gain @ S @ gain.T, rtol=1e-8, atol=1e-12)


def test_without_a_budget_the_filters_innovation_is_the_15_state_gates_to_the_bit():
    # A filter that gives no innovation of its own (the contract's default) is gated on the
    # 15 INS states' predicted covariance; ins-ekf's own innovation, without range-bias
    # states, is the same numbers (so the examples' gated runs did not move).
    from gnssframework.receiver.deep.ins_navigator import gate_innovation

    n = 6
    r, e, _ = _geometry(n)
    g = np.random.default_rng(13)
    P_ins, _ = _prior(n)
    L = g.normal(size=(M, M)) * 0.1
    Phi = (np.eye(M) + L)[None]
    Qd = (L @ L.T)[None]
    cov = np.zeros((1, n, 2, 2))
    cov[..., 0, 0], cov[..., 1, 1] = 1.0, 0.01
    differenced = {
        "transition": Phi,
        "process_noise": Qd,
        "residual_m": g.normal(size=(1, n, 2)),
        "residual_cov": cov,
        "los": e[None],
        "cn0_dbhz": np.linspace(40.0, 46.0, n)[None],
        "position_m": r[None],
    }
    loose = {
        "transition": Phi,
        "process_noise": Qd,
        "position_velocity_error": g.normal(size=(1, 6)),
        "position_velocity_cov": np.eye(6)[None],
    }
    ekf = _ekf(P_ins[None], 1)
    plugin_cls = type(ekf)
    no_own = type("NoOwnInnovation", (plugin_cls,), {"innovation": lambda self, inputs: None})
    other = no_own()
    other.reset((1,), RunContext(initial_cov=P_ins[None]))
    for inputs in (differenced, loose):
        own, fallback = gate_innovation(ekf, dict(inputs)), gate_innovation(other, dict(inputs))
        np.testing.assert_array_equal(own[0], fallback[0])
        np.testing.assert_array_equal(own[1], fallback[1])
