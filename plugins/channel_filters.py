"""Built-in tracking channel filters: ``scalar`` and ``kf-carrier-loop``."""

from __future__ import annotations

from typing import Any, Literal, Mapping

import numpy as np
from pydantic import Field

from gnssframework import registry
from gnssframework.interfaces import ChannelFilter
from gnssframework.plugin import PluginParams
from gnssframework.receiver.loop_filters import LoopFilter
from gnssframework.signal.constants import CA_CHIP_RATE_HZ, L1_FREQ_HZ

__all__ = ["ScalarTrackingLoop", "KalmanCarrierLoop"]


class ScalarParams(PluginParams):
    coherent_time_s: float = Field(0.001, gt=0, le=0.02)
    pll_bandwidth_hz: float = Field(15.0, gt=0)
    pll_order: Literal[2, 3] = 3
    fll_bandwidth_hz: float = Field(5.0, ge=0, description="FLL assist bandwidth; 0 switches the assist off")
    dll_bandwidth_hz: float = Field(1.0, gt=0)
    dll_order: Literal[1, 2] = 1
    early_late_spacing_chips: float = Field(1.0, gt=0, le=1.0)
    code_discriminator: str = "eml-envelope"
    phase_discriminator: str = "costas-atan"
    freq_discriminator: str = "atan2-fll"


class _CarrierAidedDll:
    """Carrier-aided DLL: code rate = chip rate (1 + f_carrier / f_L1) + loop correction."""

    def __init__(self, p, batch_shape):
        self.disc = registry.create("discriminator", p.code_discriminator, coherent_time_s=p.coherent_time_s,
                                    early_late_spacing_chips=p.early_late_spacing_chips)
        self.filter = LoopFilter(p.dll_order, p.dll_bandwidth_hz, p.coherent_time_s)
        self.filter.reset(batch_shape)

    def __call__(self, corr, carrier_freq_hz):
        err = self.disc(corr)
        return err, CA_CHIP_RATE_HZ * (1 + carrier_freq_hz / L1_FREQ_HZ) + self.filter(err)


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
    requires = ("correlators",)
    provides = ("carrier_freq_hz", "code_freq_hz", "code_disc_chips", "phase_disc_rad", "freq_disc_hz")

    def reset(self, batch_shape: tuple[int, ...], **context: Any) -> None:
        p = self.params
        self.phase_disc = registry.create("discriminator", p.phase_discriminator, coherent_time_s=p.coherent_time_s)
        self.freq_disc = registry.create("discriminator", p.freq_discriminator, coherent_time_s=p.coherent_time_s)
        self.carrier = LoopFilter(p.pll_order, p.pll_bandwidth_hz, p.coherent_time_s, p.fll_bandwidth_hz)
        self.carrier.reset(batch_shape, rate0=context.get("doppler_hz", 0.0))
        self.dll = _CarrierAidedDll(p, batch_shape)
        self.previous = None

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        corr = inputs["correlators"]
        phase = self.phase_disc(corr)
        freq = (self.freq_disc(corr, previous=self.previous) if self.previous is not None and self.params.fll_bandwidth_hz
                else np.zeros_like(phase))
        self.previous = corr
        f = self.carrier(phase / (2 * np.pi), freq)
        code_err, code_freq = self.dll(corr, f)
        return {"carrier_freq_hz": f, "code_freq_hz": code_freq, "code_disc_chips": code_err,
                "phase_disc_rad": phase, "freq_disc_hz": freq}


class KalmanLoopParams(PluginParams):
    coherent_time_s: float = Field(0.001, gt=0, le=0.02)
    states: Literal[2, 3] = Field(2, description="phase and frequency (2), or also frequency rate (3)")
    q: list[float] = Field([0.01, 0.1], description="diagonal of Q per interval: phase, frequency(, rate)")
    r: float = Field(5.0, gt=0, description="variance R of the phase measurement")
    angle_unit: Literal["rad", "deg", "cycles"] = Field(
        "rad", description="unit of the phase in q and r (frequency: the same unit per second)")
    phase_discriminator: str = "costas-atan"
    dll_bandwidth_hz: float = Field(1.0, gt=0)
    dll_order: Literal[1, 2] = 1
    early_late_spacing_chips: float = Field(1.0, gt=0, le=1.0)
    code_discriminator: str = "eml-envelope"
    initial_std: list[float] = Field([0.5, 5.0, 1.0], description="initial std: phase (unit), freq (unit/s), rate")


_TO_RAD = {"rad": 1.0, "deg": np.pi / 180, "cycles": 2 * np.pi}


class KalmanCarrierLoop(ChannelFilter):
    """Kalman-filter carrier loop (reference 003, Kalman tracking under scintillation).

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
    reference 003 does not state its unit.
    """

    name = "kf-carrier-loop"
    description = "Kalman carrier tracking loop on the two-quadrant arctangent (reference 003)"
    Params = KalmanLoopParams
    requires = ("correlators",)
    provides = ("carrier_freq_hz", "code_freq_hz", "carrier_phase_step_rad", "phase_disc_rad", "code_disc_chips")

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        n = p.states
        if len(p.q) != n:
            from gnssframework.errors import ConfigError
            raise ConfigError("channel_filter 'kf-carrier-loop'.q", f"needs {n} values for states={n}, got {p.q}")
        T = p.coherent_time_s
        self.F = np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]])[:n, :n]
        self.H = np.array([1.0, T / 2, T * T / 6])[:n]
        self.Q = np.diag(p.q)
        self.unit = _TO_RAD[p.angle_unit]

    def reset(self, batch_shape: tuple[int, ...], **context: Any) -> None:
        p = self.params
        self.phase_disc = registry.create("discriminator", p.phase_discriminator, coherent_time_s=p.coherent_time_s)
        n = p.states
        self.P = np.broadcast_to(np.diag(np.array(p.initial_std[:n]) ** 2), batch_shape + (n, n)).copy()
        # Frequency and its rate of the NCO, in angle_unit/s (and /s^2).
        self.freq = np.broadcast_to(2 * np.pi * np.asarray(context.get("doppler_hz", 0.0), float) / self.unit,
                                    batch_shape).copy()
        self.rate = np.zeros(batch_shape)
        self.dll = _CarrierAidedDll(p, batch_shape)

    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        corr = inputs["correlators"]
        p = self.params
        z_rad = self.phase_disc(corr)
        z = z_rad / self.unit
        # Update: the prior error state is zero after the previous feedback.
        PH = self.P @ self.H
        S = PH @ self.H + p.r
        K = PH / S[..., None]
        dx = K * z[..., None]
        self.P = self.P - K[..., :, None] * PH[..., None, :]
        # Feedback: move the NCO to the estimate, propagated to the next interval's start.
        T = p.coherent_time_s
        phase_step = dx[..., 0] + T * dx[..., 1] + (0.5 * T * T * dx[..., 2] if p.states == 3 else 0.0)
        if p.states == 3:
            self.rate = self.rate + dx[..., 2]
            self.freq = self.freq + dx[..., 1] + T * dx[..., 2] + T * self.rate
        else:
            self.freq = self.freq + dx[..., 1]
        self.P = self.F @ self.P @ self.F.T + self.Q
        f_hz = self.freq * self.unit / (2 * np.pi)
        code_err, code_freq = self.dll(corr, f_hz)
        return {"carrier_freq_hz": f_hz, "code_freq_hz": code_freq, "carrier_phase_step_rad": phase_step * self.unit,
                "phase_disc_rad": z_rad, "code_disc_chips": code_err}
