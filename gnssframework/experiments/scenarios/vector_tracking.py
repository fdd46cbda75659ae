"""Scenario ``vector-tracking``: the experiment of Zou et al. (2018) (adaptive CKF vector tracking).

GPS L1 C/A satellites of the nominal constellation, a static receiver (or one moving at
constant velocity, or a car on a figure-eight track), a receiver clock from h-parameters,
and N channels tracked in a vector loop: a channel filter per channel and one navigation
filter.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import pymap3d
from pydantic import Field, field_validator

from ... import random_streams as draw
from ...errors import ConfigError
from ...estimation.consistency import nees
from ...suggest import did_you_mean
from ...interfaces import RunContext
from ...io.text import check_input_file
from ...receiver.tracking.vector import (
    CHANNEL_OUTPUTS,
    NAV_OUTPUTS,
    VectorTruth,
    check_composition,
    run_vector_loop,
    smooth_record,
)
from ...signal.constants import SPEED_OF_LIGHT_M_S
from ...simulation.clock import PRESETS
from ...simulation.constellation import draw_epochs, nominal_constellation
from ...simulation.fade import CN0Fade, FadeCause, lowest_channels
from ...simulation.propagation import (
    cn0_from_elevation,
    draw_range_errors,
    elevation_deg,
    least_squares_fix_error,
    range_error_function,
)
from ...simulation.trajectory import FigureEight
from ..limits import SignalCoherentTime
from ..metric_components import IntegrityOutcome, Mean, Rmse, evaluate, undefined_reasons as _undefined_reasons, units
from . import BatchResult, Scenario, ScenarioParams, register_scenario

__all__ = [
    "VectorTrackingScenario",
    "SkyRealismParams",
    "METRICS",
    "steady_state_start_s",
    "draw_residuals",
    "BYTES_PER_EPOCH_RUN_CHANNEL",
]

#: Peak memory of the vector loop per epoch, run and channel (the recorded errors, NCO and
#: truth arrays), an upper bound: tests/experiments/test_limits.py holds it above the measured peak.
BYTES_PER_EPOCH_RUN_CHANNEL = 512
#: With ``smoothed``: the stored posteriors and the backward pass's arrays per epoch and run
#: (state, covariance, prediction, cross covariance, gain and smoothed covariance: about
#: six 8 x 8 matrices), an upper bound like the one above.
BYTES_PER_EPOCH_RUN_SMOOTHED = 4096


#: Receiver motions of the scenario (`VectorTrackingParams.motion`).
Motion = Literal["constant-velocity", "figure-eight"]


class SkyRealismParams(ScenarioParams):
    """Scenario options shared by the vector-tracking and deep-integration scenarios: C/N0
    from elevation, and range errors in the truth that the receiver's model lacks
    (`gnssframework.simulation.propagation`). All off by default."""

    cn0_model: Literal["constant", "elevation"] = Field(
        "constant",
        description="constant: every channel at the case's cn0_dbhz (dB-Hz). elevation: the case's "
        "cn0_dbhz is the zenith value and each channel loses the receiver antenna's attenuation towards its "
        "satellite at the start (gps-sdr-sim's gain pattern, Ebinuma 2015: 0 dB at zenith, 2.44 dB at 50 deg, "
        "7.56 dB at 10 deg; gnssframework.simulation.propagation). Default constant (references 000 "
        "and 002 state one C/N0 per case)",
    )
    iono_vertical_residual_std_m: float = Field(
        0.0,
        ge=0,
        le=50,
        description="standard deviation (m, L1) of the vertical ionospheric delay left after "
        "the receiver's model, one Gaussian value per run common to its channels and constant over the run, "
        "slant = the Klobuchar obliquity factor 1 + 16 (0.53 - E)^3 times it (IS-GPS-200 20.3.3.5.2.5); it "
        "delays the code and advances the carrier. Klobuchar (1987) removes about half the delay's RMS, so "
        "residuals of 1-5 m are common. Default 0 (off)",
    )
    tropo_zenith_residual_std_m: float = Field(
        0.0,
        ge=0,
        le=2,
        description="standard deviation (m) of the zenith tropospheric (wet) delay left after "
        "the receiver's model, one Gaussian value per run, constant, mapped by 1.001/sqrt(0.002001 + sin^2 E) "
        "(RTCA DO-229; UNB3, Collins 1999, leaves a few cm). Default 0 (off)",
    )
    orbit_clock_residual_std_m: float = Field(
        0.0,
        ge=0,
        le=20,
        description="SISRE (m): standard deviation of each satellite's broadcast orbit and "
        "clock error along its line of sight, one Gaussian value per satellite and run, constant over the run "
        "(GPS broadcast SISRE is below 1 m, Montenbruck et al. 2015). Default 0 (off)",
    )

    def range_residuals_on(self) -> bool:
        """Whether any range residual is switched on."""
        return bool(
            self.iono_vertical_residual_std_m or self.tropo_zenith_residual_std_m or self.orbit_clock_residual_std_m
        )


class VectorTrackingParams(SignalCoherentTime, SkyRealismParams):
    duration_s: float = Field(30.0, gt=0, le=3600)
    coherent_time_s: float = Field(
        0.01, description="T (s): whole 1 ms code periods, 1 to 20 ms; with 20 ms bits, 10 ms intervals stay in a bit"
    )
    channels: int = Field(8, ge=4, le=12)
    elevation_mask_deg: float = Field(10.0, ge=0, lt=90)
    start_time_s: float = Field(
        37800.0, ge=0, description="seconds into the constellation's day (with an ephemeris file: GPS seconds of week)"
    )
    ephemeris_file: str | None = Field(
        None,
        description="RINEX navigation file (broadcast ephemeris, read with "
        "georinex) instead of the nominal 24-slot constellation",
    )
    lat_deg: float = Field(34.23, ge=-90, le=90)
    lon_deg: float = Field(108.3576, ge=-180, le=360)
    height_m: float = 590.6
    velocity_enu_m_s: list[float] = Field(
        [0.0, 0.0, 0.0], min_length=3, max_length=3, description="constant receiver velocity, east/north/up"
    )
    motion: Motion = Field(
        "constant-velocity",
        description="constant-velocity: the receiver moves at velocity_enu_m_s (static by "
        "default). figure-eight: a vehicle on a figure-eight (lemniscate of Gerono) in the local horizontal plane "
        "from lat_deg, lon_deg, height_m: east = A sin(wt), north = A/2 sin(2wt), A = figure_eight_half_length_m, "
        "w = 2 pi / figure_eight_lap_s (gnssframework.simulation.trajectory.FigureEight): speed 0.66 A w to "
        "1.41 A w, acceleration up to 17/8 A w^2 (defaults: 5.2-11.1 m/s, up to 5.2 m/s^2), turning right round the "
        "east lobe, then left. A case's motion overrides it",
    )
    figure_eight_half_length_m: float = Field(
        25.0, gt=0, le=10000, description="A (m): half the figure-eight's east-west extent"
    )
    figure_eight_lap_s: float = Field(20.0, ge=1, le=3600, description="time (s) of one lap of the figure-eight")
    trajectory_file: str | None = Field(
        None,
        description="CSV trajectory (t_s and ECEF x_m,y_m,z_m or "
        "lat_deg,lon_deg,height_m) replacing the static/constant-velocity receiver",
    )
    clock: str = Field("ocxo", description="receiver clock preset: tcxo or ocxo")
    early_late_spacing_chips: float = Field(1.0, gt=0, le=1.0)
    data_bits: Literal["none", "known", "unknown"] = "known"
    initial_position_std_m: float = Field(3.0, gt=0)
    initial_velocity_std_m_s: float = Field(0.3, gt=0)
    initial_fix: Literal["independent", "least-squares"] = Field(
        "independent",
        description="independent: the nav filter's initial estimate is the truth plus Gaussian errors of "
        "initial_position_std_m and initial_velocity_std_m_s, independent of the range residuals. least-squares: "
        "plus the position and clock error the range residuals make in a least-squares fix from the first "
        "epoch's pseudoranges (gnssframework.simulation.propagation.least_squares_fix_error), as a receiver's "
        "first fix from the same ranges starts its filter. The same as independent with no residual on",
    )
    settle_s: float = Field(1.0, ge=0, description="metrics ignore the first settle_s seconds")
    pcrb: bool | None = Field(
        None,
        description="compute the posterior Cramér-Rao bound (pcrb_position, "
        "pcrb_velocity) and the same bound from the code alone (pcrb_position_code, "
        "pcrb_velocity_code); it assumes a static or constant-velocity receiver and one geometry. "
        "null: yes, unless a trajectory_file or a figure-eight motion is given (in a case: "
        "not for that case) or geometry is per-run",
    )
    steady_state_s: float | None = Field(
        None,
        ge=0,
        description="position_steady_error_rmse counts from this "
        "time on (after the nav filter's position has converged); null: a third "
        "of the run, at least settle_s",
    )
    geometry: Literal["fixed", "per-run"] = Field(
        "fixed",
        description="fixed: every run sees the satellites at start_time_s. per-run: each run draws its "
        "start epoch from its own stream, uniform over the nominal constellation's sidereal day (86164.1 s) among "
        "the epochs with `channels` satellites above the mask, and tracks the highest ones then (no PCRB). "
        "Default fixed",
    )
    integrity_risk: float = Field(
        1e-7,
        gt=0,
        lt=1,
        description="fault-free integrity risk of the protection levels hpl_m, vpl_m, computed "
        "each epoch from the nav filter's position covariance in east, north, up "
        "(gnssframework.navigation.integrity.covariance_protection_levels: VPL = Q^-1(I/2) sigma_U, "
        "HPL = sqrt(-2 ln I) sqrt(lambda_max(C_EN))); they bound the error only as far as that covariance is "
        "honest and no fault is left in. Default 1e-7",
    )
    innovation_false_alarm: float | None = Field(
        None,
        gt=0,
        lt=1,
        description="record the nav filter's normalised innovation squared (metric nis_per_dof) "
        "and test it at this false-alarm probability (metric innovation_alarm_fraction: an epoch alarms where the "
        "statistic of the channels in the update exceeds its chi-square quantile 1 - this; "
        "gnssframework.navigation.filter_integrity.innovation_test); one batched solve per epoch. Null (default): "
        "not recorded",
    )
    smoothed: bool = Field(
        False,
        description="also score the nav filter's fixed-interval RTS-smoothed estimates "
        "(position_smoothed_error_rmse, velocity_smoothed_error_rmse, nees_position_smoothed): every epoch's "
        "posterior is kept (576 bytes per epoch and run, more for the backward pass) and smoothed after the run "
        "with the filter's transition(T) (gnssframework.receiver.tracking.vector.smooth_record); needs a nav "
        "filter whose prediction is linear on its 8 published states (ekf-pv). Default false",
    )
    horizontal_alert_limit_m: float = Field(
        40.0,
        gt=0,
        description="horizontal alert limit (m) of the integrity metrics: an epoch is available "
        "where HPL < it, hazardously misleading where HPL < it < the horizontal error. Default 40 (LPV-200, "
        "ICAO Annex 10)",
    )
    vertical_alert_limit_m: float = Field(
        35.0,
        gt=0,
        description="vertical alert limit (m), as horizontal_alert_limit_m for VPL and the vertical "
        "error. Default 35 (LPV-200, ICAO Annex 10)",
    )

    @field_validator("ephemeris_file", "trajectory_file")
    @classmethod
    def _regular_file(cls, path: str | None) -> str | None:
        """Refuse a missing file, a device (/dev/zero) or a FIFO when the config loads."""
        if path is not None:
            check_input_file(path)  # its DataFileError (a ValueError) names the file after the field
        return path


class VectorTrackingCase(ScenarioParams):
    name: str | None = None
    cn0_dbhz: float = Field(..., ge=15, le=60)
    motion: Motion | None = Field(
        None, description="the receiver's motion in this case (default: the scenario's motion)"
    )
    fade_depth_db: float = Field(
        0.0,
        ge=0,
        le=30,
        description="a C/N0 fade in the truth only: the correlators' C/N0 drops by this many dB "
        "(gnssframework.simulation.fade.CN0Fade) from fade_start_s for fade_duration_s on fade_channels, while "
        "the channel filters are still given the case's cn0_dbhz (what the receiver knew before the fade). "
        "Default 0 (off)",
    )
    fade_start_s: float = Field(
        0.0,
        ge=0,
        description="start (s) of the fade: intervals whose middle lies in "
        "[fade_start_s, fade_start_s + fade_duration_s) are faded",
    )
    fade_duration_s: float | None = Field(None, gt=0, description="length (s) of the fade; null: to the end of the run")
    fade_channels: int | None = Field(
        None,
        ge=1,
        le=12,
        description="how many channels the fade shadows: "
        "the lowest ones at the start of each run (an obstruction near the horizon, "
        "trees or a building, shadows the low satellites first); null: all",
    )
    fade_cause: FadeCause = Field(
        "attenuation",
        description="attenuation: the signal loses fade_depth_db and the correlator noise is "
        "unchanged (foliage or a building; also what any cause looks like to a receiver that scales its "
        "correlators to a known noise level). noise-floor: the noise density rises by fade_depth_db at a fixed "
        "front-end gain and the signal is unchanged (in-band interference: every channel, so fade_channels must "
        "be null)",
    )

    fault_channel: int | None = Field(
        None,
        ge=0,
        le=11,
        description="a range fault in the truth only, on this channel (0: the first of the "
        "satellites above the mask; null: no fault): from fault_start_s, the channel's code range gains "
        "fault_step_m plus fault_ramp_m_s per second since the start (its carrier unchanged: a multipath-like or "
        "spoofed code delay the receiver's model lacks). Default null (off)",
    )
    fault_start_s: float = Field(0.0, ge=0, description="start (s) of the fault")
    fault_step_m: float = Field(0.0, ge=-3000, le=3000, description="code range step (m) of the fault")
    fault_ramp_m_s: float = Field(0.0, ge=-300, le=300, description="code range ramp (m/s) of the fault")

    def fault(self) -> tuple[int, float, float, float] | None:
        """``(channel, start_s, step_m, ramp_m_s)`` of the case's fault, or None."""
        if self.fault_channel is None:
            return None
        return self.fault_channel, self.fault_start_s, self.fault_step_m, self.fault_ramp_m_s

    def fade(self) -> CN0Fade | None:
        """The case's fade, or None when ``fade_depth_db`` is 0."""
        if not self.fade_depth_db:
            return None
        return CN0Fade(self.fade_depth_db, self.fade_start_s, self.fade_duration_s, self.fade_cause)


def draw_residuals(p: SkyRealismParams, rng: Any, runs: int):
    """Each run's range residuals (`gnssframework.simulation.propagation.draw_range_errors`)
    at the magnitudes of the scenario options ``p``."""
    return draw_range_errors(
        rng,
        runs,
        p.channels,
        iono_vertical_std_m=p.iono_vertical_residual_std_m,
        tropo_zenith_std_m=p.tropo_zenith_residual_std_m,
        sisre_m=p.orbit_clock_residual_std_m,
    )


def steady_state_start_s(scenario: Any) -> float:
    """Where ``position_steady_error_rmse`` starts counting (s): ``steady_state_s``, or a
    third of the run (at least ``settle_s``)."""
    p = scenario.params
    return p.steady_state_s if p.steady_state_s is not None else max(p.settle_s, p.duration_s / 3)


#: The scenario's metrics, each declared once as a component (name, unit, the series it
#: reduces); ``run_batch`` computes them all once with `evaluate`. Errors become RMS over
#: the epochs from ``settle_s`` on; NEES means over the same epochs (a consistent filter
#: averages the dimension: 8, 3 and 3); the bounds their RMS over the same window.
#: ``code_output_rmse`` and ``freq_output_rmse`` are the errors of what the channel
#: filters hand the nav filter (the quantity Zou et al. 2018 plot as code and frequency error).
#: Why a case has no bound (its metrics are then undefined rather than absent); the same for
#: the code-and-carrier and the code-only bound, computed together.
_NO_BOUND = "no bound for this case: a moving receiver, a per-run geometry, a trajectory file or a C/N0 fade"
_NOT_SMOOTHED = "not smoothed: set scenario.smoothed = true"
_NO_NIS = (
    "no innovation test: set scenario.innovation_false_alarm (and a nav filter that keeps its last_step, as ekf-pv)"
)

METRICS = (
    Rmse(
        "code_phase_error_rmse",
        "chips",
        of="code_error_chips",
        settle="settle_s",
        description="RMS code phase error of the channels' estimates",
    ),
    Rmse(
        "carrier_freq_error_rmse",
        "Hz",
        of="freq_error_hz",
        settle="settle_s",
        description="RMS carrier frequency error of the channels' estimates",
    ),
    Rmse("position_error_rmse", "m", of="position_error_m", settle="settle_s", description="RMS position error"),
    Rmse("velocity_error_rmse", "m/s", of="velocity_error_m_s", settle="settle_s", description="RMS velocity error"),
    Rmse(
        "position_steady_error_rmse",
        "m",
        of="position_error_m",
        settle=steady_state_start_s,
        description="RMS position error from steady_state_s on",
    ),
    Mean("nees", "-", of="nav_nees", settle="settle_s", description="mean NEES of the 8 nav states"),
    Mean("nees_position", "-", of="nav_nees_position", settle="settle_s", description="mean NEES of the position"),
    Mean("nees_velocity", "-", of="nav_nees_velocity", settle="settle_s", description="mean NEES of the velocity"),
    Rmse(
        "code_output_rmse",
        "chips",
        of="code_output_error_chips",
        settle="settle_s",
        description="RMS error of the code measurement handed to the nav filter",
    ),
    Rmse(
        "freq_output_rmse",
        "Hz",
        of="freq_output_error_hz",
        settle="settle_s",
        description="RMS error of the frequency measurement handed to the nav filter",
    ),
    Mean(
        "excluded_channels",
        "-",
        of="excluded_channel_count",
        settle="settle_s",
        description="mean number of channels the channel monitor excludes from the navigation update (0 without "
        "a monitor: scenario_options.channel_monitor)",
    ),
    Mean(
        "hpl_mean",
        "m",
        of="hpl_m",
        settle="settle_s",
        description="mean horizontal protection level of the nav filter's covariance at integrity_risk",
    ),
    Mean(
        "vpl_mean",
        "m",
        of="vpl_m",
        settle="settle_s",
        description="mean vertical protection level of the nav filter's covariance at integrity_risk",
    ),
    *(
        IntegrityOutcome(
            f"{axis}_{outcome}_fraction",
            of=f"{axis}_error_m",
            level=f"{axis[0]}pl_m",
            outcome=outcome,
            alert_limit=f"{axis}_alert_limit_m",
            settle="settle_s",
            description=text,
        )
        for axis in ("horizontal", "vertical")
        for outcome, text in (
            ("misleading", f"fraction of epochs with misleading information: {axis} error > {axis[0].upper()}PL"),
            (
                "hazardous",
                f"fraction of epochs with hazardously misleading information: {axis[0].upper()}PL < "
                f"{axis}_alert_limit_m < {axis} error",
            ),
            ("available", f"fraction of epochs available: {axis[0].upper()}PL < {axis}_alert_limit_m"),
        )
    ),
    Mean(
        "nis_per_dof",
        "-",
        of="nav_nis_per_dof",
        settle="settle_s",
        optional=True,
        undefined=_NO_NIS,
        description="mean normalised innovation squared of the nav filter's update per degree of freedom (1 for "
        "white innovations of the covariance the filter predicts)",
    ),
    Mean(
        "innovation_alarm_fraction",
        "-",
        of="innovation_alarm",
        settle="settle_s",
        optional=True,
        undefined=_NO_NIS,
        description="fraction of epochs whose nav-filter innovation test alarms at "
        "innovation_false_alarm (that probability for white Gaussian innovations)",
    ),
    Rmse(
        "position_smoothed_error_rmse",
        "m",
        of="position_smoothed_error_m",
        settle="settle_s",
        optional=True,
        undefined=_NOT_SMOOTHED,
        description="RMS position error of the RTS-smoothed estimates (smoothed = true)",
    ),
    Rmse(
        "velocity_smoothed_error_rmse",
        "m/s",
        of="velocity_smoothed_error_m_s",
        settle="settle_s",
        optional=True,
        undefined=_NOT_SMOOTHED,
        description="RMS velocity error of the RTS-smoothed estimates (smoothed = true)",
    ),
    Mean(
        "nees_position_smoothed",
        "-",
        of="nav_nees_position_smoothed",
        settle="settle_s",
        optional=True,
        undefined=_NOT_SMOOTHED,
        description="mean NEES of the smoothed position on its smoothed covariance (smoothed = true)",
    ),
    Rmse(
        "pcrb_position",
        "m",
        of="pcrb_position_m",
        settle="settle_s",
        optional=True,
        undefined=_NO_BOUND,
        description="posterior Cramér-Rao bound of the position error (RMS over the same window)",
    ),
    Rmse(
        "pcrb_velocity",
        "m/s",
        of="pcrb_velocity_m_s",
        settle="settle_s",
        optional=True,
        undefined=_NO_BOUND,
        description="posterior Cramér-Rao bound of the velocity error (RMS over the same window)",
    ),
    Rmse(
        "pcrb_position_code",
        "m",
        of="pcrb_position_code_m",
        settle="settle_s",
        optional=True,
        undefined=_NO_BOUND,
        description="posterior Cramér-Rao bound of the position error from the code alone (no carrier phase)",
    ),
    Rmse(
        "pcrb_velocity_code",
        "m/s",
        of="pcrb_velocity_code_m_s",
        settle="settle_s",
        optional=True,
        undefined=_NO_BOUND,
        description="posterior Cramér-Rao bound of the velocity error from the code alone (no carrier phase)",
    ),
)


class ChannelMonitorParams(ScenarioParams):
    """`gnssframework.receiver.engine.channel_monitor.ChannelMonitor`'s settings."""

    false_alarm: float = Field(
        1e-3,
        gt=0,
        lt=1,
        description="probability that a healthy channel's interval "
        "fails the innovation test (chi-square, 1 degree of freedom)",
    )
    consecutive: int = Field(
        3, ge=1, le=1000, description="failed intervals in a row that exclude a channel from the navigation update"
    )
    readmit: int | None = Field(
        None, ge=1, le=100000, description="passed intervals in a row that readmit it (null: consecutive)"
    )

    def create(self):
        from ...receiver.engine.channel_monitor import ChannelMonitor

        return ChannelMonitor(self.false_alarm, self.consecutive, self.readmit)


class VectorCandidateOptions(ScenarioParams):
    """A candidate's ``scenario_options`` in ``vector-tracking``."""

    channel_monitor: ChannelMonitorParams | None = Field(
        None,
        description="screen each channel's innovation and exclude a faulty channel from the navigation "
        "update (gnssframework.receiver.engine.channel_monitor); null: every channel always used",
    )


@register_scenario
class VectorTrackingScenario(Scenario):
    """Vector tracking (Zou et al. 2018). Candidates compose a ``channel_filter`` and a ``nav_filter``."""

    kind = "vector-tracking"
    Params = VectorTrackingParams
    params: VectorTrackingParams  # self.params, as validated
    CaseParams = VectorTrackingCase
    components = {"channel_filter": True, "nav_filter": True}
    CandidateOptions = VectorCandidateOptions
    metrics = units(METRICS)
    #: Why a metric can be undefined (NaN) in a run: no bound, or not smoothed.
    undefined_reasons = _undefined_reasons(METRICS)
    #: The raw per-epoch series the metrics reduce (metric components of other packages
    #: may read them too): code and frequency errors RMS over the channels, position and
    #: velocity error norms, the horizontal and vertical position errors (at the true
    #: position) and the protection levels of the nav filter's covariance (at
    #: ``integrity_risk``), the channels the monitor excluded (with one), the per-epoch NEES,
    #: the smoothed errors and NEES (with ``smoothed``), and the bound (if computed).
    outputs = {
        "code_error_chips": "chips",
        "freq_error_hz": "Hz",
        "position_error_m": "m",
        "velocity_error_m_s": "m/s",
        "excluded_channel_count": "-",
        "nav_nees": "-",
        "nav_nees_position": "-",
        "nav_nees_velocity": "-",
        "horizontal_error_m": "m",
        "vertical_error_m": "m",
        "hpl_m": "m",
        "vpl_m": "m",
        "position_smoothed_error_m": "m",
        "velocity_smoothed_error_m_s": "m/s",
        "nav_nees_position_smoothed": "-",
        "nav_nis_per_dof": "-",
        "innovation_alarm": "-",
        "code_output_error_chips": "chips",
        "freq_output_error_hz": "Hz",
        "pcrb_position_m": "m",
        "pcrb_velocity_m_s": "m/s",
        "pcrb_position_code_m": "m",
        "pcrb_velocity_code_m_s": "m/s",
    }
    #: Error metric -> the bound drawn beside it in the report's time-series plot.
    bounds = {"position_error_rmse": "pcrb_position", "velocity_error_rmse": "pcrb_velocity"}

    def __init__(self, params: VectorTrackingParams) -> None:
        super().__init__(params)
        if params.clock not in PRESETS:
            raise ConfigError(
                "scenario.clock",
                f"got {params.clock!r}; allowed: {', '.join(PRESETS)}{did_you_mean(params.clock, PRESETS)}",
            )
        if params.pcrb is True and params.trajectory_file:
            raise ConfigError(
                "scenario.pcrb",
                "the bound assumes a static or constant-velocity receiver; set pcrb = false with a trajectory_file",
            )
        if params.geometry == "per-run" and params.ephemeris_file:
            raise ConfigError(
                "scenario.geometry",
                "per-run geometry draws epochs over the nominal constellation's "
                'day; a broadcast ephemeris holds only near its Toe: use geometry = "fixed"',
            )
        if params.geometry == "per-run" and params.pcrb:
            raise ConfigError(
                "scenario.pcrb", 'the bound is computed for one geometry; set pcrb = false with geometry = "per-run"'
            )
        self._check_motion(params.motion, "scenario.motion")
        if params.steady_state_s is not None and not params.settle_s <= params.steady_state_s < params.duration_s:
            raise ConfigError(
                "scenario.steady_state_s",
                f"must be at least settle_s = {params.settle_s} and less "
                f"than duration_s = {params.duration_s} (got {params.steady_state_s})",
            )

    def _check_case_before_fault(self, case: dict[str, Any], where: str) -> None:
        """The case's motion and fade (`check_case` adds the fault's checks)."""
        super().check_case(case, where)
        if case.get("motion") is not None:
            self._check_motion(case["motion"], f"{where}.motion")
        self._check_fade(self.CaseParams.model_validate(case), where)

    def _check_fade(self, c: VectorTrackingCase, where: str) -> None:
        """Refuse fade settings that do nothing or cannot be met."""
        p = self.params
        given = [
            f for f in ("fade_start_s", "fade_duration_s", "fade_channels", "fade_cause") if f in c.model_fields_set
        ]
        if not c.fade_depth_db:
            if given:
                raise ConfigError(f"{where}.{given[0]}", "has no effect without a fade: set fade_depth_db > 0")
            return
        if c.fade_start_s >= p.duration_s:
            raise ConfigError(
                f"{where}.fade_start_s", f"must be below duration_s = {p.duration_s} (got {c.fade_start_s})"
            )
        if c.fade_channels is not None and c.fade_channels > p.channels:
            raise ConfigError(f"{where}.fade_channels", f"at most channels = {p.channels} (got {c.fade_channels})")
        if c.fade_cause == "noise-floor" and c.fade_channels is not None:
            raise ConfigError(
                f"{where}.fade_channels",
                "a noise-floor rise is in the front end, common to every channel: leave fade_channels unset (null)",
            )
        if p.pcrb:
            raise ConfigError(
                "scenario.pcrb",
                f"the bound is computed at the nominal C/N0; set pcrb = false with a C/N0 fade ({where}.fade_depth_db)",
            )

    def _check_motion(self, motion: str, field: str) -> None:
        """Refuse a figure-eight beside another definition of the receiver's motion, or with
        the bound (which assumes constant velocity)."""
        p = self.params
        if motion != "figure-eight":
            return
        if p.trajectory_file:
            raise ConfigError(field, "a figure-eight replaces the trajectory_file's receiver; give one or the other")
        if any(p.velocity_enu_m_s):
            raise ConfigError(
                field, "the figure-eight sets the receiver's velocity; leave velocity_enu_m_s at [0, 0, 0]"
            )
        if p.pcrb:
            raise ConfigError(
                "scenario.pcrb",
                "the bound assumes a static or constant-velocity receiver; set pcrb = false with a figure-eight motion",
            )

    def batch_memory(self, case: dict[str, Any], runs: int, where: str, candidates=()) -> tuple[float, str, str]:
        p = self.params
        epochs = int(round(p.duration_s / p.coherent_time_s))
        smoothing = BYTES_PER_EPOCH_RUN_SMOOTHED * epochs * runs if p.smoothed else 0
        return (
            BYTES_PER_EPOCH_RUN_CHANNEL * epochs * runs * p.channels + smoothing,
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
            check_composition(plugins["channel_filter"], plugins["nav_filter"])
        except ConfigError as exc:
            outputs = CHANNEL_OUTPUTS if exc.field == "channel_filter" else NAV_OUTPUTS
            raise self.refuse(exc, where, outputs) from None
        if self.params.smoothed:
            nav = plugins["nav_filter"]
            F = np.asarray(nav.transition(self.params.coherent_time_s)[0]) if hasattr(nav, "transition") else None
            if F is None or F.shape != (8, 8):
                raise ConfigError(
                    f"{where}.nav_filter",
                    f"scenario.smoothed needs a nav filter whose prediction is "
                    f"linear on its 8 published states, with transition(T) (ekf-pv); "
                    f"{getattr(nav, 'name', '?')!r} has " + ("none" if F is None else f"{F.shape[0]} states"),
                )

    def build(
        self, candidate: dict[str, Any], options: dict[str, Any] | None = None, case: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        """The candidate's plugins, and its channel monitor under ``"channel_monitor"`` if it has one."""
        plugins = super().build(candidate, case=case)
        monitor = self.candidate_options(options).channel_monitor
        return plugins if monitor is None else {**plugins, "channel_monitor": monitor}

    def truth(
        self,
        cn0_dbhz: float,
        runs: int,
        rng: np.random.Generator,
        motion: str | None = None,
        fade: CN0Fade | None = None,
        fade_channels: int | None = None,
        fault: tuple[int, float, float, float] | None = None,
    ) -> tuple[VectorTruth, np.ndarray, np.ndarray]:
        """The truth of ``runs`` runs at ``cn0_dbhz``: satellites, receiver (``motion``,
        default the scenario's), clock and C/N0 (with ``fade`` on the ``fade_channels``
        lowest channels, None: all), with ``fault`` (`VectorTrackingCase.fault`) on one
        channel's code range; and the nav filter's initial estimate and covariance."""
        p = self.params
        motion = motion or p.motion
        traj = None
        lat, lon, height = p.lat_deg, p.lon_deg, p.height_m
        if p.trajectory_file:
            from ...simulation.trajectory import load_trajectory

            traj = load_trajectory(p.trajectory_file)
            lat, lon, height = pymap3d.ecef2geodetic(*traj.position_m[0])  # satellites seen from the start
        if p.ephemeris_file:
            from ...simulation.ephemeris import load_rinex_nav

            const = load_rinex_nav(p.ephemeris_file, t_s=p.start_time_s)
        else:
            const = nominal_constellation()
        if p.geometry == "per-run":  # each run its own epoch, from its own stream
            start_s, index = draw_epochs(
                const, draw.child(rng, "geometry"), runs, lat, lon, height, p.elevation_mask_deg, p.channels
            )
            sats = const.subset(index)
            start = start_s[:, None]  # (runs, 1) against the satellites (runs, ch)
        else:
            sats = const.subset(const.visible(p.start_time_s, lat, lon, height, p.elevation_mask_deg, p.channels))
            start = p.start_time_s
        r0 = np.array(pymap3d.geodetic2ecef(p.lat_deg, p.lon_deg, p.height_m))
        v = np.array(pymap3d.enu2uvw(*p.velocity_enu_m_s, p.lat_deg, p.lon_deg))
        T = p.coherent_time_s
        K = int(round(p.duration_s / T))
        bias_s, drift = PRESETS[p.clock].simulate(K + 1, T, rng, (runs,))
        clock = np.stack([bias_s, drift], -1) * SPEED_OF_LIGHT_M_S

        if p.geometry == "per-run":

            def sat_state(t):  # (*t.shape, runs, ch, 3)
                pos, vel, _ = sats.state_at(start + np.asarray(t, float)[..., None, None])
                return pos, vel
        else:

            def sat_state(t):
                pos, vel, _ = sats.state(start + np.asarray(t))
                return pos, vel

        if motion == "figure-eight":
            eight = FigureEight(p.figure_eight_half_length_m, p.figure_eight_lap_s)
            # Columns: the east, north and up unit vectors in ECEF at the start.
            enu_to_ecef = np.stack(pymap3d.enu2uvw(*np.eye(3), p.lat_deg, p.lon_deg), axis=0)

            def receiver_state(t):
                t = np.asarray(t, dtype=float)
                pos, vel, _ = eight.enu(t)
                shape = t.shape + (runs, 3)
                return (
                    np.broadcast_to((r0 + pos @ enu_to_ecef.T)[..., None, :], shape),
                    np.broadcast_to((vel @ enu_to_ecef.T)[..., None, :], shape),
                )
        elif traj is not None:

            def receiver_state(t):
                pos, vel = traj.state(t)
                shape = np.shape(t) + (runs, 3)
                return np.broadcast_to(pos[..., None, :], shape), np.broadcast_to(vel[..., None, :], shape)
        else:

            def receiver_state(t):
                t = np.asarray(t, dtype=float)
                shape = t.shape + (runs, 3)
                return np.broadcast_to(r0 + t[..., None, None] * v, shape), np.broadcast_to(v, shape)

        def start_elevations() -> np.ndarray:
            # Elevations at the start, (runs, ch): satellites shared (ch, 3) or per run (runs, ch, 3).
            return elevation_deg(sat_state(np.asarray(0.0))[0], receiver_state(np.asarray(0.0))[0], lat, lon)

        if p.cn0_model == "elevation":
            cn0 = cn0_from_elevation(cn0_dbhz, start_elevations())
        else:
            cn0 = np.full((runs, p.channels), cn0_dbhz)
        gains = {}
        if fade is not None:  # in the correlators only: the channel filters keep the nominal cn0
            faded = lowest_channels(np.broadcast_to(start_elevations(), (runs, p.channels)), fade_channels)
            gains = dict(zip(("signal_gain", "noise_gain"), fade.gains(np.arange(K) * T + T / 2, faded)))
        range_error = None
        fix_error = np.zeros((runs, 8))
        if p.range_residuals_on():
            range_error = range_error_function(
                draw_residuals(p, draw.child(rng, "range-errors"), runs), sat_state, receiver_state, lat, lon
            )
            if p.initial_fix == "least-squares":  # the first fix's error from the same residuals
                t0 = np.asarray(T / 2)
                dx = least_squares_fix_error(range_error(t0)[0], sat_state(t0)[0], receiver_state(t0)[0])
                fix_error[:, 0:3], fix_error[:, 6] = dx[..., 0:3], dx[..., 3]
        if fault is not None:
            range_error = _with_fault(range_error, fault, runs, p.channels)
        truth = VectorTruth(sat_state, receiver_state, clock, cn0, T, range_error_m=range_error, **gains)
        P0 = np.diag(
            [p.initial_position_std_m**2] * 3
            + [p.initial_velocity_std_m_s**2] * 3
            + [p.initial_position_std_m**2, p.initial_velocity_std_m_s**2]
        )
        x0 = truth.nav_truth(T / 2, 0) + draw.standard_normal(rng, (runs, 8), 0) @ np.sqrt(P0) + fix_error
        return truth, x0, P0

    def assumption_context(self, case):
        return {"coherent_time_s": self.params.coherent_time_s, "cn0_dbhz": float(case["cn0_dbhz"])}

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        series, rec = self.vector_series(case, plugins, runs, rng)
        return evaluate(METRICS, series, rec.time_s, self)

    def vector_series(self, case, plugins, runs, rng) -> tuple[dict[str, np.ndarray], Any]:
        """Run the vector loop over ``runs`` runs of ``case``: the raw series the metrics
        reduce, and the loop's `VectorRecord` (per-channel errors)."""
        rng = draw.as_run_streams(rng, runs)  # one stream per run: numbers independent of batching
        p = self.params
        motion = case.get("motion") or p.motion
        c = self.CaseParams.model_validate(case)
        truth, x0, P0 = self.truth(float(case["cn0_dbhz"]), runs, rng, motion, c.fade(), c.fade_channels, c.fault())
        monitor = plugins.get("channel_monitor")
        rec = run_vector_loop(
            plugins["channel_filter"],
            plugins["nav_filter"],
            truth,
            x0,
            P0,
            rng,
            early_late_spacing_chips=p.early_late_spacing_chips,
            data_bits=p.data_bits,
            monitor=None if monitor is None else monitor.create(),
            integrity_risk=p.integrity_risk,
            store_estimates=p.smoothed,
            innovations=p.innovation_false_alarm is not None,
        )
        last_s = rec.time_s[-1]
        if not (p.settle_s <= last_s and steady_state_start_s(self) <= last_s):
            raise ConfigError(
                "scenario.settle_s",
                f"settle_s = {p.settle_s} and steady_state_s = "
                f"{steady_state_start_s(self)} must be below the run's last epoch at {last_s:.3f} s",
            )

        def channel_rms(x: np.ndarray) -> np.ndarray:  # (K, runs, channels) -> (K, runs)
            return np.sqrt(np.mean(x**2, axis=-1))

        series = {
            "code_error_chips": channel_rms(rec.code_error_chips),
            "freq_error_hz": channel_rms(rec.freq_error_hz),
            "position_error_m": np.linalg.norm(rec.position_error_m, axis=-1),
            "velocity_error_m_s": np.linalg.norm(rec.velocity_error_m_s, axis=-1),
            "nav_nees": rec.nees,
            "nav_nees_position": rec.nees_position,
            "nav_nees_velocity": rec.nees_velocity,
            "code_output_error_chips": channel_rms(rec.code_output_error_chips),
            "freq_output_error_hz": channel_rms(rec.freq_output_error_hz),
            # East-north-up at the true position, and the covariance's protection levels.
            "horizontal_error_m": np.hypot(rec.position_error_enu_m[..., 0], rec.position_error_enu_m[..., 1]),
            "vertical_error_m": np.abs(rec.position_error_enu_m[..., 2]),
            "hpl_m": rec.hpl_m,
            "vpl_m": rec.vpl_m,
        }
        if rec.nis is not None and rec.nis_dof is not None and p.innovation_false_alarm is not None:
            from scipy.stats import chi2

            series["nav_nis_per_dof"] = rec.nis / np.maximum(rec.nis_dof, 1)
            series["innovation_alarm"] = (rec.nis > chi2.isf(p.innovation_false_alarm, rec.nis_dof)).astype(float)
        if p.smoothed:  # the RTS pass over the stored posteriors, with the filter's own transition
            pos_s, vel_s, cov_s = smooth_record(rec, plugins["nav_filter"].transition(p.coherent_time_s), x0, P0)
            series["position_smoothed_error_m"] = np.linalg.norm(pos_s, axis=-1)
            series["velocity_smoothed_error_m_s"] = np.linalg.norm(vel_s, axis=-1)
            series["nav_nees_position_smoothed"] = nees(pos_s, cov_s[..., 0:3, 0:3])
        # Without a channel monitor no channel is ever excluded: 0, so candidates with and
        # without one pair on this metric too.
        series["excluded_channel_count"] = (
            rec.extra["excluded"].sum(axis=-1).astype(float)
            if "excluded" in rec.extra
            else np.zeros_like(series["position_error_m"])
        )
        if p.pcrb or (
            p.pcrb is None
            and not p.trajectory_file
            and p.geometry == "fixed"
            and motion == "constant-velocity"
            and c.fade() is None
            and c.fault() is None
        ):
            _, bound_pos, bound_vel = self.bound(float(case["cn0_dbhz"]), P0)
            series["pcrb_position_m"] = np.repeat(bound_pos[:, None], runs, axis=1)
            series["pcrb_velocity_m_s"] = np.repeat(bound_vel[:, None], runs, axis=1)
            # The code-only bound (carrier phase dropped): what the carrier adds (11 ms a batch).
            _, bound_pos, bound_vel = self.bound(float(case["cn0_dbhz"]), P0, "code")
            series["pcrb_position_code_m"] = np.repeat(bound_pos[:, None], runs, axis=1)
            series["pcrb_velocity_code_m_s"] = np.repeat(bound_vel[:, None], runs, axis=1)
        return series, rec

    def check_case(self, case: dict[str, Any], where: str) -> None:
        self._check_case_before_fault(case, where)
        c = self.CaseParams.model_validate(case)
        given = [f for f in ("fault_start_s", "fault_step_m", "fault_ramp_m_s") if f in c.model_fields_set]
        if c.fault_channel is None:
            if given:
                raise ConfigError(f"{where}.{given[0]}", "has no effect without a fault: set fault_channel")
            return
        if c.fault_channel >= self.params.channels:
            raise ConfigError(
                f"{where}.fault_channel", f"must be below channels = {self.params.channels} (got {c.fault_channel})"
            )
        if not (c.fault_step_m or c.fault_ramp_m_s):
            raise ConfigError(f"{where}.fault_step_m", "a fault needs fault_step_m or fault_ramp_m_s")
        if self.params.pcrb:
            raise ConfigError("scenario.pcrb", f"the bound knows no fault; set pcrb = false with {where}.fault_channel")

    def bound(
        self, cn0_dbhz: float, P0: np.ndarray, measurements: str = "code-and-carrier"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The PCRB of this scenario at ``cn0_dbhz`` (`gnssframework.receiver.tracking.pcrb.vector_tracking_pcrb`)
        from ``measurements`` (``"code-and-carrier"`` or ``"code"``): times, RMS position bound (m) and RMS
        velocity bound (m/s), each ``(K,)``."""
        from ...receiver.tracking.pcrb import vector_tracking_pcrb

        p = self.params
        T = p.coherent_time_s
        K = int(round(p.duration_s / T))
        truth, _, _ = self.truth(cn0_dbhz, 1, np.random.default_rng(0))  # geometry only; the draws are unused
        r0, v = truth.receiver_state(np.asarray(0.0))
        clock_q = SPEED_OF_LIGHT_M_S**2 * PRESETS[p.clock].process_noise(T)
        return vector_tracking_pcrb(
            lambda t: truth.sat_state(t)[0],
            r0[0],
            v[0],
            clock_q,
            P0,
            np.asarray(truth.cn0_dbhz, float)[0],
            T,
            K,
            p.early_late_spacing_chips,
            measurements,
        )


def _with_fault(range_error, fault: tuple[int, float, float, float], runs: int, channels: int):
    """``range_error`` (`LoopTruth.range_error_m`, or None) with the case's fault added to
    one channel's code range: ``step + ramp (t - start)`` from ``start`` (s) on."""
    channel, start_s, step_m, ramp_m_s = fault

    def f(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(t, float)
        if range_error is None:
            code = carrier = np.zeros(t.shape + (runs, channels))
        else:
            code, carrier = range_error(t)
            code = np.array(np.broadcast_to(code, t.shape + (runs, channels)))
        on = t >= start_s
        bias = np.where(on, step_m + ramp_m_s * (t - start_s), 0.0)
        code = np.array(code, float)
        code[..., channel] += bias[..., None]
        return code, carrier

    return f
