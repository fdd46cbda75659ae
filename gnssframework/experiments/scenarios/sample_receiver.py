"""Scenario ``sample-receiver``: the whole software receiver on generated samples.

Each run writes a short recording (seconds, complex int8 at 2.6 MHz by default) of a
static receiver seeing the case's number of satellites of the nominal constellation at
the case's C/N0, each signal carrying its LNAV message with the code, carrier and data
timing of the geometry (`sample_receiver_signals`), and runs
`gnssframework.receiver.navigation.receive.receive` on it: acquisition of all 32 PRNs,
sample-driven tracking with the candidate's ``channel_filter`` (after the pull-in stage),
LNAV decoding, observables and weighted least-squares fixes at ``rate_hz``.

To keep runs short the receiver is given the generator's broadcast ephemerides (as the
``--ephemeris`` option of the commands gives a RINEX navigation file): the first fix
needs only the TOW of one subframe, not the 18-30 s of subframes 1-3. The recording
starts ``lead_s`` before a subframe boundary, so the first fix comes about
``lead_s + 6 s`` in. By default (``atmosphere``) the signals carry an ionosphere,
``iono_scale`` times the broadcast Klobuchar model's delay, and a troposphere, the
receiver model's plus ``tropo_zenith_residual_m`` at the zenith, and the receiver corrects
both with its own models (Klobuchar from ``iono_alpha``/``iono_beta``, given as a
navigation file's header gives them; Saastamoinen): what is left is the models' error, as
on a real recording. Each satellite's signal also carries a broadcast orbit and clock
error along its line of sight (``orbit_clock_residual_std_m``, SISRE) that the receiver's
ephemeris does not. Every run draws its own (`SampleReceiverScenario.run_plan`, from the
run's ``child("errors")`` stream, the same for every candidate): the ionosphere's scale
(spread ``iono_scale_std``), the troposphere's residual (``tropo_zenith_residual_std_m``)
and the orbit and clock errors, so a case's errors are a distribution over runs, not one
sky (each run's recording is then generated anew: about 2 s each). A case with
``atmosphere = false`` is a clean control: no delay, no orbit or clock error, the models
off. The noise is drawn from each run's own stream
(``child("samples")``): every candidate sees the same samples in the same run, so the
comparison's paired differences are those of the receivers alone.

A candidate chooses the channel filter and, optionally, a navigation filter (run on the
pseudoranges and Dopplers from the first least-squares fix; without one the positions
are the least squares'): `receive_candidate`, which ``sample-recording`` shares.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from pydantic import Field, field_validator

from ... import random_streams as draw
from ... import registry
from ...errors import ConfigError
from ...plugin_ref import PluginSpec
from ...receiver.channels import tracking_config
from ...receiver.channels.closure import ERROR_OUTPUTS
from ...receiver.channels.factory import StageFilters
from ...receiver.frontend import open_recording
from ...receiver.frontend.recording import Recording
from ...receiver.navigation import receive as receive_module
from ...receiver.navigation.filtered import check_nav_filter
from ...receiver.tracking.scalar import NCO_COMMANDS
from ..metric_components import evaluate, undefined_reasons as _undefined_reasons, units
from . import BatchResult, Scenario, ScenarioParams, register_scenario
from .sample_receiver_metrics import SERIES, FiniteFraction, FiniteRms, FirstFinite, Last, run_series
from .sample_receiver_signals import (
    SAMPLE_FORMAT,
    Atmosphere,
    SignalPlan,
    signal_plan,
    with_atmosphere,
    write_run_recording,
)

__all__ = ["SampleReceiverScenario", "METRICS", "receive_candidate", "candidate_filters", "evaluate_runs"]

_SUBFRAME_S = 6.0
_NO_FIX = "no fix in the run"


class SampleReceiverParams(ScenarioParams):
    duration_s: float = Field(10.0, gt=0, le=120, description="length of each run's recording (s)")
    sample_rate_hz: float = Field(
        2.6e6, ge=2.046e6, le=4.092e6, description="sample rate of the recordings (complex int8)"
    )
    rate_hz: float = Field(5.0, gt=0, le=50, description="position solutions per second")
    cn0_dbhz: float = Field(45.0, ge=30, le=60, description="C/N0 of every satellite")
    satellites: int = Field(6, ge=4, le=12, description="satellites in the recording: the highest above mask_deg")
    mask_deg: float = Field(10.0, ge=0, lt=90, description="elevation mask of the generated satellites")
    lat_deg: float = Field(34.23, ge=-90, le=90)
    lon_deg: float = Field(108.3576, ge=-180, le=180)
    height_m: float = Field(590.6, ge=-500, le=10_000)
    gps_week: int = Field(2300, ge=0, description="GPS week of the recording")
    subframe_tow_s: float = Field(
        345612.0,
        ge=0,
        lt=604_800,
        description="GPS time of week of the first subframe boundary in the recording "
        "(a multiple of 6 s; the default starts subframe 3, after the bit transitions "
        "of subframe 2 that bit synchronisation needs)",
    )
    lead_s: float = Field(
        1.5,
        ge=1.0,
        le=5.0,
        description="recording time before that boundary (pull-in and bit synchronisation happen in it)",
    )
    coherent_ms: int = Field(10, description="coherent integration after bit synchronisation (ms; divides 20)")
    acquisition: str = Field("pcps", description="acquisition plugin searching all 32 PRNs")
    atmosphere: bool = Field(
        True,
        description="the recordings carry an ionosphere and a troposphere and the receiver corrects both with "
        "its models (Klobuchar from iono_alpha/iono_beta, Saastamoinen); false: neither, and the "
        "receiver's models off (a clean control)",
    )
    iono_alpha: tuple[float, float, float, float] = Field(
        (1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08),
        description="broadcast Klobuchar alpha (s, s/semicircle^n), given to the receiver as a navigation "
        "file header would (default: tests/data/07590920.05n, RTKLIB's test data, 2005-04-02)",
    )
    iono_beta: tuple[float, float, float, float] = Field(
        (8.8060e04, 1.6380e04, -1.9660e05, -1.3110e05),
        description="broadcast Klobuchar beta (s, s/semicircle^n; the same file)",
    )
    iono_scale: float = Field(
        1.5,
        ge=0,
        le=5,
        description="true ionospheric delay over the broadcast model's along each line of sight (1.5: the "
        "correction leaves a third of it; the model removes about half in RMS)",
    )
    tropo_zenith_residual_m: float = Field(
        0.05,
        ge=-1,
        le=1,
        description="true zenith tropospheric delay minus the receiver model's (m), mapped as the model maps",
    )
    iono_scale_std: float = Field(
        0.25,
        ge=0,
        le=2,
        description="standard deviation of iono_scale across runs: each run draws its own scale "
        "(iono_scale + iono_scale_std N, at least 0), as days differ",
    )
    tropo_zenith_residual_std_m: float = Field(
        0.03,
        ge=0,
        le=0.5,
        description="standard deviation (m) of the zenith troposphere's residual across runs (each run its own "
        "draw around tropo_zenith_residual_m; UNB3-class models leave a few cm, Collins 1999)",
    )
    orbit_clock_residual_std_m: float = Field(
        0.6,
        ge=0,
        le=20,
        description="SISRE (m): each satellite's broadcast orbit and clock error along its line of sight, one "
        "Gaussian value per satellite and run, constant over the run (GPS broadcast SISRE is below 1 m, "
        "Montenbruck et al. 2015); the signal carries it, the receiver's ephemeris does not",
    )

    @field_validator("acquisition")
    @classmethod
    def _registered(cls, value: str) -> str:
        known = registry.names("acquisition")
        if value not in known:
            raise ValueError(f"unknown acquisition {value!r}; known: {', '.join(known)}")
        return value

    @field_validator("subframe_tow_s")
    @classmethod
    def _on_a_subframe(cls, value: float) -> float:
        if value % _SUBFRAME_S:
            raise ValueError(f"must be a multiple of 6 s (a subframe boundary), got {value}")
        return value

    @field_validator("coherent_ms")
    @classmethod
    def _divides_a_bit(cls, value: int) -> int:
        if value not in (1, 2, 4, 5, 10, 20):
            raise ValueError(f"must be 1, 2, 4, 5, 10 or 20 (divides a 20 ms bit), got {value}")
        return value


class SampleReceiverCase(ScenarioParams):
    name: str | None = None
    cn0_dbhz: float | None = Field(
        None, ge=30, le=60, description="C/N0 of every satellite in this case (default: the scenario's)"
    )
    satellites: int | None = Field(None, ge=4, le=12, description="satellites in this case (default: the scenario's)")
    atmosphere: bool | None = Field(
        None,
        description="the atmosphere and the orbit and clock errors in this case (default: the scenario's; "
        "false: a labelled clean control)",
    )


#: The scenario's metrics, each declared once as a component (name, unit, the series it
#: reduces); ``run_batch`` computes them all once with `evaluate`.
METRICS = (
    FiniteRms(
        "horizontal_error_rms",
        "m",
        of="horizontal_error_m",
        undefined=_NO_FIX,
        description="RMS horizontal position error of the fixes against the generator's receiver position",
    ),
    FiniteRms(
        "vertical_error_rms",
        "m",
        of="vertical_error_m",
        undefined=_NO_FIX,
        description="RMS vertical position error of the fixes",
    ),
    FirstFinite(
        "time_to_first_fix_s",
        "s",
        of="fix_time_s",
        undefined=_NO_FIX,
        description="recording time of the first fix (the receiver has the ephemerides: one subframe's TOW is enough)",
    ),
    FiniteFraction(
        "fix_fraction",
        "-",
        of="fix_time_s",
        description="fraction of the epochs k / rate_hz of the recording with a fix",
    ),
    Last(
        "channels_locked",
        "-",
        of="locked_channels",
        description="channels of the generated satellites in lock at the end of the recording",
    ),
    Last(
        "false_channels_locked",
        "-",
        of="locked_false_channels",
        description="channels of satellites not in the recording in lock at its end (false acquisitions)",
    ),
    FiniteRms(
        "cn0_error_rms_db",
        "dB",
        of="cn0_error_db",
        undefined="no channel in lock",
        description="RMS of the C/N0 estimates of the locked generated channels minus the true C/N0",
    ),
)


@register_scenario
class SampleReceiverScenario(Scenario):
    """The software receiver (acquisition, tracking, LNAV, fixes) on generated LNAV samples."""

    kind = "sample-receiver"
    #: 1: each run its own atmosphere and orbit and clock errors (issue 42), and before it the
    #: atmosphere on by default: a store written before gives other numbers.
    revision = 1
    Params = SampleReceiverParams
    params: SampleReceiverParams  # self.params, as validated
    CaseParams = SampleReceiverCase
    components = {"channel_filter": True, "nav_filter": False}
    metrics = units(METRICS)
    #: The raw per-epoch series the metrics reduce (metric components of other packages
    #: may read them too); NaN where there is no fix (or no locked channel).
    outputs = dict(SERIES)
    #: Why a metric can be undefined (NaN) in a run; summary.json and report.md say it.
    undefined_reasons = _undefined_reasons(METRICS)

    def check_case(self, case: dict, where: str) -> None:
        """The case's own checks, and a recording long enough for one subframe after the lead."""
        super().check_case(case, where)
        p = self.params
        if p.duration_s < p.lead_s + _SUBFRAME_S + 1.0 / p.rate_hz:
            raise ConfigError(
                "scenario.duration_s",
                f"must be at least lead_s + 6 s + one epoch = "
                f"{p.lead_s + _SUBFRAME_S + 1.0 / p.rate_hz:g} s (the TOW of a whole subframe gives "
                f"the first fix; got {p.duration_s!r})",
            )
        self.plan(case, where)

    def check_composition(self, plugins, where: str) -> None:
        """A channel filter the sample tracker can run: it reads correlators and gives NCO
        commands or the errors an FLL/DLL closes (`SampleTracker`)."""
        ch = plugins["channel_filter"]
        provides = set(ch.provides)
        if "correlators" not in ch.requires or not (set(NCO_COMMANDS) <= provides or set(ERROR_OUTPUTS) <= provides):
            able = sorted(
                set(self.capable("channel_filter", NCO_COMMANDS)) | set(self.capable("channel_filter", ERROR_OUTPUTS))
            )
            able = [n for n in able if "correlators" in registry.get("channel_filter", n).requires]
            raise ConfigError(
                f"{where}.channel_filter.name",
                f"{ch.name!r} cannot track on samples: it must require "
                f"'correlators' and provide {', '.join(NCO_COMMANDS)} or {', '.join(ERROR_OUTPUTS)}; "
                f"channel filters that do: {', '.join(able)}",
            )
        nav = plugins.get("nav_filter")
        if nav is not None:  # one run on the pseudoranges and Dopplers after the first fix
            check_nav_filter(nav.name, f"{where}.nav_filter.name")

    def plan(self, case: dict, where: str = "case") -> SignalPlan:
        """What the case's recordings hold (satellites, their records, the receiver)."""
        p = self.params
        c = self.CaseParams.model_validate(case)
        satellites = p.satellites if c.satellites is None else c.satellites
        try:
            return signal_plan(
                lat_deg=p.lat_deg,
                lon_deg=p.lon_deg,
                height_m=p.height_m,
                subframe_tow_s=p.subframe_tow_s,
                lead_s=p.lead_s,
                week=p.gps_week,
                satellites=satellites,
                cn0_dbhz=p.cn0_dbhz if c.cn0_dbhz is None else c.cn0_dbhz,
                duration_s=p.duration_s,
                sample_rate_hz=p.sample_rate_hz,
                mask_deg=p.mask_deg,
                atmosphere=self.atmosphere(c),
            )
        except ConfigError as exc:
            field = f"{where}.satellites" if c.satellites is not None else "scenario.satellites"
            raise ConfigError(field, exc.detail) from None

    def atmosphere(self, case: SampleReceiverCase) -> Atmosphere | None:
        """The case's `Atmosphere` (None: a clean case)."""
        p = self.params
        if not (p.atmosphere if case.atmosphere is None else case.atmosphere):
            return None
        return Atmosphere(tuple(p.iono_alpha), tuple(p.iono_beta), p.iono_scale, p.tropo_zenith_residual_m)

    def time_s(self) -> np.ndarray:
        """The scenario's epochs ``k / rate_hz`` (s from the first sample)."""
        p = self.params
        return np.arange(int(np.floor(p.duration_s * p.rate_hz + 1e-9))) / p.rate_hz

    def receive(
        self, plan: SignalPlan, plugins: dict, path: Path, filters: StageFilters | None = None
    ) -> receive_module.ReceiveResult:
        """`receive_candidate` on one run's recording, with the generator's ephemerides; the
        receiver's ionosphere (with the plan's Klobuchar coefficients) and troposphere models
        on where the recording has an atmosphere, off where it has none."""
        recording = open_recording(path, SAMPLE_FORMAT, plan.sample_rate_hz, 0.0)
        atm = plan.atmosphere
        return receive_candidate(
            recording,
            plugins,
            self.params,
            rinex=plan.ephemerides,
            ionosphere=atm is not None,
            troposphere=atm is not None,
            reference_week=plan.week,
            filters=filters,
            iono_fallback=None if atm is None else atm.iono_utc(),
        )

    def run_plan(self, plan: SignalPlan, rng: np.random.Generator) -> SignalPlan:
        """One run's recording: the case's ``plan`` with the run's own atmosphere and orbit
        and clock errors drawn from ``rng`` (`Atmosphere.drawn`); a clean case's, or one
        whose spreads are all 0, unchanged (its samples are then shared by the runs)."""
        p = self.params
        spreads = (p.iono_scale_std, p.tropo_zenith_residual_std_m, p.orbit_clock_residual_std_m)
        if plan.atmosphere is None or not any(spreads):
            return plan
        return with_atmosphere(plan, plan.atmosphere.drawn(rng, len(plan.prns), *spreads))

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        rng = draw.as_run_streams(rng, runs)  # one stream per run: numbers independent of batching
        noise = rng.child("samples")  # the same for every candidate: common random numbers
        errors = rng.child("errors")  # the run's atmosphere, orbits and clocks: the same for every candidate
        case_plan = self.plan(case)
        t = self.time_s()
        per_run = []
        filters = candidate_filters(plugins, self.params)  # the channel filters built once for the batch
        with tempfile.TemporaryDirectory(prefix="gnssframework-sample-receiver-") as tmp:
            for r in range(runs):  # one recording and one receiver per run
                plan = self.run_plan(case_plan, errors.generators[r])
                path = write_run_recording(plan, noise.generators[r], Path(tmp) / f"run{r}.{SAMPLE_FORMAT}")
                result = self.receive(plan, plugins, path, filters)
                per_run.append(run_series(result, plan.prns, plan.cn0_dbhz, plan.receiver_lat_lon_h, t))
                path.unlink()
        return evaluate_runs(METRICS, per_run, t, self)


def candidate_filters(plugins: dict, params) -> StageFilters:
    """The tracking settings of a candidate (its ``channel_filter`` and parameters, the
    scenario's ``coherent_ms``) with their stages' filters, built once for a batch: the
    candidate's own plugin is the ``track`` stage's prototype."""
    channel = plugins["channel_filter"]
    config = tracking_config(
        channel_filter=channel.name,
        channel_params=_as_config(channel.params.model_dump(mode="json")),
        coherent_ms=params.coherent_ms,
    )
    return StageFilters(config, channel)


def receive_candidate(
    recording: Recording,
    plugins: dict,
    params,
    *,
    rinex,
    ionosphere: bool,
    troposphere: bool,
    reference_week: int | None,
    filters: StageFilters | None = None,
    iono_fallback=None,
) -> receive_module.ReceiveResult:
    """`receive` on ``recording`` as a candidate builds it: its ``channel_filter`` (with its
    parameters) in the sample tracker and, when it names one, its ``nav_filter`` on the
    pseudoranges and Dopplers from the first least-squares fix; ``params`` gives the
    scenario's ``acquisition``, ``coherent_ms`` and ``rate_hz``. ``filters``: the
    batch's `candidate_filters` (built here when None); ``iono_fallback``: Klobuchar
    coefficients where no channel decodes them (`receive`)."""
    filters = filters if filters is not None else candidate_filters(plugins, params)
    return receive_module.receive(
        recording,
        registry.create("acquisition", params.acquisition),
        filters.config,
        rate_hz=params.rate_hz,
        rinex=rinex,
        ionosphere=ionosphere,
        troposphere=troposphere,
        reference_week=reference_week,
        nav_filter=_spec(plugins.get("nav_filter")),
        filters=filters,
        iono_fallback=iono_fallback,
    )


def evaluate_runs(metrics, per_run: list[dict[str, np.ndarray]], time_s: np.ndarray, scenario) -> BatchResult:
    """The metrics of a batch from its runs' series (each ``(K,)``; stacked on axis 1)."""
    series = {name: np.stack([s[name] for s in per_run], axis=1) for name in per_run[0]}
    return evaluate(metrics, series, time_s, scenario)


def _spec(nav) -> PluginSpec | None:
    """A built nav_filter plugin as the reference `receive` takes (None stays None)."""
    if nav is None:
        return None
    return PluginSpec("nav_filter", nav.name, _as_config(nav.params.model_dump(mode="json")))


def _as_config(value):
    """A plugin's dumped parameters as config input again (nested plugin references
    without their ``kind``)."""
    if isinstance(value, dict):
        if {"kind", "name", "params"} <= set(value):
            return {"name": value["name"], "params": _as_config(value["params"])}
        return {k: _as_config(v) for k, v in value.items()}
    return value
