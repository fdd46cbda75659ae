"""Scenario ``deep-integration``: coherent deep GNSS/INS integration (Cai and Guo 2017).

GPS L1 C/A channels of the nominal constellation seen from an aircraft flying reference
002's pull-up (`gnssframework.inertial`; or straight flight, or straight flight with one
smooth acceleration pulse of given peak jerk, ``profile = "jerk-pulse"``), a receiver
clock from h-parameters, and five kinds of candidate, told apart by what they compose:

* ``deep`` / ``deep-no-accel``: a prefilter ``channel_filter`` that hands over each
  interval's new information (``iq-filter`` with ``output = "equivalent"``) and the
  ``ins-ekf`` nav_filter; the corrected INS aids the NCOs (`receiver.deep.aided_tracking`), with or
  without the line-of-sight acceleration (``ins-ekf``'s ``accel_aiding``), and with or
  without a carrier-phase prefilter closing only the carrier loop (``ins-ekf``'s
  ``carrier_filter``).
* ``vector``: a vector-loop channel filter and a GNSS-only nav filter that closes the
  loop (``iq-filter`` + ``ekf-pv``; `receiver.tracking.vector.run_vector_loop`), no INS.
* ``loose``: a scalar loop per channel (a ``channel_filter`` that closes its own loop,
  e.g. ``scalar``) and ``ins-ekf`` fed with position/velocity fixes
  (`receiver.deep.loose`).
* ``tight``: the same scalar loops and ``ins-ekf`` with ``coupling = "tight"``: each
  channel's pseudorange and rate update the INS error state, single-differenced
  (`receiver.deep.ins_navigator.tight_update`); no fix between.

Every series is on the integration filter's grid (10 Hz); errors are in local axes at the
true position (ENU via pymap3d), attitude as roll/pitch/yaw. Each metric is declared once
as a component (`METRICS`, from `gnssframework.experiments.metric_components`) over one of
these series, computed once by `evaluate`.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from ... import random_streams as draw
from ...errors import ConfigError
from ...suggest import did_you_mean
from ...inertial.earth import STANDARD_GRAVITY_MPS2
from ...interfaces import ErrorStateNavFilter, RunContext
from ...inertial.imu import ImuGrade
from ...inertial.trajectory import MAX_START_LAT_DEG
from ...receiver.deep.aided_tracking import DeepTruth, loss_of_lock
from ...receiver.engine.lock_detector import CN0LockDetector
from .deep_integration_lock import LOCK_METRICS, LockDetectorParams, check_lock, lock_series, make_lock, whole_multiple
from .deep_integration_metrics import attitude_errors_deg, enu_errors
from ...receiver.tracking.scalar import NCO_COMMANDS
from ...receiver.tracking.vector import CHANNEL_OUTPUTS, NAV_OUTPUTS, VectorTruth, run_vector_loop
from .vector_tracking import SkyRealismParams, draw_residuals
from ...signal.constants import SPEED_OF_LIGHT_M_S
from ...simulation.clock import PRESETS
from ...simulation.constellation import draw_epochs, nominal_constellation
from ...simulation.fade import lowest_channels
from ...simulation.propagation import cn0_from_elevation, elevation_deg, range_error_function
from ..limits import SignalCoherentTime
from ..metric_components import Mean, PostSettleMax, Rmse, evaluate, units
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = ["DeepIntegrationScenario", "BYTES_PER_EPOCH_RUN_CHANNEL"]

#: Peak memory of the aided tracking (or the vector loop) per coherent interval, run and
#: channel, an upper bound over the candidate kinds: tests/experiments/test_limits.py holds it above
#: the measured peak.
BYTES_PER_EPOCH_RUN_CHANNEL = 256

ERRORS = (
    "horizontal_position_error",
    "height_error",
    "horizontal_velocity_error",
    "vertical_velocity_error",
    "attitude_error",
)
UNITS = {
    "horizontal_position_error": "m",
    "height_error": "m",
    "horizontal_velocity_error": "m/s",
    "vertical_velocity_error": "m/s",
    "attitude_error": "deg",
}
_WHAT = {
    "horizontal_position_error": "horizontal position error (ENU at the true position)",
    "height_error": "height error",
    "horizontal_velocity_error": "horizontal velocity error",
    "vertical_velocity_error": "vertical velocity error",
    "attitude_error": "attitude error, the largest of |roll|, |pitch|, |yaw| errors",
}

#: The scenario's metrics, each declared once as a component (name, unit, the per-update series
#: it reduces, from settle_s on); ``run_batch`` computes them all once with `evaluate`.
METRICS = (
    *(
        Rmse(f"{e}_rmse", UNITS[e], of=e, settle="settle_s", description=f"RMS {_WHAT[e]} after settle_s")
        for e in ERRORS
    ),
    *(
        PostSettleMax(f"{e}_max", UNITS[e], of=e, settle="settle_s", description=f"largest {_WHAT[e]} after settle_s")
        for e in ERRORS
    ),
    Rmse(
        "code_tracking_error_rmse",
        "chips",
        of="code_tracking_error",
        settle="settle_s",
        description="replica code error, RMS over channels and coherent intervals",
    ),
    Rmse(
        "freq_tracking_error_rmse",
        "Hz",
        of="freq_tracking_error",
        settle="settle_s",
        description="replica frequency error, RMS over channels and coherent intervals",
    ),
    Rmse(
        "phase_tracking_error_rmse",
        "rad",
        of="phase_tracking_error",
        settle="settle_s",
        description="carrier phase error modulo pi (Costas), RMS over channels and coherent intervals",
    ),
    Mean(
        "loss_of_lock_fraction",
        "-",
        of="loss_of_lock",
        settle="settle_s",
        description="fraction of channel-epochs out of lock (code > 0.5 chip or frequency > 1/(2T))",
    ),
    Mean(
        "nees",
        "-",
        of="nees_pv",
        settle="settle_s",
        description="NEES of the 6 position and velocity states, mean over updates",
    ),
    Mean(
        "phase_lock_loss_fraction",
        "-",
        of="phase_unlocked",
        settle="settle_s",
        description="fraction of channel-epochs whose carrier phase error modulo pi exceeds pi/4 (45 deg, "
        "the Costas tracking threshold of Kaplan and Hegarty 2017)",
    ),
    Mean(
        "cycle_slip_rate",
        "1/s",
        of="cycle_slips",
        settle="settle_s",
        description="half-cycle slips of the carrier phase error per channel and second",
    ),
)


class DeepIntegrationParams(SignalCoherentTime, SkyRealismParams, LockDetectorParams):
    """The flight and receiver of reference 002; the C/N0 and range-residual options of
    `SkyRealismParams` (off by default); the lock detector of `LockDetectorParams` (ideal by
    default: `deep_integration_lock`)."""

    duration_s: float = Field(50.0, gt=0, le=600, description="flight length (Cai and Guo 2017: 50 s)")
    profile: Literal["pull-up", "straight", "jerk-pulse"] = Field(
        "pull-up",
        description="Cai and Guo's (2017) flight (level 10 s, then a pull-up), straight flight, or straight "
        "flight with one smooth acceleration pulse (pulse_* parameters)",
    )
    coherent_time_s: float = Field(
        0.001, description="T of correlators and prefilters (s): whole 1 ms code periods, 1 to 20 ms"
    )
    imu_interval_s: float = Field(0.005, gt=0, description="IMU increment interval (200 Hz in Cai and Guo 2017)")
    nco_interval_s: float = Field(0.005, gt=0, description="interval at which the NCOs are re-aided (deep)")
    update_interval_s: float = Field(0.1, gt=0, description="integration filter interval (10 Hz)")
    pull_in_updates: int = Field(
        1,
        ge=0,
        description="first integration intervals whose prefilter output is not "
        "used (prefilters pulling in from acquisition)",
    )
    channels: int = Field(8, ge=5, le=12)
    elevation_mask_deg: float = Field(10.0, ge=0, lt=90)
    start_time_s: float = Field(37800.0, ge=0, description="seconds into the nominal constellation's day")
    lat_deg: float = Field(
        34.23,
        ge=-MAX_START_LAT_DEG,
        le=MAX_START_LAT_DEG,
        description="start latitude (deg), "
        "within 89 deg of the equator: the flights are integrated in local north/east axes, "
        "which degenerate at a pole",
    )
    lon_deg: float = Field(108.3576, ge=-180, le=360)
    height_m: float = 590.6
    clock: str = Field(
        "ocxo",
        description="receiver clock preset (a TCXO's white frequency noise alone gives "
        "about 16 Hz of frequency error per 1 ms interval, which no loop removes)",
    )
    oscillator_g_sensitivity_per_g: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0),
        description="g-sensitivity vector Gamma of the receiver oscillator in body axes (forward, right, down), in "
        "1/g; default 0 (none). The true clock's fractional frequency error gains Gamma . f_b / g0 (f_b the specific "
        "force along the flight, IEEE Std 1193 / Filler 1988: typical crystals 1e-10 to 1e-8 per g; at 30 g and "
        "1e-9/g that is 3e-8, about 47 Hz of common Doppler at L1); the receiver's clock model does not know it",
    )
    early_late_spacing_chips: float = Field(1.0, gt=0, le=1.0)
    initial_position_std_m: float = Field(
        5.0, gt=0, description="initial position error per axis (not stated in Cai and Guo 2017)"
    )
    initial_velocity_std_m_s: float = Field(0.3, gt=0)
    initial_attitude_std_deg: float = Field(0.5, gt=0)
    initial_clock_std_m: tuple[float, float] = Field(
        (3.0, 0.3), description="initial clock bias (m) and drift (m/s) errors"
    )
    imu: ImuGrade = Field(
        default_factory=ImuGrade,
        description="IMU error levels (Cai and Guo's (2017) as defaults; "
        "see gnssframework.inertial.imu for the reading of its white-noise units)",
    )
    filter_imu: ImuGrade | None = Field(
        None,
        description="the IMU error levels the INS filter assumes (its initial bias covariance and its "
        "process noise), when they are not the truth's: a receiver knows its IMU from a datasheet, not "
        "exactly. Default null: the filter is handed imu itself. Scale factors and misalignments are not "
        "states of the 15-state error filter: set in imu they are unmodelled whatever this says, unless "
        "ins-ekf is given their priors (its gyro_scale_factor_ppm ... accel_misalignment_mrad: 33 states)",
    )
    settle_s: float = Field(5.0, ge=0, description="metrics (and their _max) count from here on")
    rate_window_s: float = Field(0.02, gt=0, description="loose, tight: window of the scalar loops' carrier-phase rate")
    loose_rate_window: Literal["centred", "trailing"] = Field(
        "centred",
        description="loose, tight: the rate window centred on the update instant (reaches rate_window_s/2 past "
        "it) or trailing it (ends there; its mean rate carried to the instant with the INS's line-of-sight "
        "acceleration)",
    )
    loose_dll_correlation: Literal["white", "loop"] = Field(
        "white",
        description="loose, tight: the scalar loops' pseudorange variance as the DLL's thermal value (white) or "
        "inflated by (1+rho)/(1-rho), rho = exp(-4 B_L update_interval_s), the correlation of a first-order "
        "loop's error between updates (loop)",
    )
    loose_gate_probability: float = Field(
        0.0,
        ge=0,
        lt=1,
        description="loose, tight: false-alarm probability of the chi-square innovation gate on each fix (tight: on each update's differences together) (0: no gate)",
    )
    pulse_accel_g: float = Field(20.0, gt=0, le=100, description="jerk-pulse profile: peak acceleration (g)")
    pulse_jerk_g_s: float = Field(
        50.0,
        gt=0,
        le=1000,
        description="jerk-pulse profile: peak jerk (g/s); the smooth rise lasts 1.875 pulse_accel_g / pulse_jerk_g_s",
    )
    pulse_start_s: float = Field(2.0, ge=0, description="jerk-pulse profile: start of the pulse")
    pulse_hold_s: float = Field(1.0, ge=0, description="jerk-pulse profile: time at peak acceleration")
    pulse_direction_enu: tuple[float, float, float] = Field(
        (0.0, 0.0, 1.0), description="jerk-pulse profile: direction of the acceleration (ENU at the start)"
    )
    geometry: Literal["fixed", "per-run"] = Field(
        "fixed",
        description="fixed: every run sees the satellites at start_time_s. per-run: each run draws its "
        "start epoch from its own stream, uniform over the nominal constellation's sidereal day (86164.1 s) among "
        "the epochs with `channels` satellites above the mask, and tracks the highest ones then; the truth grid "
        "then holds every run's satellites (memory grows with runs x duration_s / coherent_time_s). Default fixed",
    )


class DeepIntegrationCase(ScenarioParams):
    name: str | None = None
    cn0_dbhz: float = Field(..., ge=15, le=60)
    # Error sources a case may add to the scenario's truth, so that a comparison can hold a
    # case with and one without them (on common random numbers: the case's `streams`).
    oscillator_g_sensitivity_per_g: tuple[float, float, float] | None = Field(
        None, description="this case's oscillator g-sensitivity vector (1/g, body axes; default: the scenario's)"
    )
    gyro_misalignment_mrad: float | None = Field(
        None, ge=0, description="this case's gyro misalignment (mrad; default: the scenario's imu)"
    )
    accel_misalignment_mrad: float | None = Field(
        None, ge=0, description="this case's accelerometer misalignment (mrad; default: the scenario's imu)"
    )
    gyro_scale_factor_ppm: float | None = Field(
        None, ge=0, description="this case's gyro scale-factor error (ppm; default: the scenario's imu)"
    )
    accel_scale_factor_ppm: float | None = Field(
        None, ge=0, description="this case's accelerometer scale-factor error (ppm; default: the scenario's imu)"
    )

    outage_channels: int | None = Field(
        None,
        ge=1,
        description="a satellite outage in the truth: this many channels, the lowest elevations first (at the "
        "start of the flight), lose their signal (correlator signal amplitude 0, noise unchanged) for intervals "
        "whose middle lies in [outage_start_s, outage_end_s); with the scenario's lock_detector 'ideal' every "
        "candidate (loose, tight, deep, vector) drops them from the first update whose measurements reach into the "
        "outage and does not take them back (an ideal lock detector without reacquisition); with a C/N0 test each "
        "candidate decides from its own prompts. Default null (off)",
    )
    outage_start_s: float = Field(0.0, ge=0, description="start (s) of the outage")
    outage_end_s: float | None = Field(None, gt=0, description="end (s) of the outage; null: to the end of the run")

    def outage(self) -> tuple[int, float, float | None] | None:
        """``(channels, start_s, end_s)`` of the case's outage, or None."""
        if self.outage_channels is None:
            return None
        return self.outage_channels, self.outage_start_s, self.outage_end_s

    def scenario_update(self, params: DeepIntegrationParams) -> dict[str, Any]:
        """The scenario parameters this case replaces (empty: none)."""
        update: dict[str, Any] = {}
        if self.oscillator_g_sensitivity_per_g is not None:
            update["oscillator_g_sensitivity_per_g"] = self.oscillator_g_sensitivity_per_g
        imu = {
            k: getattr(self, k)
            for k in (
                "gyro_misalignment_mrad",
                "accel_misalignment_mrad",
                "gyro_scale_factor_ppm",
                "accel_scale_factor_ppm",
            )
            if getattr(self, k) is not None
        }
        if imu:
            update["imu"] = params.imu.model_copy(update=imu)
        return update


def phase_lock_series(phase_error_rad: np.ndarray, n_upd: int, update_interval_s: float) -> dict[str, np.ndarray]:
    """Per-update carrier-phase series from the phase errors ``(U * n_upd, runs, ch)`` of a Costas loop.

    A Costas loop locks at either of two phases half a cycle apart, so the error counts
    modulo pi: ``phase_tracking_error`` is its RMS over channels and the coherent intervals
    of each update interval; ``phase_unlocked`` the fraction of those channel-epochs beyond
    pi/4 (45 deg: the rule-of-thumb Costas tracking threshold, Kaplan and Hegarty 2017,
    section 8.6); ``cycle_slips`` the half-cycle slips per channel and second, from the
    error unwrapped modulo pi (a slip: its nearest multiple of pi changes).
    """
    K, runs = phase_error_rad.shape[:2]
    U = K // n_upd
    doubled = np.unwrap(2.0 * phase_error_rad, axis=0)
    wrapped = np.angle(np.exp(1j * doubled)) / 2
    cycles = np.rint(doubled / (2 * np.pi))
    slips = np.abs(np.diff(cycles, axis=0, prepend=cycles[:1]))
    by_update = (U, n_upd, runs, -1)
    return {
        "phase_tracking_error": np.sqrt(np.mean(wrapped.reshape(by_update) ** 2, axis=(1, 3))),
        "phase_unlocked": np.mean(np.abs(wrapped.reshape(by_update)) > np.pi / 4, axis=(1, 3)),
        "cycle_slips": np.sum(slips.reshape(by_update), axis=1).mean(axis=-1) / update_interval_s,
    }


def _kind(plugins: dict[str, Any]) -> str:
    ch, nav = plugins["channel_filter"], plugins["nav_filter"]
    if isinstance(nav, ErrorStateNavFilter):
        if all(o in ch.provides for o in CHANNEL_OUTPUTS):
            return "deep"
        if all(o in ch.provides for o in NCO_COMMANDS) and "correlators" in ch.requires:
            return "tight" if nav.aiding().coupling == "tight" else "loose"
        raise ConfigError(
            "channel_filter",
            f"{ch.name!r} can neither feed deep integration (it would provide "
            f"{', '.join(CHANNEL_OUTPUTS)}) nor close a scalar loop (provide "
            f"{', '.join(NCO_COMMANDS)})",
        )
    if all(o in nav.provides for o in NAV_OUTPUTS) and all(o in ch.provides for o in CHANNEL_OUTPUTS):
        return "vector"
    raise ConfigError(
        "nav_filter",
        f"{nav.name!r} with {ch.name!r} is neither deep/loose integration (an "
        "error-state nav filter, e.g. ins-ekf) nor a vector loop (a nav filter providing "
        + ", ".join(NAV_OUTPUTS)
        + ")",
    )


@register_scenario
class DeepIntegrationScenario(Scenario):
    """Deep GNSS/INS integration (Cai and Guo 2017) against vector tracking and loose coupling."""

    kind = "deep-integration"
    Params = DeepIntegrationParams
    params: DeepIntegrationParams  # self.params, as validated
    CaseParams = DeepIntegrationCase
    components = {"channel_filter": True, "nav_filter": True}
    metrics = units(METRICS)
    #: The raw per-update series (RMS over channels and the coherent intervals of each update
    #: interval for the tracking errors) that the metrics reduce.
    outputs = {
        **UNITS,
        "code_tracking_error": "chips",
        "freq_tracking_error": "Hz",
        "phase_tracking_error": "rad",
        "loss_of_lock": "-",
        "nees_pv": "-",
        "phase_unlocked": "-",
        "cycle_slips": "1/s",
        # with a C/N0 lock detector (deep_integration_lock.lock_series):
        "false_exclusion": "-",
        "missed_exclusion": "-",
        "channels_in_update": "-",
    }

    #: Why a metric can be undefined in a run (summary.json and report.md say it).
    undefined_reasons = {
        "phase_lock_loss_fraction": "carrier phase not tracked (deep tracks it only with "
        "ins-ekf's carrier_filter set; vector has no carrier loop)",
        "cycle_slip_rate": "carrier phase not tracked (deep tracks it only with ins-ekf's "
        "carrier_filter set; vector has no carrier loop)",
        "attitude_error_rmse": "no attitude estimate (vector tracking has no INS)",
        "attitude_error_max": "no attitude estimate (vector tracking has no INS)",
        "phase_tracking_error_rmse": "carrier phase not tracked (deep tracks it only with ins-ekf's "
        "carrier_filter set; vector has no carrier loop)",
    }

    def __init__(self, params: DeepIntegrationParams) -> None:
        super().__init__(params)
        p = params
        if p.clock not in PRESETS:
            raise ConfigError(
                "scenario.clock", f"got {p.clock!r}; allowed: {', '.join(PRESETS)}{did_you_mean(p.clock, PRESETS)}"
            )
        for name, small, big in (
            ("imu_interval_s", p.coherent_time_s, p.imu_interval_s),
            ("nco_interval_s", p.coherent_time_s, p.nco_interval_s),
            ("update_interval_s", p.imu_interval_s, p.update_interval_s),
            ("update_interval_s", p.nco_interval_s, p.update_interval_s),
            ("duration_s", p.update_interval_s, p.duration_s),
        ):
            whole_multiple(name, big, small, f"{small} s")
        if p.settle_s >= p.duration_s:
            raise ConfigError("scenario.settle_s", f"must be less than duration_s = {p.duration_s}")
        check_lock(p)
        if p.lock_detector != "ideal":  # the detector's own metrics (deep_integration_lock.LOCK_METRICS)
            self.metrics = units(METRICS + LOCK_METRICS)

    def check_case(self, case: dict[str, Any], where: str) -> None:
        """The case's fields, and an outage that does something and fits the flight."""
        super().check_case(case, where)
        c = DeepIntegrationCase.model_validate(case)
        p = self.params
        given = [f for f in ("outage_start_s", "outage_end_s") if f in c.model_fields_set]
        if c.outage_channels is None:
            if given:
                raise ConfigError(f"{where}.{given[0]}", "has no effect without an outage: set outage_channels")
            return
        if c.outage_channels >= p.channels:
            raise ConfigError(
                f"{where}.outage_channels",
                f"must leave at least 1 of the channels = {p.channels} (got {c.outage_channels})",
            )
        if c.outage_start_s >= p.duration_s:
            raise ConfigError(
                f"{where}.outage_start_s", f"must be below duration_s = {p.duration_s} (got {c.outage_start_s})"
            )
        if c.outage_end_s is not None and not c.outage_start_s < c.outage_end_s <= p.duration_s:
            raise ConfigError(
                f"{where}.outage_end_s",
                f"must be after outage_start_s = {c.outage_start_s} and at most duration_s = {p.duration_s} "
                f"(got {c.outage_end_s})",
            )

    def batch_memory(self, case: dict[str, Any], runs: int, where: str, candidates=()) -> tuple[float, str, str]:
        p = self.params
        epochs = int(round(p.duration_s / p.coherent_time_s))
        return (
            BYTES_PER_EPOCH_RUN_CHANNEL * epochs * runs * p.channels,
            "scenario.coherent_time_s",
            f"a batch of {runs} runs of {where} ({epochs} epochs x {p.channels} channels)",
        )

    def run_contexts(self, cases: list[dict[str, Any]]) -> list[RunContext]:
        p = self.params
        return [
            RunContext(
                coherent_time_s=p.coherent_time_s,
                early_late_spacing_chips=p.early_late_spacing_chips,
                epoch_interval_s=p.coherent_time_s,
            )
        ]

    def check_composition(self, plugins: dict[str, Any], where: str) -> None:
        try:
            _kind(plugins)
        except ConfigError as exc:
            raise ConfigError(f"{where}.{exc.field}.name", exc.detail) from None

    # --- truth --------------------------------------------------------------------------
    def satellites(self):
        p = self.params
        const = nominal_constellation()
        return const.subset(
            const.visible(p.start_time_s, p.lat_deg, p.lon_deg, p.height_m, p.elevation_mask_deg, p.channels)
        )

    def flight(self):
        """Reference 002's flight (or a straight one) from `gnssframework.inertial`."""
        from .deep_integration_flight import make_flight

        p = self.params
        pulse = {
            "accel_g": p.pulse_accel_g,
            "jerk_g_s": p.pulse_jerk_g_s,
            "start_s": p.pulse_start_s,
            "hold_s": p.pulse_hold_s,
            "direction_enu": p.pulse_direction_enu,
        }
        return make_flight(p.profile, p.lat_deg, p.lon_deg, p.height_m, p.duration_s, pulse=pulse)

    def g_sensitivity_frequency_error(self, flight, t_s: np.ndarray) -> np.ndarray | None:
        """The oscillator's fractional frequency error from acceleration, ``Gamma . f_b / g0``
        at times ``t_s`` (None when ``oscillator_g_sensitivity_per_g`` is zero).

        The frequency of a crystal under a specific force ``f`` shifts by
        ``Gamma . f / g0`` (IEEE Std 1193-2003, the g-sensitivity vector ``Gamma`` in 1/g;
        Filler, "The acceleration sensitivity of quartz crystal oscillators: a review",
        IEEE Trans. UFFC 35(3), 1988). The truth's clock drift gains it and its bias its
        integral (trapezoid over the grid), so every channel sees the same Doppler
        ``f_L1 Gamma . f / g0``.
        """
        gamma = np.asarray(self.params.oscillator_g_sensitivity_per_g, float)
        if not np.any(gamma):
            return None
        f_b = flight.truth(np.asarray(t_s, float)).specific_force_b_mps2
        return f_b @ gamma / STANDARD_GRAVITY_MPS2

    def _truth(self, flight, cn0_dbhz: float, runs: int, rng: np.random.Generator, outage=None):
        """The truth of a batch; ``outage`` ``(channels, start_s, end_s)`` (`DeepIntegrationCase.outage`)
        or None: the lowest channels at the start lose their signal then (``signal_gain`` 0)."""
        p = self.params
        if p.geometry == "per-run":  # each run its own epoch and satellites, from its own stream
            const = nominal_constellation()
            start_s, index = draw_epochs(
                const,
                draw.child(rng, "geometry"),
                runs,
                p.lat_deg,
                p.lon_deg,
                p.height_m,
                p.elevation_mask_deg,
                p.channels,
            )
            sats, start = const.subset(index), start_s[:, None]  # satellites (runs, ch), epochs (runs, 1)

            def orbit(t):  # (*t.shape, runs, ch, 3)
                return sats.state_at(start + np.asarray(t, float)[..., None, None])
        else:
            sats = self.satellites()

            def orbit(t):
                return sats.state(p.start_time_s + np.asarray(t))

        T = p.coherent_time_s
        K = int(round(p.duration_s / T))
        bias_s, drift = PRESETS[p.clock].simulate(K + 1, T, rng, (runs,))
        y_g = self.g_sensitivity_frequency_error(flight, np.arange(K + 1) * T)
        if y_g is not None:  # truth only: the receiver's clock model does not know it
            drift = drift + y_g[:, None]
            bias_s = bias_s + np.concatenate([[0.0], np.cumsum(0.5 * T * (y_g[1:] + y_g[:-1]))])[:, None]
        clock = np.stack([bias_s, drift], -1) * SPEED_OF_LIGHT_M_S
        # Truth on the grid of epoch edges, computed once (vectorised): the harnesses ask for it at
        # every edge, and evaluating the flight or the orbits per epoch dominated the run time.
        grid = np.arange(K + 1) * T
        sat_grid = orbit(grid)
        rx_grid = flight.kinematics(grid)

        def _on_grid(t):
            t = np.asarray(t, float)
            k = np.rint(t / T).astype(int)
            return k if np.all(np.abs(k * T - t) < 1e-9) and np.all((k >= 0) & (k <= K)) else None

        def sat_state(t):
            k = _on_grid(t)
            if k is None:
                return orbit(t)
            return tuple(x[k] for x in sat_grid)

        def receiver_state(t):
            k = _on_grid(t)
            pos, vel, acc = flight.kinematics(np.asarray(t, float)) if k is None else (x[k] for x in rx_grid)
            shape = np.shape(t) + (runs, 3)
            return tuple(np.broadcast_to(np.asarray(x)[..., None, :], shape) for x in (pos, vel, acc))

        el0 = elevation_deg(sat_grid[0][0], rx_grid[0][0], p.lat_deg, p.lon_deg)  # (ch,) or (runs, ch)
        blocked = None
        if outage is not None:  # the lowest satellites at the start lose their signal (simulation.fade)
            from .deep_integration_runs import ChannelOutage

            n_out, start_s, end_s = outage
            mask = lowest_channels(np.broadcast_to(el0, (runs, p.channels)), n_out)
            blocked = ChannelOutage(mask, start_s, end_s)
        if p.cn0_model == "elevation":  # per channel, from the elevation at the start of the flight
            cn0 = np.broadcast_to(cn0_from_elevation(cn0_dbhz, el0), (runs, p.channels)).copy()
        else:
            cn0 = np.full((runs, p.channels), cn0_dbhz)
        range_error = None
        if p.range_residuals_on():  # errors of the truth the receiver's model lacks, from their own stream
            range_error = range_error_function(
                draw_residuals(p, draw.child(rng, "range-errors"), runs),
                sat_state,
                receiver_state,
                p.lat_deg,
                p.lon_deg,
            )
        return DeepTruth(
            sat_state,
            receiver_state,
            clock,
            cn0,
            T,
            receiver_positions=lambda t: receiver_state(t)[0],
            range_error_m=range_error,
            signal_gain=None if blocked is None else blocked.signal_gain(K, T),
        )

    # --- candidates ---------------------------------------------------------------------
    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        c = DeepIntegrationCase.model_validate(case)
        update = c.scenario_update(self.params)
        if update:  # the case's error sources: the same scenario with those parameters replaced
            plain = {"name": case.get("name"), "cn0_dbhz": case["cn0_dbhz"]}
            plain.update({k: case[k] for k in ("outage_channels", "outage_start_s", "outage_end_s") if k in case})
            return type(self)(self.params.model_copy(update=update)).run_batch(plain, plugins, runs, rng)
        rng = draw.as_run_streams(rng, runs)  # one stream per run: numbers independent of batching
        p = self.params
        kind = _kind(plugins)
        flight = self.flight()
        cn0 = float(case["cn0_dbhz"])
        truth = self._truth(flight, cn0, runs, rng, c.outage())
        outage = None
        if c.outage_channels is not None:  # the ideal detector's side: the channels the truth blocks
            from .deep_integration_runs import ChannelOutage

            blocked = np.any(truth.signal_gain == 0, axis=0)
            outage = ChannelOutage(blocked, c.outage_start_s, c.outage_end_s)
        lock = make_lock(p, outage)  # the receiver's verdicts: the ideal detector (the outage itself) or a C/N0 test
        n_upd = int(round(p.update_interval_s / p.coherent_time_s))
        if kind == "vector":
            out = self._run_vector(plugins, truth, runs, rng, lock)
        else:  # looked up when called: a script may wrap one (docs/deep_integration_nees_split.py)
            from . import deep_integration_runs

            run: deep_integration_runs.CandidateRun = getattr(deep_integration_runs, f"run_{kind}")
            out = run(self, plugins, flight, truth, runs, rng, lock)
        t_u = out["time_s"]
        pos_t, vel_t, _ = flight.kinematics(t_u)
        pos_t = np.broadcast_to(pos_t[:, None, :], out["position_m"].shape)
        vel_t = np.broadcast_to(vel_t[:, None, :], out["velocity_m_s"].shape)
        dp, dv = enu_errors(out["position_m"], pos_t, out["velocity_m_s"], vel_t)
        series = {
            "horizontal_position_error": np.linalg.norm(dp[..., :2], axis=-1),
            "height_error": np.abs(dp[..., 2]),
            "horizontal_velocity_error": np.linalg.norm(dv[..., :2], axis=-1),
            "vertical_velocity_error": np.abs(dv[..., 2]),
        }
        if "body_to_ned" in out:
            att = attitude_errors_deg(
                out["body_to_ned"], np.broadcast_to(flight.body_to_ned(t_u)[:, None], out["body_to_ned"].shape)
            )
            series["attitude_error"] = np.max(np.abs(att), axis=-1)
        else:
            series["attitude_error"] = np.full(dp.shape[:2], np.nan)
        # Tracking errors: RMS over channels and over the coherent intervals of each update interval.
        code, freq = out["code_error_chips"], out["freq_error_hz"]
        U = len(t_u)
        series["code_tracking_error"] = np.sqrt(
            np.mean(code[: U * n_upd].reshape(U, n_upd, runs, -1) ** 2, axis=(1, 3))
        )
        series["freq_tracking_error"] = np.sqrt(
            np.mean(freq[: U * n_upd].reshape(U, n_upd, runs, -1) ** 2, axis=(1, 3))
        )
        lol = loss_of_lock(code, freq, p.coherent_time_s)[: U * n_upd].reshape(U, n_upd, runs, -1)
        series["loss_of_lock"] = lol.mean(axis=(1, 3))
        if "phase_error_rad" in out:
            series.update(phase_lock_series(out["phase_error_rad"][: U * n_upd], n_upd, p.update_interval_s))
        else:  # undefined: no carrier loop
            for name in ("phase_tracking_error", "phase_unlocked", "cycle_slips"):
                series[name] = np.full((U, runs), np.nan)
        series["nees_pv"] = out["nees"]
        if p.lock_detector == "ideal":
            return evaluate(METRICS, series, t_u, self)
        series.update(lock_series(lock, t_u, truth.signal_gain, n_upd, code.shape[1:]))
        return evaluate(METRICS + LOCK_METRICS, series, t_u, self)

    def _run_vector(
        self, plugins, truth: DeepTruth, runs: int, rng: np.random.Generator, lock=None
    ) -> dict[str, np.ndarray]:
        """Vector tracking without INS (``run_vector_loop``), decimated to the integration grid.
        With ``lock`` verdicts, each interval's navigation update leaves out the channels they
        exclude: an outage's blocked channels by its end (`ScheduledExclusion`, the ideal lock
        detector ``loose`` and ``tight`` have) or a lock test's (`CN0LockDetector`, the loop's
        monitor); their replicas go on being steered by the navigation solution."""
        p = self.params
        T = p.coherent_time_s
        monitor = None
        if isinstance(lock, CN0LockDetector):  # the lock test on the prompts as the loop's monitor
            monitor = lock
        elif lock is not None:
            from ...receiver.engine.channel_monitor import ScheduledExclusion

            monitor = ScheduledExclusion(lambda k: lock.usable(k * T, T))
        vt = VectorTruth(
            lambda t: truth.sat_state(t)[:2],
            lambda t: truth.receiver_state(t)[:2],
            truth.clock_m,
            truth.cn0_dbhz,
            T,
            range_error_m=truth.range_error_m,
            signal_gain=truth.signal_gain,
        )
        std = np.array([p.initial_position_std_m] * 3 + [p.initial_velocity_std_m_s] * 3 + list(p.initial_clock_std_m))
        P0 = np.diag(std**2)
        x0 = vt.nav_truth(T / 2, 0) + draw.standard_normal(rng, (runs, 8), 0) * std
        rec = run_vector_loop(
            plugins["channel_filter"],
            plugins["nav_filter"],
            vt,
            x0,
            P0,
            rng,
            early_late_spacing_chips=p.early_late_spacing_chips,
            data_bits="none",
            monitor=monitor,
        )
        n_upd = int(round(p.update_interval_s / T))
        idx = np.arange(n_upd - 1, truth.epochs, n_upd)  # the interval ending at each update instant
        t_u = (idx + 1) * T
        # ekf-pv's estimate refers to the interval's middle; move it to the update instant with its velocity.
        true_mid_p, true_mid_v, _ = truth.receiver_state(rec.time_s[idx])
        pos = true_mid_p + rec.position_error_m[idx]
        vel = true_mid_v + rec.velocity_error_m_s[idx]
        pos = pos + vel * (T / 2)
        # ekf-pv's record keeps the position and velocity marginal NEES (3 + 3), not the joint one.
        nees_pv = rec.nees_position[idx] + rec.nees_velocity[idx]
        return {
            "time_s": t_u,
            "position_m": pos,
            "velocity_m_s": vel,
            "code_error_chips": rec.code_error_chips,
            "freq_error_hz": rec.freq_error_hz,
            "nees": nees_pv,
        }
