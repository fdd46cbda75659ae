"""Built-in tracking channel filters: ``scalar`` and ``kf-carrier-loop``."""

from __future__ import annotations

from typing import Any, Literal
from collections.abc import Mapping

import numpy as np
from pydantic import Field, NonNegativeFloat, PositiveFloat, model_validator

from gnssframework import registry
from gnssframework.errors import ConfigError, NumericalError
from gnssframework.estimation import FilterStep, Gaussian, LinearModel, register_warm_up
from gnssframework.interfaces import ChannelFilter, RunContext
from gnssframework.signal.channel_model import channel_model
from gnssframework.signal.correlator_model import tap_noise_cov
from gnssframework.signal.navdata import wipe_off
from gnssframework.plugin import NestedFieldError, PluginParams
from gnssframework.plugin_ref import PluginRef, handles_nonlinear
from gnssframework.receiver.tracking.loop_filters import MAX_BANDWIDTH_TIME, LoopFilter, check_bandwidth_time
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.spec import SignalSpec
from gnssframework.simulation.clock import PRESETS, ClockPreset

__all__ = ["ScalarTrackingLoop", "KalmanCarrierLoop", "DiscriminatorChannel", "IqFilter"]

# The iq-filter's channel model: its fused drivers (5 states, 6 correlator outputs) compile
# in the kernels' warm-up, before `compare` forks its workers.
register_warm_up(channel_model(0.001, 0.5, np.eye(5), np.eye(6)).compiled, 5, 6)


#: Bound of every loop bandwidth: B_L T at most 0.2 at the shortest T (1 ms); the harness's
#: T is checked against it when the config loads (`check_context`).
_MAX_BANDWIDTH_HZ = MAX_BANDWIDTH_TIME / 0.001
_BANDWIDTH_RULE = f"; B_L T at most {MAX_BANDWIDTH_TIME} at the harness's T (200 Hz at 1 ms, 10 Hz at 20 ms)"


class ScalarParams(PluginParams):
    pll_bandwidth_hz: float = Field(
        15.0, gt=0, le=_MAX_BANDWIDTH_HZ, description="PLL noise bandwidth B_L (Hz)" + _BANDWIDTH_RULE
    )
    pll_order: Literal[2, 3] = Field(3, description="PLL order (2 tracks a frequency step, 3 a Doppler ramp)")
    fll_bandwidth_hz: float = Field(
        5.0,
        ge=0,
        le=_MAX_BANDWIDTH_HZ,
        description="FLL assist bandwidth (Hz); 0 switches the assist off" + _BANDWIDTH_RULE,
    )
    dll_bandwidth_hz: float = Field(
        1.0, gt=0, le=_MAX_BANDWIDTH_HZ, description="DLL noise bandwidth B_L (Hz, carrier aided)" + _BANDWIDTH_RULE
    )
    dll_order: Literal[1, 2] = Field(1, description="DLL loop order")
    code_discriminator: PluginRef("discriminator", unit="chips") = Field(
        "eml-envelope", description="DLL discriminator"
    )
    phase_discriminator: PluginRef("discriminator", unit="rad") = Field("costas-atan", description="PLL discriminator")
    freq_discriminator: PluginRef("discriminator", unit="Hz") = Field(
        "atan2-fll", description="FLL-assist discriminator (on consecutive prompts)"
    )


def _check_bandwidths(loop: ChannelFilter, context: RunContext, fields: tuple[str, ...]) -> None:
    """Refuse a bandwidth of ``loop`` too large for the context's T, naming the parameter."""
    who = f"{loop.kind} {loop.name!r}"
    T = context.require("coherent_time_s", who)
    for field in fields:
        check_bandwidth_time(getattr(loop.params, field), T, f"{who}.{field}")


def _signal_of(context: Mapping[str, Any] | RunContext | None, default: SignalSpec = GPS_L1CA) -> SignalSpec:
    """The tracked signal of a run context (or an assumptions mapping): its ``signal``, or
    ``default`` (GPS L1 C/A) where it names none."""
    found = None if context is None else context.get("signal")
    return default if found is None else found


def _carrier_loop_at(loop: ChannelFilter, context: Mapping[str, Any]) -> tuple[ChannelFilter, float] | None:
    """``loop`` at the context's interval T (re-created with its other parameters if its
    own ``coherent_time_s`` differs, as the ``scintillation`` scenario re-creates it), and
    T; ``None`` when the scenario gives no T (its loops may run at another)."""
    T = context.get("coherent_time_s")
    if T is None:
        return None
    from gnssframework.receiver.tracking.loop_bandwidth import at_interval  # as equivalent_bandwidth_hz below

    return at_interval(loop, float(T)), float(T)


def _carrier_loop_bandwidth(loop: ChannelFilter, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
    r"""The loop's one-sided noise bandwidth at its steady state, measured at the context's
    T (`gnssframework.receiver.tracking.loop_bandwidth.equivalent_bandwidth_hz`:
    $B_L = \sum h_n^2 / (2T (\sum h_n)^2)$ of its closed-loop impulse response)."""
    from gnssframework.receiver.tracking.loop_bandwidth import equivalent_bandwidth_hz

    at = _carrier_loop_at(loop, context)
    if at is None:
        return {}
    try:
        return {"carrier loop noise bandwidth": (equivalent_bandwidth_hz(*at), "Hz")}
    except ConfigError:  # the probe did not settle: no bandwidth to declare
        return {"carrier loop noise bandwidth": ("undefined (did not settle)", "Hz")}


def _phase_thermal_variance(loop: ChannelFilter, context: Mapping[str, Any]) -> float | None:
    r"""The loop's phase discriminator's thermal variance (rad² per interval) at the
    context's C/N0 and T (``costas-atan``: $1/(2cT)\,(1 + 1/(2cT))$), or ``None``."""
    at, cn0 = _carrier_loop_at(loop, context), context.get("cn0_dbhz")
    if at is None or cn0 is None:
        return None
    disc = loop.params.phase_discriminator.create(coherent_time_s=at[1])
    return float(disc.noise_variance(float(cn0)))


class _CarrierAidedDll:
    """Carrier-aided DLL: code rate = chip rate (1 + f_carrier / f_L) + loop correction
    (chip rate and carrier frequency ``f_L`` the tracked signal's)."""

    def __init__(self, p, batch_shape, T: float, spacing_chips: float, signal: SignalSpec):
        self.disc = p.code_discriminator.create(coherent_time_s=T, early_late_spacing_chips=spacing_chips)
        self.filter = LoopFilter(p.dll_order, p.dll_bandwidth_hz, T)
        self.filter.reset(batch_shape)
        self.chip_rate_hz, self.carrier_hz = signal.chip_rate_hz, signal.carrier_freq_hz

    def __call__(self, corr, carrier_freq_hz):
        err = self.disc(corr)
        rate = self.chip_rate_hz * (1 + carrier_freq_hz / self.carrier_hz) + self.filter(err)
        # A commanded code jump (`Discriminator.code_jump_chips`) moves the replica over the
        # next interval, outside the loop filter.
        return err, rate + self.disc.code_jump_chips() / self.disc.params.coherent_time_s


class ScalarTrackingLoop(ChannelFilter):
    """Scalar tracking: FLL-assisted PLL (order 2 or 3) and a carrier-aided DLL.

    Every interval: the phase discriminator (``costas-atan``) drives the carrier loop
    filter, in cycles, and the frequency discriminator (``atan2-fll`` on consecutive
    prompts) enters one integrator earlier as the FLL assist. The code discriminator
    (``eml-envelope``) drives a DLL whose rate is aided by the carrier frequency. The
    thermal jitter is $B_L/c\\,(1 + 1/(2cT))$ rad² for the PLL and $2 B_L T\\,\\sigma_D^2$
    for the DLL; both are tested in closed loop.
    """

    name = "scalar"
    description = "Scalar tracking: FLL-assisted PLL (order 2-3) + carrier-aided DLL"
    Params = ScalarParams
    params: ScalarParams  # self.params, as validated
    requires = ("correlators",)
    provides = ("carrier_freq_hz", "code_freq_hz", "code_disc_chips", "phase_disc_rad", "freq_disc_hz")

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        p = self.params
        who = f"channel_filter {self.name!r}"
        T = context.require("coherent_time_s", who)
        d = context.require("early_late_spacing_chips", who)
        self.phase_disc = p.phase_discriminator.create(coherent_time_s=T)
        self.freq_disc = p.freq_discriminator.create(coherent_time_s=T)
        self.carrier = LoopFilter(p.pll_order, p.pll_bandwidth_hz, T, p.fll_bandwidth_hz)
        self.carrier.reset(batch_shape, rate0=context.get("doppler_hz", 0.0))
        self.dll = _CarrierAidedDll(p, batch_shape, T, d, _signal_of(context))
        self.previous = None

    def assumptions(self, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
        r"""The carrier loop's order, design and measured noise bandwidths (Hz), and the
        dynamics a 2nd-order loop is the steady-state Kalman filter for.

        A 2nd-order loop with damping $\zeta = 1/\sqrt{2}$ (the design's) is the
        steady-state Kalman-Bucy filter of a phase driven by a white angular acceleration
        of density $q_w = \omega_0^4 r_c$ (rad²/s³) measured with white phase noise of
        density $r_c = T \sigma_\phi^2$ (rad² s), $\sigma_\phi^2$ the discriminator's thermal
        variance at the case's C/N0 and $\omega_0 = B_L / 0.53$ (Kaplan & Hegarty); as a
        line-of-sight acceleration its PSD is $q_w (\lambda / 2\pi)^2$ (m²/s³). A 3rd-order
        loop tracks a constant acceleration instead (no such PSD is declared).
        """
        p = self.params
        out: dict[str, tuple[Any, str]] = {
            "carrier loop": (f"PLL, order {p.pll_order}", ""),
            "carrier loop design bandwidth": (float(p.pll_bandwidth_hz), "Hz"),
        }
        out.update(_carrier_loop_bandwidth(self, context))
        out["FLL assist bandwidth"] = (float(p.fll_bandwidth_hz), "Hz")
        var = _phase_thermal_variance(self, context)
        if p.pll_order == 2 and var is not None:
            from gnssframework.receiver.tracking.loop_filters import natural_frequency

            T = _carrier_loop_at(self, context)[1]
            lam = context.get("wavelength_m", _signal_of(context).wavelength_m)
            q_w = natural_frequency(2, p.pll_bandwidth_hz) ** 4 * T * var
            out["line-of-sight acceleration PSD"] = (float(q_w * (lam / (2 * np.pi)) ** 2), "m²/s³")
        return out

    def check_context(self, context: RunContext) -> None:
        _check_bandwidths(self, context, ("pll_bandwidth_hz", "fll_bandwidth_hz", "dll_bandwidth_hz"))

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        corr = inputs["correlators"]
        phase = self.phase_disc(corr)
        freq = (
            self.freq_disc(corr, previous=self.previous)
            if self.previous is not None and self.params.fll_bandwidth_hz
            else np.zeros_like(phase)
        )
        self.previous = corr
        f = self.carrier(phase / (2 * np.pi), freq)
        code_err, code_freq = self.dll(corr, f)
        return {
            "carrier_freq_hz": f,
            "code_freq_hz": code_freq,
            "code_disc_chips": code_err,
            "phase_disc_rad": phase,
            "freq_disc_hz": freq,
        }


class KalmanLoopParams(PluginParams):
    states: Literal[2, 3] = Field(2, description="phase and frequency (2), or also frequency rate (3)")
    q: list[NonNegativeFloat] = Field(
        [0.01, 0.1],
        min_length=2,
        max_length=3,
        description="diagonal of Q per interval, each >= 0: phase, frequency(, rate); one value per state",
    )
    r: float = Field(5.0, gt=0, description="variance R of the phase measurement")
    angle_unit: Literal["rad", "deg", "cycles"] = Field(
        "rad", description="unit of the phase in q and r (frequency: the same unit per second)"
    )
    clock: ClockPreset | None = Field(
        None,
        description="receiver clock preset whose h-parameters add their phase and frequency noise to q "
        "(gnssframework.simulation.clock); null for q alone",
    )
    phase_discriminator: PluginRef("discriminator", unit="rad") = Field(
        "costas-atan", description="phase discriminator: the filter's measurement z"
    )
    dll_bandwidth_hz: float = Field(
        1.0, gt=0, le=_MAX_BANDWIDTH_HZ, description="DLL noise bandwidth B_L (Hz, carrier aided)" + _BANDWIDTH_RULE
    )
    dll_order: Literal[1, 2] = Field(1, description="DLL loop order")
    code_discriminator: PluginRef("discriminator", unit="chips") = Field(
        "eml-envelope", description="DLL discriminator"
    )
    initial_std: list[PositiveFloat] = Field(
        [0.5, 5.0, 1.0],
        min_length=2,
        max_length=3,
        description="initial std, each > 0: phase (unit), freq (unit/s), rate; at least one value per state",
    )

    @model_validator(mode="after")
    def _one_value_per_state(self) -> KalmanLoopParams:
        n = self.states
        if len(self.q) != n:
            raise NestedFieldError("q", f"needs {n} values for states = {n} (got {self.q})")
        if len(self.initial_std) < n:
            raise NestedFieldError(
                "initial_std", f"needs at least {n} values for states = {n} (got {self.initial_std})"
            )
        return self


_TO_RAD = {"rad": 1.0, "deg": np.pi / 180, "cycles": 2 * np.pi}


class KalmanCarrierLoop(ChannelFilter):
    """Kalman-filter carrier loop (Xia et al., Kalman tracking under scintillation, undated).

    Error state $x = [\\delta\\theta, \\delta\\omega(, \\dot{\\delta\\omega})]$ of the carrier
    relative to the NCO, in ``angle_unit`` (and per second). With T the interval:

    $$
    F = \\begin{bmatrix} 1 & T & T^2/2 \\\\ 0 & 1 & T \\\\ 0 & 0 & 1 \\end{bmatrix}, \\quad
    z = \\arctan(Q_P / I_P) = H x + v, \\quad H = [1, T/2, T^2/6]
    $$

    H gives the mean phase error over the interval: the two-quadrant arctangent sees the
    mid-interval rotation. After each update the estimated errors are fed back to the
    NCO (phase step and frequency) and the error state is reset to zero. The covariance
    runs the Kalman recursion with the user's Q (per interval) and R, so this is a PLL
    whose gains follow the Riccati equation. Q and R are given in ``angle_unit``;
    Xia et al. do not state its unit. The filter is the ``kf`` estimator run through
    `gnssframework.estimation.FilterStep`, so its failures name the loop, the channel
    and the interval. T and the correlator spacing come from the harness's run context.
    With ``clock`` set, Q adds the receiver oscillator's phase and frequency noise from its
    h-parameters (`process_noise`): the loop's model of the clock instead of a hand-set q.
    """

    name = "kf-carrier-loop"
    description = "Kalman carrier tracking loop on the two-quadrant arctangent (Xia et al.)"
    Params = KalmanLoopParams
    params: KalmanLoopParams  # self.params, as validated
    requires = ("correlators",)
    provides = ("carrier_freq_hz", "code_freq_hz", "carrier_phase_step_rad", "phase_disc_rad", "code_disc_chips")

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        self.unit = _TO_RAD[p.angle_unit]
        self.filter_step = FilterStep(registry.create("estimator", "kf"), name=f"{self.name} (kf)")

    def assumptions(self, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
        r"""The loop's noise bandwidth at its steady state (Hz), the unit Q and R are read
        in, Q and R in rad² per interval, the line-of-sight dynamics they assume, and R
        against the discriminator's thermal variance.

        With $u$ the angle unit in rad, the phase Q is $q_0 u^2$ (rad²), the frequency Q
        $q_1 u^2$ ((rad/s)²) and R $r u^2$ (rad²), per interval. The frequency state's
        random walk is a white angular acceleration of density $q_1 u^2 / T$ (rad²/s³),
        a line-of-sight acceleration PSD of $q_1 u^2 / T\,(\lambda/2\pi)^2$ (m²/s³); with
        three states the rate's, $q_2 u^2 / T\,(\lambda/2\pi)^2$, a jerk PSD (m²/s⁵).
        """
        p, u2 = self.params, self.unit**2
        out: dict[str, tuple[Any, str]] = {"carrier loop": (f"Kalman, {p.states} states", "")}
        out.update(_carrier_loop_bandwidth(self, context))
        out["Q and R read in"] = (p.angle_unit, "")
        if p.clock is not None:
            out["receiver clock in Q"] = (p.clock, "h-parameters")
        out["phase Q"] = (float(p.q[0] * u2), "rad² per interval")
        out["frequency Q"] = (float(p.q[1] * u2), "(rad/s)² per interval")
        if p.states == 3:
            out["frequency-rate Q"] = (float(p.q[2] * u2), "(rad/s²)² per interval")
        out["phase R"] = (float(p.r * u2), "rad² per interval")
        at = _carrier_loop_at(self, context)
        if at is not None:
            T, lam = at[1], context.get("wavelength_m", _signal_of(context).wavelength_m)
            out["line-of-sight acceleration PSD"] = (float(p.q[1] * u2 / T * (lam / (2 * np.pi)) ** 2), "m²/s³")
            if p.states == 3:
                out["line-of-sight jerk PSD"] = (float(p.q[2] * u2 / T * (lam / (2 * np.pi)) ** 2), "m²/s⁵")
        var = _phase_thermal_variance(self, context)
        if var is not None:
            out["phase R / thermal variance"] = (float(p.r * u2 / var), "-")
        return out

    def check_context(self, context: RunContext) -> None:
        _check_bandwidths(self, context, ("dll_bandwidth_hz",))

    def process_noise(self, coherent_time_s: float, signal: SignalSpec = GPS_L1CA) -> np.ndarray:
        r"""Q per interval in ``angle_unit``: ``diag(q)`` plus, with ``clock`` set, the
        clock's noise on the carrier phase and frequency, $M\,Q_{trk}\,M$ with $Q_{trk}$
        the phase (rad) and frequency (Hz) block of `ClockModel.tracking_process_noise` at
        ``signal``'s carrier and $M = \mathrm{diag}(1, 2\pi)/u$ (a frequency in Hz is
        $2\pi$ rad/s; $u$ the unit in rad). A 3-state loop's rate state gets none: the
        two-state clock has no such state."""
        p = self.params
        Q = np.diag(np.asarray(p.q, float))
        if p.clock is not None:
            trk = PRESETS[p.clock].tracking_process_noise(coherent_time_s, signal.carrier_freq_hz, signal.chip_rate_hz)
            M = np.diag([1.0, 2 * np.pi]) / self.unit
            Q[:2, :2] += M @ trk[1:, 1:] @ M
        return Q

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        p = self.params
        who = f"channel_filter {self.name!r}"
        T = context.require("coherent_time_s", who)
        d = context.require("early_late_spacing_chips", who)
        n = p.states
        self.T = T
        F = np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]])[:n, :n]
        H = np.array([[1.0, T / 2, T * T / 6]])[:, :n]
        self.model = LinearModel(F, H, self.process_noise(T, _signal_of(context)), np.array([[p.r]]))
        self.phase_disc = p.phase_discriminator.create(coherent_time_s=T)
        P0 = np.diag(np.array(p.initial_std[:n]) ** 2)
        self.state = self.filter_step.start(Gaussian(np.zeros(batch_shape + (n,)), P0), self.model)
        # Frequency and its rate of the NCO, in angle_unit/s (and /s^2).
        self.freq = np.broadcast_to(
            2 * np.pi * np.asarray(context.get("doppler_hz", 0.0), float) / self.unit, batch_shape
        ).copy()
        self.rate = np.zeros(batch_shape)
        self.dll = _CarrierAidedDll(p, batch_shape, T, d, _signal_of(context))

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        corr = inputs["correlators"]
        p = self.params
        z_rad = self.phase_disc(corr)
        z = z_rad / self.unit
        # The error state is zero after the previous feedback; the first epoch updates P0.
        res = self.filter_step(self.state, z[..., None], self.model, predict=self.filter_step.step_index > 0)
        dx = res.posterior.mean
        # Feedback: move the NCO to the estimate, propagated to the next interval's start;
        # the error state restarts at zero with the posterior covariance.
        T = self.T
        phase_step = dx[..., 0] + T * dx[..., 1] + (0.5 * T * T * dx[..., 2] if p.states == 3 else 0.0)
        if p.states == 3:
            self.rate = self.rate + dx[..., 2]
            self.freq = self.freq + dx[..., 1] + T * dx[..., 2] + T * self.rate
        else:
            self.freq = self.freq + dx[..., 1]
        self.state = Gaussian(np.zeros_like(dx), res.posterior.cov)
        f_hz = self.freq * self.unit / (2 * np.pi)
        code_err, code_freq = self.dll(corr, f_hz)
        return {
            "carrier_freq_hz": f_hz,
            "code_freq_hz": code_freq,
            "carrier_phase_step_rad": phase_step * self.unit,
            "phase_disc_rad": z_rad,
            "code_disc_chips": code_err,
        }


# -- vector-tracking channel filters ------------------------------------------------

VECTOR_OUTPUTS = ("code_error_chips", "code_error_var_chips2", "freq_error_hz", "freq_error_var_hz2")


class DiscriminatorChannelParams(PluginParams):
    code_discriminator: PluginRef("discriminator", unit="chips") = Field(
        "eml-envelope", description="code discriminator plugin"
    )
    freq_discriminator: PluginRef("discriminator", unit="Hz") = Field(
        "cross-product", description="frequency discriminator plugin"
    )
    fixed_r_cn0_dbhz: float | None = Field(
        None,
        ge=15,
        le=60,
        description="give the nav filter the thermal variances at this fixed C/N0 (a fixed R "
        "tuned once, e.g. at 45 dB-Hz) instead of at the channel's C/N0; null: the channel's C/N0",
    )
    freq_r_scale: float = Field(
        1.0,
        gt=0,
        le=1e4,
        description="multiply the frequency variance handed to the nav filter by this (an R "
        "inflation or deflation to tune: cross-product FLL errors are correlated between intervals, which a white "
        "R at the thermal variance does not describe)",
    )


class DiscriminatorChannel(ChannelFilter):
    """Discriminators as a vector-loop channel filter: the classic baseline of Zou et al. (2018).

    Outputs the code discriminator (``eml-envelope``) and the frequency discriminator
    (``cross-product`` on consecutive prompts) with their thermal-noise variances at the
    channel's C/N0 (given in the context as ``cn0_dbhz``; a receiver would use its C/N0
    estimate). The first interval has no previous prompt: its frequency output is 0 with
    a variance of 1e8 Hz². Known data bits are wiped off.

    With ``fixed_r_cn0_dbhz`` the variances are those at that C/N0 whatever the signal:
    a fixed R tuned once (Zou et al. 2018 do not state their baseline's R; a fixed R tuned
    on a strong signal is the common practice it most likely followed). Below that C/N0
    the nav filter then trusts the discriminators too much.
    """

    name = "discriminator"
    description = "Code and frequency discriminators with their noise variances, for vector loops"
    Params = DiscriminatorChannelParams
    params: DiscriminatorChannelParams  # self.params, as validated
    requires = ("correlators",)
    provides = VECTOR_OUTPUTS

    def assumptions(self, context):
        out = {"line-of-sight acceleration PSD": ("none (memoryless)", "m²/s³")}
        cn0, T = context.get("cn0_dbhz"), context.get("coherent_time_s")
        fixed = self.params.fixed_r_cn0_dbhz
        if cn0 is None or T is None or fixed is None:
            code_ratio = 1.0
            freq_ratio = self.params.freq_r_scale
        else:  # R at the fixed C/N0 against the thermal variance at the case's
            code = self.params.code_discriminator.create(coherent_time_s=T)
            freq = self.params.freq_discriminator.create(coherent_time_s=T)
            code_ratio = float(code.noise_variance(fixed) / code.noise_variance(cn0))
            freq_ratio = float(freq.noise_variance(fixed) / freq.noise_variance(cn0)) * self.params.freq_r_scale
        out["code R / thermal variance"] = (code_ratio, "-")
        out["frequency R / thermal variance"] = (freq_ratio, "-")
        return out

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        who = f"channel_filter {self.name!r}"
        T = context.require("coherent_time_s", who)
        spacing = context.get("early_late_spacing_chips", 1.0)
        self.code = self.params.code_discriminator.create(coherent_time_s=T, early_late_spacing_chips=spacing)
        self.freq = self.params.freq_discriminator.create(coherent_time_s=T)
        if self.code.unit != "chips" or self.freq.unit != "Hz":
            raise ConfigError(
                "channel_filter 'discriminator'",
                "needs a code discriminator (chips) and a frequency "
                f"discriminator (Hz), got {self.code.unit} and {self.freq.unit}",
            )
        cn0 = np.broadcast_to(np.asarray(context.require("cn0_dbhz", who), float), batch_shape)
        if self.params.fixed_r_cn0_dbhz is not None:
            cn0 = np.full(batch_shape, self.params.fixed_r_cn0_dbhz)
        self.var_code = np.broadcast_to(self.code.noise_variance(cn0), batch_shape)
        self.var_freq = np.broadcast_to(self.freq.noise_variance(cn0) * self.params.freq_r_scale, batch_shape)
        self.previous = None

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        corr = inputs["correlators"]
        if "data_bit" in inputs:
            corr = wipe_off(corr, inputs["data_bit"])
        code = self.code(corr)
        if self.previous is None:
            # No previous prompt: no information. A huge finite variance (not inf, which
            # would make S non-finite) lets the nav filter ignore the output.
            freq, var_freq = np.zeros_like(code), np.full(code.shape, 1e8)
        else:
            freq, var_freq = self.freq(corr, previous=self.previous), self.var_freq
        self.previous = corr
        return {
            "code_error_chips": code,
            "code_error_var_chips2": self.var_code,
            "freq_error_hz": freq,
            "freq_error_var_hz2": var_freq,
        }


class IqFilterParams(PluginParams):
    estimator: PluginRef("estimator", check=handles_nonlinear) = Field(
        "svd-ckf", description="estimator plugin: svd-ckf, ckf or ukf"
    )
    adapter: PluginRef("noise_adapter") | None = Field(
        "innovation", description="noise adapter plugin for R, or null for none"
    )
    adaptive: bool = Field(
        True,
        description="re-estimate R with the adapter; false keeps R at the correlators' "
        "true noise covariance (the same as adapter = null, which TOML cannot write)",
    )
    window: int = Field(20, ge=2, description="window L of the innovation adapter")
    warmup: int = Field(20, ge=0, description="updates before R adaptation starts")
    q: list[NonNegativeFloat] = Field(
        [1e-3, 1e-8, 1e-5, 1e-4, 1e-2],
        min_length=5,
        max_length=5,
        description="diagonal of Q per interval, 5 values each >= 0: A, dtau (chips), "
        "dtheta (rad), df (Hz), dfdot (Hz/s)",
    )
    initial_std: list[PositiveFloat] = Field(
        [2.0, 0.05, 0.3, 5.0, 5.0], min_length=5, max_length=5, description="initial std of the five states, each > 0"
    )
    output: Literal["split", "equivalent", "filtered", "reset"] = Field(
        "split",
        description="what the nav filter gets: split (code from the discriminator or from this "
        "interval's new information, see split_code; frequency filtered; consistent, the default), equivalent (both from this interval's new information), "
        "filtered (the paper's filtered estimates; counts old correlators again every interval), reset "
        "(filtered estimates from a prefilter reset after every output)",
    )
    split_code: Literal["discriminator", "new-information"] = Field(
        "discriminator",
        description="output split: the code error comes from the code discriminator with its "
        "thermal-noise variance at the channel's C/N0, or from this interval's new information",
    )
    equivalent_code: Literal["new-information", "discriminator"] = Field(
        "new-information",
        description="output equivalent: the code error from this interval's new information "
        "(default), or from the code discriminator with its thermal-noise variance at the channel's C/N0. The new "
        "information shrinks a code error that is small against the filter's code uncertainty towards 0 (the "
        "prompt measures |dtau| at the correlation peak, which the filter's linearisation takes as dtau with its "
        "prior mean's sign); the discriminator does not",
    )
    code_discriminator: PluginRef("discriminator", unit="chips") = Field(
        "eml-envelope", description="code discriminator of the split output (and of equivalent_code = 'discriminator')"
    )
    clock: str | None = Field(
        None,
        description="receiver clock preset (tcxo, tcxo-hq, ocxo) whose h-parameters "
        "add their process noise to q; null for q alone",
    )


# A carrier phase known to no better than uniform over the circle: var of U(-pi, pi).
PHASE_VAR_UNIFORM_RAD2 = np.pi**2 / 3


def _phase_spread_within_circle(cov: np.ndarray) -> np.ndarray:
    r"""``cov`` with the carrier phase's variance (state 2) at most that of a uniform phase.

    The phase is an angle: once a channel has lost lock its variance grows without bound,
    which means no more than "uniform over the circle", $\pi^2/3$. Beyond the measurement's
    nonlinearity scale a sigma-point rule with a negative central weight (the UKF's
    alpha = 1e-3: about -1e6) computes the correlators' covariance as a difference of
    terms of size $|W_0^c|\,|z_0-\hat z|^2$ whose rounding reaches R, and
    the innovation covariance loses positive definiteness by chance
    (`tests/receiver/test_deep_prefilter_lost_channel.py`). Scaling the phase's row and column,
    $P \leftarrow D P D$ with $D = \mathrm{diag}(1, 1, s, 1, 1)$, keeps P positive
    definite and every correlation; a channel in lock (tenths of a radian) is untouched.
    """
    var = cov[:, 2, 2]
    if not (var > PHASE_VAR_UNIFORM_RAD2).any():
        return cov
    s = np.sqrt(np.minimum(1.0, PHASE_VAR_UNIFORM_RAD2 / var))
    cov = cov * np.ones_like(s)[:, None, None]  # a batch-shaped copy (cov may be shared)
    cov[:, 2, :] *= s[:, None]
    cov[:, :, 2] *= s[:, None]
    return cov


def _equivalent_measurement(prior: Gaussian, post: Gaussian, idx: list[int]):
    """The measurement that carries exactly the information one update added.

    On the marginal of the states ``idx``: $R_{eq} = (P^{+-1} - P^{--1})^{-1}$,
    $z_{eq} = R_{eq}(P^{+-1} x^+ - P^{--1} x^-)$. Elements where the update added no
    information in some direction get a variance of 1e8 there.
    """
    sel = np.ix_(idx, idx)
    Ppr, Ppo = prior.cov[(...,) + sel], post.cov[(...,) + sel]
    Ipr, Ipo = np.linalg.inv(Ppr), np.linalg.inv(Ppo)
    gain = Ipo - Ipr
    # 2x2: invert directly where the gain is PD; eigen-clip only where it is not.
    det = gain[..., 0, 0] * gain[..., 1, 1] - gain[..., 0, 1] * gain[..., 1, 0]
    ok = (det > 1e-16) & (gain[..., 0, 0] > 1e-8)
    adj = np.stack(
        [np.stack([gain[..., 1, 1], -gain[..., 0, 1]], -1), np.stack([-gain[..., 1, 0], gain[..., 0, 0]], -1)], -2
    )
    R_eq = adj / np.where(ok, det, 1.0)[..., None, None]
    if not ok.all():  # no (or negative, from nonlinearity) information: variance 1e8 there
        w, v = np.linalg.eigh(0.5 * (gain[~ok] + np.swapaxes(gain[~ok], -1, -2)))
        w = np.maximum(w, 1e-8)
        R_eq[~ok] = (v / w[..., None, :]) @ np.swapaxes(v, -1, -2)
    info = Ipo @ post.mean[..., idx, None] - Ipr @ prior.mean[..., idx, None]
    z_eq = (R_eq @ info)[..., 0]
    return z_eq, R_eq


class IqFilter(ChannelFilter):
    """The per-channel filter of Zou et al. (2018) on the six correlator outputs.

    State $x = [A, \\delta\\tau, \\delta\\theta, \\delta f, \\dot{\\delta f}]$, transition of
    `gnssframework.signal.channel_model.channel_transition`, measurements
    $[I_E, I_P, I_L, Q_E, Q_P, Q_L]$ through `channel_iq` (eqs. 2-7), batched over runs
    and channels. The estimator is ``svd-ckf`` by default. R starts at the correlators'
    true noise covariance (unit-variance I and Q, correlated across taps as the code
    autocorrelation) and is re-estimated by the ``innovation`` adapter (eq. 31) over a
    window of L updates.

    Initialisation: the amplitude and carrier phase come from the first prompt, and
    the code and frequency errors start at 0. The vector loop's NCO shifts are
    subtracted from $\\delta\\tau$ and $\\delta f$ before each prediction, so the states
    stay relative to the replica actually in use.

    Output modes (``output``), i.e. what the nav filter is handed, and their
    consistency in the vector loop (Zou et al.'s (2018) scenario, 45 and 30 dB-Hz; see the
    docs page of that experiment):

    - ``split`` (default): the code error from the code discriminator with its thermal
      variance at the channel's C/N0 (``split_code = "discriminator"``) or from this
      interval's new information (``"new-information"``), and the CKF's filtered
      frequency estimate with its variance. Consistent: position and velocity NEES
      about 3 each. The filtered frequency is correlated over a few intervals only,
      short against the nav filter's velocity memory, so it is not double counted.
    - ``filtered``: the filtered code and frequency estimates with their variances,
      as in the paper. Inconsistent: the filtered code error is correlated over
      ~150 intervals and counted again every interval; position NEES in the thousands
      (the velocity NEES stays about 3).
    - ``equivalent``: the measurement that carries exactly this interval's information
      on the $(\\delta\\tau, \\delta f)$ marginal (`_equivalent_measurement`). Consistent
      in code; one interval says almost nothing about the frequency, so the frequency
      gain is lost. A code error small against the filter's code uncertainty comes out
      shrunk towards 0 (the prompt's slope changes sign at the correlation peak; 0.71 of
      a 0.002-chip error at 45 dB-Hz, `tests/receiver/test_deep_code_shrinkage.py`);
      ``equivalent_code = "discriminator"`` takes the code error from the code
      discriminator with its thermal variance instead; a UKF estimator with its sigma
      points spread over the prior (``alpha = 1``) keeps the new information without it.
    - ``reset``: after each output the filter forgets $\\delta\\tau$ and $\\delta f$ (mean
      0 relative to the new replica, initial variance, no cross-covariance) and the
      innovation adapter's window restarts, so R stays at the correlators' true
      covariance (without the restart the large post-reset spread drives eq. 31's R
      below the true variances). Its filtered outputs are then nearly white, but the
      frequency comes from two intervals of phase, like an FLL, and the code output still
      leans on the reset prior (docs/experiments/vector-tracking.md, "`iq-filter` output
      modes and their consistency", gives the measured consequences).

    With ``clock`` set, Q adds the oscillator's noise on code, phase and frequency from
    its h-parameters (`process_noise`).

    A lost channel's carrier phase variance is kept within a uniform phase's, $\\pi^2/3$
    (`_phase_spread_within_circle`): beyond it the sigma points' moments of the bounded
    correlators lose positive definiteness to rounding.

    Data bits: with ``data_bit`` in the inputs the correlators are wiped off.
    Otherwise the bit is decided from the sign of the prompt projected on the predicted
    carrier phase (decision-directed). A wrong decision rotates the phase by $\\pi$
    for one interval.

    The filter keeps its batch flat, ``(runs x channels, 5)``, so every compiled call
    of its step takes the one-axis path (no reshape per operand; about 20 us less per
    epoch of one vector-loop run); the outputs have the harness's batch shape and a
    numerical failure names the element in it. Internal arrays are flat: ``state`` and
    the adapted R in force (``filter_step.in_force(model).R``) are
    ``(runs x channels, ...)``, in C order.
    """

    name = "iq-filter"
    description = "CKF on the six I/Q correlator outputs with adaptive R (Zou et al. 2018)"
    Params = IqFilterParams
    params: IqFilterParams  # self.params, as validated
    requires = ("correlators",)
    provides = VECTOR_OUTPUTS + ("amplitude", "phase_error_rad")

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        if p.clock is not None and p.clock not in PRESETS:
            raise ConfigError(
                "channel_filter 'iq-filter'.clock", f"got {p.clock!r}; allowed: {', '.join(PRESETS)} or null"
            )
        self.engine = p.estimator.create()
        self.adapter = None
        if p.adapter and p.adaptive:
            # window and warmup are this filter's; the adapter's own params win over them.
            self.adapter = p.adapter.create(defaults={"warmup": p.warmup, "window": p.window})
        self.filter_step = FilterStep(self.engine, self.adapter, name=f"{self.name} ({self.engine.name})")

    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        T = context.require("coherent_time_s", f"channel_filter {self.name!r}")
        d = context.get("early_late_spacing_chips", 1.0) / 2
        signal = _signal_of(context)
        taps = tap_noise_cov(np.array([-d, 0.0, d]), signal=signal)
        R0 = np.zeros((6, 6))
        R0[:3, :3] = R0[3:, 3:] = taps + 1e-6 * np.eye(3)  # E/P/L share noise; a touch of jitter keeps it PD
        # Same f/h as channel_iq/channel_transition, plus compiled twins (one fused kernel per step).
        self.model = channel_model(T, d, self.process_noise(T, signal), R0, signal=signal)
        self.batch_shape = batch_shape
        self._flat_shape = (int(np.prod(batch_shape, dtype=np.int64)),)
        self.state = None
        self.T = T
        self.pending_reset = False
        self._restart: np.ndarray | None = None
        self.code_disc = None
        p = self.params
        field = (
            "split_code"
            if p.output == "split" and p.split_code == "discriminator"
            else "equivalent_code"
            if p.output == "equivalent" and p.equivalent_code == "discriminator"
            else None
        )
        if field is not None:
            self.code_disc = self.params.code_discriminator.create(coherent_time_s=T, early_late_spacing_chips=2 * d)
            if context.get("cn0_dbhz") is None:
                raise ConfigError(
                    f"channel_filter 'iq-filter'.{field}",
                    "'discriminator' needs the channel's "
                    "C/N0 (run context cn0_dbhz) for the discriminator's variance; this harness gives "
                    f"none: use {field} = 'new-information'",
                )
            cn0 = np.broadcast_to(np.asarray(context.get("cn0_dbhz"), float), batch_shape)
            self.code_var = np.broadcast_to(self.code_disc.noise_variance(cn0), batch_shape)

    def assumptions(self, context):
        T = context.get("coherent_time_s")
        out = {}
        if T is not None:
            # The frequency state's random walk (Q[3,3] per interval, clock included) is a white
            # line-of-sight acceleration of PSD Q33 / T * lambda^2 (df = -a / lambda); the
            # frequency-rate state's (Q[4,4]) a white jerk of PSD Q44 / T * lambda^2.
            signal = _signal_of(context)
            Q = self.process_noise(T, signal)
            lam = signal.wavelength_m
            out["line-of-sight acceleration PSD"] = (float(Q[3, 3] / T * lam**2), "m²/s³")
            out["line-of-sight jerk PSD"] = (float(Q[4, 4] / T * lam**2), "m²/s⁵")
        out["correlator R"] = (
            f"adaptive ({self.params.adapter.name}, window {self.params.window})"
            if self.params.adapter and self.params.adaptive
            else "true covariance",
            "",
        )
        p = self.params
        code_from_disc = p.output == "equivalent" and p.equivalent_code == "discriminator"
        out["output"] = (f"{p.output} (code from {p.code_discriminator.name})" if code_from_disc else p.output, "")
        return out

    def process_noise(self, coherent_time_s: float, signal: SignalSpec = GPS_L1CA) -> np.ndarray:
        r"""Q per interval: ``diag(q)`` plus, with ``clock`` set, the clock's noise on
        $(\delta\tau, \delta\theta, \delta f)$ from its h-parameters
        (`ClockModel.tracking_process_noise`, at ``signal``'s carrier and chip rate)."""
        Q = np.diag(np.asarray(self.params.q, float))
        if self.params.clock is not None:
            Q[1:4, 1:4] += PRESETS[self.params.clock].tracking_process_noise(
                coherent_time_s, signal.carrier_freq_hz, signal.chip_rate_hz
            )
        return Q

    def _reset_prefilter(self, mean: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r"""Forget what the filter knows about $\delta\tau$ and $\delta f$: the nav filter has
        it now, and its NCO command is the new reference (error 0, initial variance)."""
        mean, cov = mean.copy(), np.array(np.broadcast_to(cov, mean.shape + (5,)), copy=True)
        std = np.asarray(self.params.initial_std, float)
        for i in (1, 3):
            mean[..., i] = 0.0
            cov[..., i, :] = 0.0
            cov[..., :, i] = 0.0
            cov[..., i, i] = std[i] ** 2
        return mean, cov

    def restart(self, elements: np.ndarray) -> bool:
        """From the next step, ``elements`` (bool, the batch shape) start again as at the first
        step: amplitude and phase from that step's prompt, code, frequency and frequency rate
        errors 0 against the replica, the covariance ``initial_std``. With an adaptive R
        (``adaptive``) they are held on the correlators' own R for the adapter's window
        (`FilterStep.hold_model_noise`), so that the R they adapt to next comes from their
        new innovations only, as a filter started afresh there would (with its warm-up one
        step shorter than its window: ``tests/receiver/test_lock_detector.py``)."""
        mask = np.broadcast_to(np.asarray(elements, bool), self.batch_shape).reshape(self._flat_shape)
        self._restart = mask if self._restart is None else self._restart | mask
        if self.adapter is not None:
            self.filter_step.hold_model_noise(mask, int(getattr(self.adapter.params, "window", self.params.window)))
        return True

    def _restarted(self, mean: np.ndarray, cov: np.ndarray, prompt) -> tuple[np.ndarray, np.ndarray]:
        """``mean`` and ``cov`` with the elements `restart` marked started again from ``prompt``."""
        m, self._restart = self._restart, None
        p0 = self._flat(prompt)
        start = np.zeros_like(mean)
        start[:, 0], start[:, 2] = np.abs(p0), np.angle(p0)
        P0 = np.diag(np.square(np.asarray(self.params.initial_std, float)))
        return np.where(m[:, None], start, mean), np.where(m[:, None, None], P0, cov)

    def _flat(self, a) -> np.ndarray:
        """A batch-shaped input (or one broadcast to it) as the flat ``(runs x channels,)``."""
        if type(a) is np.ndarray and a.shape == self.batch_shape:
            return a.reshape(self._flat_shape)
        # Its own dtype: the first prompt is complex (amplitude and phase come from it).
        return np.broadcast_to(np.asarray(a), self.batch_shape).reshape(self._flat_shape)

    def _named(self, exc: NumericalError) -> NumericalError:
        """The failure with its batch elements in the harness's batch shape."""
        where = [
            tuple(int(i) for i in np.unravel_index(b[0], self.batch_shape)) if len(b) == 1 else b
            for b in exc.batch_indices
        ]
        return type(exc)(exc.filter_name, where, exc.step, exc.detail)

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        try:
            return self._step(inputs)
        except NumericalError as exc:
            raise self._named(exc) from None

    def _step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        corr = inputs["correlators"]
        if "data_bit" in inputs:
            corr = wipe_off(corr, inputs["data_bit"])
        shape, flat = self.batch_shape, self._flat_shape
        if self.state is None:
            p0 = self._flat(corr.prompt)
            mean = np.zeros(flat + (5,))
            mean[:, 0] = np.abs(p0)
            mean[:, 2] = np.angle(p0)
            previous = prior = self.filter_step.start(
                Gaussian(mean, np.diag(np.square(self.params.initial_std))), self.model
            )
        else:
            mean = self.state.mean.copy()
            mean[:, 1] -= self._flat(inputs["nco_shift_chips"])
            mean[:, 3] -= self._flat(inputs["nco_shift_hz"])
            cov = _phase_spread_within_circle(self.state.cov)
            if self.pending_reset:
                mean, cov = self._reset_prefilter(mean, cov)
                # The innovation window restarts from the correlators' own R with the reset.
                # The adapter's warm-up counts the updates of its new run, so with a reset
                # every interval it never leaves warm-up: R stays the correlators' true
                # covariance (the running step count does not change that).
                self.filter_step.restart_adapter(self.model, from_model_noise=True, restart_warmup=False)
            if self._restart is not None and self._restart.any():  # a lost signal back (`restart`)
                mean, cov = self._restarted(mean, cov, corr.prompt)
            previous = Gaussian(mean, cov)
            prior = self.filter_step.predict(previous, self.model)
        if "data_bit" not in inputs:  # decision-directed wipe-off
            phase = (prior.mean[:, 2] + np.pi * prior.mean[:, 3] * self.T).reshape(shape)
            bit = np.where(np.real(corr.prompt * np.exp(-1j * phase)) >= 0, 1.0, -1.0)
            corr = wipe_off(corr, bit)
        first = self.filter_step.step_index == 0
        iq = corr.as_iq()
        if iq.shape[:-1] != shape:  # correlators shared by a batch dimension, as before flattening
            iq = np.broadcast_to(iq, shape + iq.shape[-1:])
        upd = self.filter_step.update(prior, iq.reshape(flat + iq.shape[-1:]), self.model, previous=previous)
        self.state = upd.posterior
        x, P = upd.posterior.mean, upd.posterior.cov
        out = {"amplitude": x[:, 0].reshape(shape), "phase_error_rad": x[:, 2].reshape(shape)}
        mode = self.params.output
        self.pending_reset = mode == "reset"
        if mode in ("filtered", "reset") or first:
            out.update(
                code_error_chips=x[:, 1].reshape(shape),
                code_error_var_chips2=P[:, 1, 1].reshape(shape),
                freq_error_hz=x[:, 3].reshape(shape),
                freq_error_var_hz2=P[:, 3, 3].reshape(shape),
            )
            return out
        if self.code_disc is not None and mode == "split":  # split, code from the discriminator
            out.update(
                code_error_chips=self.code_disc(corr),
                code_error_var_chips2=self.code_var,
                freq_error_hz=x[:, 3].reshape(shape),
                freq_error_var_hz2=P[:, 3, 3].reshape(shape),
            )
            return out
        z, R = _equivalent_measurement(prior, upd.posterior, [1, 3])
        out.update(code_error_chips=z[:, 0].reshape(shape), code_error_var_chips2=R[:, 0, 0].reshape(shape))
        if mode == "equivalent":
            out.update(freq_error_hz=z[:, 1].reshape(shape), freq_error_var_hz2=R[:, 1, 1].reshape(shape))
            if self.code_disc is not None:  # equivalent_code = "discriminator"
                out.update(code_error_chips=self.code_disc(corr), code_error_var_chips2=self.code_var)
        else:  # split, code from the new information
            out.update(freq_error_hz=x[:, 3].reshape(shape), freq_error_var_hz2=P[:, 3, 3].reshape(shape))
        return out
