"""Scenario ``sample-recording``: the whole software receiver on a RECORDED file.

The sibling of ``sample-receiver`` (which writes its own recordings) for samples that
were recorded: a SigMF recording (a gps-sdr-sim file written by
``validation/gps_sdr_sim_recording.py``, a front end's capture) or a raw file with its
format and rate given. Run ``r`` of every case is the segment
``[start_s + r segment_s, start_s + (r + 1) segment_s)`` of the file: disjoint segments,
so the runs are independent draws of the receiver's noise as far as the signal's own
history allows, and run ``r`` of every candidate is the same segment (common random
numbers: the comparison's paired differences are those of the receivers alone). A
segment past the end of the file is refused naming ``scenario.segment_s`` and how many
segments the file holds.

With ``runs_on = "one-segment-with-noise"`` every run is instead the segment at
``start_s`` with independent white Gaussian noise added (`write_noisy_segment`): a paired
Monte Carlo of the recording at a C/N0 lower by ``cn0_reduction_db``. The recording's
noise power per component ``sigma_n^2`` is taken as the segment's power about its mean
(every GNSS signal is below the noise), and noise of variance
``sigma_n^2 (10^(cn0_reduction_db / 10) - 1)`` per component multiplies the noise density
``N0`` by ``10^(cn0_reduction_db / 10)``. The signals' own power in that estimate,
``s = sum_k C_k / (N0 fs)`` (0.13 for eleven satellites at 45 dB-Hz and 2.6 MHz), makes
the noise added slightly larger: one signal's C/N0 drops by
``10 log10(1 + (1 + s)(10^(cn0_reduction_db / 10) - 1))`` dB, 10.5 dB for a stated 10 dB
in that example. The noise is drawn from run ``r``'s stream (``child("added-noise")``):
every candidate sees the same noisy samples in run ``r``, and a run's samples do not
depend on its batch. Nothing is re-quantised: the stored samples (integers, exact in
float32 below 2^24) plus the noise are written as complex float32 (``cf32_le``), so the
added noise is Gaussian as stated and the recording's own quantisation is kept as it
is; real-sample formats are refused in this mode (there is no real float format to
write them in).

Each segment goes to `gnssframework.receiver.navigation.receive.receive` (acquisition of
all 32 PRNs, sample-driven tracking with the candidate's ``channel_filter``, LNAV,
observables, least-squares fixes at ``rate_hz``, and the candidate's ``nav_filter`` on the
pseudoranges and Dopplers when it names one), with the ephemerides of ``ephemeris`` (a
RINEX navigation file, as ``receive --ephemeris``) so that a fix needs one subframe's TOW.

Metrics that need no truth: the fraction of the segment's epochs with a fix, the time of
the first fix, the channels in lock at the segment's end and the scatter of the fixes
about their run's mean position (horizontal and vertical RMS). With ``truth_lat_lon_h``
(the receiver's known position, as ``receive --truth``), the horizontal and vertical
errors against it too; without it those are undefined, and the reports say why.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Literal

import numpy as np
import pymap3d
from pydantic import Field, field_validator

from ... import random_streams as draw
from ... import registry
from ...errors import ConfigError
from ...navigation.ephemeris import read_rinex_nav
from ...receiver.frontend import open_recording
from ...receiver.frontend.recording import Recording
from ...receiver.navigation import receive as receive_module
from ..metric_components import undefined_reasons as _undefined_reasons, units
from . import BatchResult, Scenario, ScenarioParams, register_scenario
from .sample_receiver import SampleReceiverScenario, candidate_filters, evaluate_runs, receive_candidate
from .sample_receiver_metrics import FiniteFraction, FiniteRms, FirstFinite, Last, run_series

__all__ = [
    "SampleRecordingScenario",
    "METRICS",
    "SERIES",
    "segment_bounds",
    "noise_power",
    "write_noisy_segment",
    "NOISY_FORMAT",
]

#: Where ``validation/gps_sdr_sim_recording.py`` writes the example's recording.
DEFAULT_RECORDING = "build/gps_sdr_sim_45dbhz.sigmf-data"
_NO_TRUTH = "no fix in the run, or no truth_lat_lon_h given"
_NO_FIX = "no fix in the run"
_ALL_PRNS = tuple(range(1, 33))
#: The format the noisy segments are written in: complex float32 holds the stored integers
#: exactly and the added noise unquantised.
NOISY_FORMAT = "cf32_le"
_BLOCK_SAMPLES = 1 << 20  # samples read, noised and written at a time (memory of one block)

#: The raw series of one run (name -> unit), each ``(K,)`` on the segment's epochs.
SERIES = {
    "fix_time_s": "s",
    "horizontal_error_m": "m",
    "vertical_error_m": "m",
    "horizontal_scatter_m": "m",
    "vertical_scatter_m": "m",
    "locked_channels": "-",
}


class SampleRecordingParams(ScenarioParams):
    recording: str = Field(
        DEFAULT_RECORDING,
        description="the recorded file (path from the working directory; "
        "default: the one validation/gps_sdr_sim_recording.py writes for the example); its SigMF "
        "metadata file, if beside it, gives what format, sample_rate_hz and if_hz leave out",
    )
    format: str | None = Field(None, description="sample format (a sample_source plugin; default: SigMF's)")
    sample_rate_hz: float | None = Field(None, gt=0, description="sample rate (default: SigMF's)")
    if_hz: float | None = Field(None, description="intermediate frequency (default: SigMF's, else 0)")
    ephemeris: str | None = Field(
        None,
        description="RINEX navigation file for fixes before the subframes arrive (path from the working directory)",
    )
    truth_lat_lon_h: list[float] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="known receiver position: latitude, longitude (deg), "
        "height (m); without it the error metrics are undefined",
    )
    start_s: float = Field(0.0, ge=0, description="start of run 0's segment in the file (s)")
    segment_s: float = Field(
        12.0,
        gt=0,
        le=120,
        description="length of each run's segment (s); with runs_on = segments, run r starts at start_s + r segment_s",
    )
    runs_on: Literal["segments", "one-segment-with-noise"] = Field(
        "segments",
        description="segments: run r is the segment r of the file; one-segment-with-noise: every run "
        "is the segment at start_s with its own white Gaussian noise added (cn0_reduction_db)",
    )
    cn0_reduction_db: float = Field(
        0.0,
        ge=0,
        le=30,
        description="C/N0 reduction by the noise added to every run "
        "(dB; one-segment-with-noise only, where it must be > 0)",
    )
    rate_hz: float = Field(1.0, gt=0, le=50, description="position solutions per second")
    gps_week: int | None = Field(
        None,
        ge=0,
        description="full GPS week near the recording (the decoded 10-bit "
        "week is placed nearest it; needed when no subframe 1 arrives)",
    )
    ionosphere: bool = Field(True, description="apply the Klobuchar model (decoded page 18)")
    troposphere: bool = Field(False, description="apply the troposphere model (gps-sdr-sim has none)")
    coherent_ms: int = Field(10, description="coherent integration after bit synchronisation (ms; divides 20)")
    acquisition: str = Field("pcps", description="acquisition plugin searching all 32 PRNs")

    @field_validator("acquisition")
    @classmethod
    def _registered(cls, value: str) -> str:
        known = registry.names("acquisition")
        if value not in known:
            raise ValueError(f"unknown acquisition {value!r}; known: {', '.join(known)}")
        return value

    @field_validator("coherent_ms")
    @classmethod
    def _divides_a_bit(cls, value: int) -> int:
        if value not in (1, 2, 4, 5, 10, 20):
            raise ValueError(f"must be 1, 2, 4, 5, 10 or 20 (divides a 20 ms bit), got {value}")
        return value


class SampleRecordingCase(ScenarioParams):
    name: str | None = None


METRICS = (
    FiniteRms(
        "horizontal_error_rms",
        "m",
        of="horizontal_error_m",
        undefined=_NO_TRUTH,
        description="RMS horizontal position error of the fixes against truth_lat_lon_h",
    ),
    FiniteRms(
        "vertical_error_rms",
        "m",
        of="vertical_error_m",
        undefined=_NO_TRUTH,
        description="RMS vertical position error of the fixes against truth_lat_lon_h",
    ),
    FiniteRms(
        "horizontal_scatter_rms",
        "m",
        of="horizontal_scatter_m",
        undefined=_NO_FIX,
        description="RMS horizontal distance of the run's fixes from their mean position (needs no truth)",
    ),
    FiniteRms(
        "vertical_scatter_rms",
        "m",
        of="vertical_scatter_m",
        undefined=_NO_FIX,
        description="RMS vertical distance of the run's fixes from their mean position (needs no truth)",
    ),
    FirstFinite(
        "time_to_first_fix_s",
        "s",
        of="fix_time_s",
        undefined=_NO_FIX,
        description="time of the first fix from the segment's start",
    ),
    FiniteFraction(
        "fix_fraction", "-", of="fix_time_s", description="fraction of the segment's epochs k / rate_hz with a fix"
    ),
    Last("channels_locked", "-", of="locked_channels", description="channels in lock at the segment's end"),
)


def segment_bounds(recording: Recording, start_s: float, segment_s: float, run: int) -> tuple[int, int]:
    """First sample and sample count of run ``run``'s segment, on whole chunks of the format.

    Raises
    ------
    ConfigError
        When the segment ends past the file (naming how many segments it holds).
    """
    fs = recording.info.sample_rate_hz
    spc = recording.source.samples_per_chunk
    first = int(round((start_s + run * segment_s) * fs)) // spc * spc
    count = int(round(segment_s * fs)) // spc * spc
    if first + count > recording.n_samples:
        fits = max(0, int((recording.duration_s - start_s + 1e-9) // segment_s))
        raise ConfigError(
            "scenario.segment_s",
            f"run {run}'s segment ends at {(first + count) / fs:.3f} s, past the "
            f"end of {recording.path.name} ({recording.duration_s:.3f} s): the file holds {fits} "
            f"segment(s) of {segment_s:g} s from start_s = {start_s:g} s; lower runs or segment_s",
        )
    return first, count


@register_scenario
class SampleRecordingScenario(SampleReceiverScenario):
    """The software receiver (acquisition, tracking, LNAV, fixes) on segments of a recorded file."""

    kind = "sample-recording"
    Params = SampleRecordingParams
    params: SampleRecordingParams  # self.params, as validated
    CaseParams = SampleRecordingCase
    components = {"channel_filter": True, "nav_filter": False}
    metrics = units(METRICS)
    outputs = dict(SERIES)
    undefined_reasons = _undefined_reasons(METRICS)

    def check_case(self, case: dict, where: str) -> None:
        """The case's own checks, the files (recording, ephemeris) and a first segment in the file."""
        Scenario.check_case(self, case, where)  # the base's: the parent's needs its generated plan
        p = self.params
        rec = self.open()
        segment_bounds(rec, p.start_s, p.segment_s, 0)
        self.ephemerides()
        if p.runs_on == "segments" and p.cn0_reduction_db:
            raise ConfigError(
                "scenario.cn0_reduction_db",
                f"adds noise only with runs_on = "
                f"'one-segment-with-noise' (runs_on is 'segments'); got {p.cn0_reduction_db:g}",
            )
        if p.runs_on == "one-segment-with-noise":
            if not p.cn0_reduction_db > 0:
                raise ConfigError(
                    "scenario.cn0_reduction_db",
                    "must be > 0 with runs_on = 'one-segment-with-noise' (the runs would be the same samples)",
                )
            if not rec.is_complex:
                raise ConfigError(
                    "scenario.runs_on",
                    f"'one-segment-with-noise' writes complex float32 samples; "
                    f"{rec.path.name} holds real ones ({rec.info.format})",
                )

    def open(self) -> Recording:
        """The recording, with the format, rate and IF of the parameters or its SigMF file."""
        p = self.params
        try:
            return open_recording(p.recording, p.format, p.sample_rate_hz, p.if_hz)
        except ConfigError as exc:
            field = exc.field if exc.field in ("format", "sample_rate_hz", "if_hz") else "recording"
            hint = (
                " (a gps-sdr-sim recording is made by validation/gps_sdr_sim_recording.py)"
                if "no such file" in exc.detail
                else ""
            )
            raise ConfigError(f"scenario.{field}", exc.detail + hint) from None

    def ephemerides(self):
        """The RINEX navigation file's records, or None."""
        path = self.params.ephemeris
        if path is None:
            return None
        if not Path(path).is_file():
            raise ConfigError("scenario.ephemeris", f"{path}: no such file")
        return read_rinex_nav(path)

    def time_s(self) -> np.ndarray:
        """The segment's epochs ``k / rate_hz`` (s from its first sample)."""
        p = self.params
        return np.arange(int(np.floor(p.segment_s * p.rate_hz + 1e-9))) / p.rate_hz

    def run_batch(self, case, plugins, runs, rng) -> BatchResult:
        p = self.params
        streams = draw.as_run_streams(rng, runs)
        noise = streams.child("added-noise")  # the same for every candidate: common random numbers
        rec, rinex, t = self.open(), self.ephemerides(), self.time_s()
        truth = tuple(p.truth_lat_lon_h) if p.truth_lat_lon_h is not None else None
        noisy = p.runs_on == "one-segment-with-noise"
        if noisy:
            first, count = segment_bounds(rec, p.start_s, p.segment_s, 0)
            added_sigma = np.sqrt(noise_power(rec, first, count) * (10 ** (p.cn0_reduction_db / 10) - 1))
        per_run = []
        filters = candidate_filters(plugins, p)  # the channel filters built once for the batch
        with tempfile.TemporaryDirectory(prefix="gnssframework-sample-recording-") as tmp:
            for i, run in enumerate(streams.runs):
                path = Path(tmp) / f"run{run}.bin"
                if noisy:
                    write_noisy_segment(rec, first, count, added_sigma, noise.generators[i], path)
                    segment = open_recording(path, NOISY_FORMAT, rec.info.sample_rate_hz, rec.info.if_hz, 1)
                else:
                    _copy_segment(rec, *segment_bounds(rec, p.start_s, p.segment_s, run), path)
                    segment = open_recording(
                        path, rec.info.format, rec.info.sample_rate_hz, rec.info.if_hz, rec.info.q_sign
                    )
                result = receive_candidate(
                    segment,
                    plugins,
                    p,
                    rinex=rinex,
                    ionosphere=p.ionosphere,
                    troposphere=p.troposphere,
                    reference_week=p.gps_week,
                    filters=filters,
                )
                per_run.append(_series(result, truth, t))
                path.unlink()
        return evaluate_runs(METRICS, per_run, t, self)


def noise_power(rec: Recording, first: int, count: int) -> float:
    """Power per real component of samples ``[first, first + count)`` about their mean
    (``E|x - mean|^2 / 2`` for complex samples): the recording's noise, whose density
    ``N0 = 2 sigma^2 / fs`` every signal below it is measured against."""
    total, total_sq = 0.0 + 0.0j, 0.0
    for _, x in rec.blocks(_BLOCK_SAMPLES, first, first + count):
        x = x.astype(np.complex128)
        total += x.sum()
        total_sq += float(np.vdot(x, x).real)
    return (total_sq / count - abs(total / count) ** 2) / 2


def write_noisy_segment(
    rec: Recording, first: int, count: int, sigma: float, rng: np.random.Generator, path: str | Path
) -> Path:
    """Samples ``[first, first + count)`` of ``rec`` (complex, Q sign applied) plus complex
    white Gaussian noise of ``sigma`` per component drawn from ``rng``, written to ``path``
    as `NOISY_FORMAT` (no metadata file: the caller gives the format).

    The draws are ``(n, 2)`` normals block after block, I then Q of each sample: the
    noise of a sample depends only on ``rng`` and its index, not on the block size.
    """
    source = registry.create("sample_source", NOISY_FORMAT)
    path = Path(path)
    with path.open("wb") as out:
        for _, x in rec.blocks(_BLOCK_SAMPLES, first, first + count):
            n = rng.standard_normal((x.size, 2))
            out.write(source.encode(x + sigma * (n[:, 0] + 1j * n[:, 1])))
    return path


def _copy_segment(rec: Recording, first: int, count: int, path: Path) -> Path:
    """The bytes of samples ``[first, first + count)`` (whole chunks) as a file of their own."""
    spc, bpc = rec.source.samples_per_chunk, rec.source.bytes_per_chunk
    with rec.path.open("rb") as src:
        src.seek(first // spc * bpc)
        path.write_bytes(src.read(count // spc * bpc))
    return path


def _series(result: receive_module.ReceiveResult, truth: tuple | None, t: np.ndarray) -> dict[str, np.ndarray]:
    """One run's `SERIES`: `run_series` against the truth (NaN without one) and against the
    run's own mean position (the scatter)."""
    table = result.positions
    mean = (0.0, 0.0, 0.0)
    if table is not None and len(table):
        mean = tuple(float(v) for v in pymap3d.ecef2geodetic(*table.ecef_m.mean(axis=0)))
    own = run_series(result, _ALL_PRNS, 0.0, mean, t)
    out = {
        "fix_time_s": own["fix_time_s"],
        "horizontal_scatter_m": own["horizontal_error_m"],
        "vertical_scatter_m": own["vertical_error_m"],
        "locked_channels": own["locked_channels"],
    }
    if truth is None:
        out["horizontal_error_m"] = out["vertical_error_m"] = np.full(t.size, np.nan)
    else:
        against = run_series(result, _ALL_PRNS, 0.0, truth, t)
        out["horizontal_error_m"], out["vertical_error_m"] = against["horizontal_error_m"], against["vertical_error_m"]
    return out
