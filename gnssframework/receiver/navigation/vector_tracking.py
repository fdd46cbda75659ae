r"""Vector tracking on samples: the navigation filter closes every channel's NCOs.

`VectorSampleTracker` is a `~gnssframework.receiver.channels.SampleTracker` that starts as
the scalar receiver (pull-in, PLL, bit sync, LNAV). Once at least four channels run
bit-aligned (``extended``) with a transmit time from their LNAV and an ephemeris (decoded,
or from a RINEX file), it solves a first fix (`fixes.solve_epochs`) and hands those
channels over: each gets an error-output channel filter (``discriminator`` or
``iq-filter``) and a navigation filter (``ekf-pv``) starts from the fix. From then on,
every coherent interval ``T`` (the channels' bit-aligned ``coherent_ms``):

1. each channel's filter turns its correlators into a code error and a frequency error
   with their variances (the channel parts of the vector loop of reference 000,
   `gnssframework.receiver.tracking.vector`);
2. the navigation filter takes them as pseudorange and rate errors of each replica at a
   common epoch (Zou et al. 2018, eqs. 35-36): the replica's pseudorange is
   :math:`R = c\,(t_{rx} - t_{tx})`, its receive time from the sample counter and its
   transmit time from the chips its code NCO has generated since the fix;
3. the filter's position, velocity and clock predict every channel's pseudorange and
   rate at the start of its next interval,
   :math:`\hat R = \lVert s(t_{tx}) - r \rVert + b - c\,\Delta t_{SV} + I` (satellite
   at transmit time, rotated by the Earth's turn during the flight, its clock from the
   ephemeris, Klobuchar :math:`I` when page 18 is known) and
   :math:`\dot{\hat R} = (v_s - v)\cdot e + d - c\,\Delta\dot t_{SV}`: the code NCO is
   moved by :math:`(R - \hat R)/\lambda_{chip}` and the carrier NCO set to
   :math:`-\dot{\hat R}/\lambda_{L1}` (carrier: a vector FLL; no PLL, no carrier phase
   tracking after the hand-over).

A channel whose signal fades keeps being driven by the solution; its C/N0 estimate scales
the variances it reports (the thermal variances grow as 1/C/N0), so the filter leans on
the strong channels, and below ``min_cn0_dbhz`` its output is left out of the update.
Loss of lock (`_drop`): a channel whose C/N0 estimate over a full ``cn0_window_ms`` stays
below ``loss_cn0_dbhz`` (18 dB-Hz) for ``loss_ms`` (500 ms) leaves the loop and the
tracker's active channels (a signal gone, not one faded to 24 dB-Hz, whose estimates stay
above 21 dB-Hz on the project's generator).

With an `Assistance` (an approximate position and the recording's start time, with RINEX
ephemerides) the loop does not wait for LNAV: each replica's transmit time is resolved
from the prediction (`_assisted_transmit_times`), and every acquired channel is closed
from its pull-in on (`_try_assisted_handover`).

Once the loop runs (after either hand-over), a satellite outside it that the solution can
predict (a dropped channel's ephemeris, or the RINEX file's) is searched every
``reacquire_every_ms`` in the window of code phase and Doppler the state predicts
(`receiver.acquisition.assisted.window_search`) and joins the loop when found
(`_reacquire`); a lost scalar channel it cannot predict gets the scalar receiver's full
search.

Sign conventions: the sample tracker's error-output filters report the code error as the
chips the replica must advance (`closure.ErrorFeedback` adds it to the code phase), the
opposite of the analytic loop's "true minus replica delay": it is negated before the
navigation filter. Frequency errors are true minus replica Doppler in both.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pymap3d
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ... import names, registry
from ...errors import ConfigError, NumericalError
from ...interfaces import RunContext
from ...navigation.ephemeris import Ephemerides, satellite_state
from ...navigation.geometry import line_of_sight
from ...navigation.lnav import IonoUtc
from ...navigation.pvt import dop, klobuchar_delay_s, solve_position
from ...plugin import validation_message
from ...signal.correlators import Correlators
from ...signal.constants import CA_CHIP_LENGTH_M, CA_CHIP_RATE_HZ, CA_CODE_LENGTH, L1_FREQ_HZ, L1_WAVELENGTH_M
from ..acquisition.assisted import SearchWindow, window_search
from ..acquisition.search import Acquisition, AcquisitionResult
from ..channels import SampleTracker, TrackingConfig, TrackingResult
from ..frontend.recording import Recording
from ..tracking.vector import check_composition
from .fixes import PositionTable, full_week, solve_epochs
from .observables import SPEED_OF_LIGHT_MPS, channel_timing, observables

__all__ = ["VectorConfig", "vector_config", "VectorSampleTracker", "VectorSolution", "Assistance", "assistance"]

_C = SPEED_OF_LIGHT_MPS
_OMEGA_E = 7.2921151467e-5  # WGS 84 Earth rotation rate (rad/s), IS-GPS-200 Table 20-IV
#: Variance (chips², Hz²) that makes the navigation filter ignore a channel's output.
_IGNORE_VAR = 1e8
#: Interval (s) of the assisted start's checks (bit edges, hand-over): each costs an ephemeris evaluation.
_ASSIST_EVERY_S = 0.1
#: Code periods every channel runs (its pull-in) before an assisted hand-over.
_ASSIST_SETTLE_MS = 100
#: An assisted fix further than this from the approximate position (m) is refused (a wrong millisecond).
_ASSIST_RADIUS_M = 300e3
#: ... or one with a residual above this (m): pull-in code phases are within a chip (300 m), a wrong
#: millisecond is 300 km.
_ASSIST_MAX_RESIDUAL_M = 1000.0
#: Resolve-and-fix rounds of an assisted hand-over.
_ASSIST_ITERATIONS = 4


class VectorConfig(BaseModel):
    """How vector tracking takes over from the scalar channels."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    nav_filter: str = Field("ekf-pv", description="nav_filter plugin closing the loop")
    nav_params: dict[str, Any] = Field(default_factory=dict, description="its parameters")
    channel_filter: str = Field("discriminator", description="error-output channel_filter of the vector channels")
    channel_params: dict[str, Any] = Field(default_factory=dict, description="its parameters")
    earliest_s: float = Field(0.0, ge=0, description="no hand-over before this recording time (s)")
    try_every_s: float = Field(1.0, gt=0, description="interval between hand-over attempts (s)")
    pseudorange_sigma_m: float = Field(
        5.0, gt=0, description="pseudorange standard deviation of the first fix: its position and clock covariance is "
        "this squared times (G^T G)^-1 of the hand-over geometry")
    range_rate_sigma_mps: float = Field(
        0.2, gt=0, description="range-rate standard deviation of the Dopplers the initial velocity and clock drift "
        "are solved from")
    assisted_pseudorange_sigma_m: float = Field(
        100.0, gt=0, description="as pseudorange_sigma_m for an assisted start (code phases of channels still in "
        "pull-in: a quarter chip off)")
    assisted_range_rate_sigma_mps: float = Field(
        5.0, gt=0, description="as range_rate_sigma_mps for an assisted start (Dopplers of acquisition or of a 1 ms "
        "loop)")
    reacquire_coherent_ms: Literal[1, 10] = Field(
        10, description="coherent blocks of the aided re-acquisition (10: summed by parity, as alternate_blocks)")
    reacquire_noncoherent: int = Field(8, ge=2, le=100, description="its blocks (even)")
    reacquire_pfa: float = Field(1e-3, gt=0, lt=1, description="its false-alarm probability over the window")
    reacquire_sigmas: float = Field(
        4.0, gt=0, description="half widths of its window in standard deviations of the predicted range and rate")
    reacquire_elevation_deg: float = Field(5.0, description="satellites predicted below this are not searched")
    min_cn0_dbhz: float = Field(18.0, description="a channel whose C/N0 estimate is below this is not used")
    elevation_mask_deg: float = Field(5.0, description="nor one whose satellite the state sees below this (deg)")
    loss_cn0_dbhz: float = Field(
        18.0, description="loss of lock of a vector channel: its C/N0 estimate (over the tracker's full "
        "cn0_window_ms) below this ...")
    loss_ms: int = Field(500, ge=10, description="... for this long: the channel leaves the navigation filter and "
                         "is searched again in the window the solution predicts")
    solution_rate_hz: float = Field(1.0, gt=0, description="rows of the position table per second")

    @field_validator("reacquire_noncoherent")
    @classmethod
    def _even_blocks(cls, value: int, info) -> int:
        if info.data.get("reacquire_coherent_ms") == 10 and value % 2:
            raise ValueError(f"must be even with reacquire_coherent_ms 10 (blocks summed by parity), got {value}")
        return value


def vector_config(**values: Any) -> VectorConfig:
    """A `VectorConfig`; a bad value, or a channel and navigation filter that cannot close
    the loop together (`check_composition`), raises `ConfigError` naming the field."""
    try:
        config = VectorConfig(**values)
    except ValidationError as exc:
        raise validation_message(exc, prefix="vector", model=VectorConfig) from None
    check_composition(registry.create("channel_filter", config.channel_filter, **config.channel_params),
                      registry.create("nav_filter", config.nav_filter, **config.nav_params))
    return config


@dataclass(frozen=True)
class Assistance:
    """What a receiver knows before any LNAV: where it roughly is and when the recording began.

    ``position_ecef_m`` ``(3,)`` within ~100 km of the truth (the code phases' millisecond
    ambiguity is resolved from it); ``week`` and ``start_tow_s`` the GPS time of the first
    sample, to ~1 ms (a satellite moves ~4 m in 1 ms: a time error becomes a position
    error of that order); ``iono`` Klobuchar coefficients (e.g. a RINEX header's), or None.
    """

    position_ecef_m: np.ndarray
    week: int
    start_tow_s: float
    iono: IonoUtc | None = None


def assistance(lat_lon_h: tuple[float, float, float], week: int, start_tow_s: float,
               iono: IonoUtc | None = None) -> Assistance:
    """An `Assistance` from a geodetic position (deg, deg, m); bad values raise `ConfigError`."""
    lat, lon, h = (float(v) for v in lat_lon_h)
    if not (-90 <= lat <= 90 and -180 <= lon <= 360 and -1e4 < h < 1e5):
        raise ConfigError("approx_position", f"latitude, longitude (deg) and height (m) out of range: {lat_lon_h}")
    if not (0 <= week < 10_000 and 0 <= start_tow_s < 604_800):
        raise ConfigError("start_time", f"a full GPS week and a time of week in [0, 604800) s, got "
                                        f"{week}, {start_tow_s}")
    xyz = np.array(pymap3d.geodetic2ecef(lat, lon, h), float)
    return Assistance(xyz, int(week), float(start_tow_s), iono)


@dataclass
class VectorSolution:
    """The navigation filter's states, one per nav epoch after the hand-over.

    ``sample_time_s`` ``(K,)`` recording time of each epoch; ``state`` ``(K, 8)``
    ``[x, y, z, vx, vy, vz, b, d]`` (ECEF m, m/s; clock in m and m/s, against the
    receiver time ``sample_time_s + rx_offset_s``); ``cov`` ``(K, 8, 8)`` its covariance; ``prns`` the vector channels (those that joined later included); ``used`` ``(K, 32)``
    whether the output of the channel of each PRN (slot ``prn - 1``) entered the update;
    ``used_sat_pos_m`` ``(K,)`` of ``(n, 3)``: the positions of those satellites (the
    table's HDOP and VDOP come from them, for its rows only); ``handover_s`` the recording time of the
    hand-over fix; ``events`` what happened (``(time_s, text)``).
    """

    prns: tuple[int, ...] = ()
    handover_s: float | None = None
    rx_offset_s: float = 0.0
    week: int = -1
    sample_time_s: list[float] = field(default_factory=list)
    state: list[np.ndarray] = field(default_factory=list)
    cov: list[np.ndarray] = field(default_factory=list)
    used: list[np.ndarray] = field(default_factory=list)
    used_sat_pos_m: list[np.ndarray] = field(default_factory=list)
    events: list[tuple[float, str]] = field(default_factory=list)
    #: Per vector channel's PRN at the end of the run: the recording time of its next
    #: interval's start and its replica's transmit time there (s of week, SV time).
    replica_tx: dict[int, tuple[float, float]] = field(default_factory=dict)

    def table(self, rate_hz: float = 1.0) -> PositionTable | None:
        """The epochs nearest whole multiples of ``1 / rate_hz`` of recording time as a
        position table (the columns of `fixes.POSITION_COLUMNS`; DOPs of the vector channels), or None
        before any epoch."""
        if not self.sample_time_s:
            return None
        t = np.asarray(self.sample_time_s)
        x = np.asarray(self.state)
        grid = np.arange(np.ceil(t[0] * rate_hz), np.floor(t[-1] * rate_hz) + 1) / rate_hz
        k = np.unique(np.clip(np.searchsorted(t, grid), 0, t.size - 1))
        x, t = x[k], t[k]
        lat, lon, h = (np.asarray(v, float) for v in pymap3d.ecef2geodetic(x[:, 0], x[:, 1], x[:, 2]))
        ve, vn, vu = (np.asarray(v, float) for v in pymap3d.ecef2enuv(x[:, 3], x[:, 4], x[:, 5], lat, lon))
        n_used = np.asarray(self.used)[k].sum(axis=1)  # (rows over the 32 PRN slots)
        dops = np.array([_dops(self.used_sat_pos_m[j], x[i, :3]) for i, j in enumerate(k)]).reshape(-1, 2)
        columns = {"gps_week": np.full(k.size, self.week), "tow_s": t + self.rx_offset_s - x[:, 6] / _C,
                   "lat_deg": lat, "lon_deg": lon, "height_m": h, "vel_e_mps": ve, "vel_n_mps": vn, "vel_u_mps": vu,
                   "clock_bias_m": x[:, 6], "n_sats": n_used.astype(int), "hdop": dops[:, 0], "vdop": dops[:, 1]}
        used = [tuple(int(p) + 1 for p in np.flatnonzero(row)) for row in np.asarray(self.used)[k]]
        return PositionTable(columns, x[:, :3].copy(), t, used, np.zeros(k.size, int))


class _VectorClosure:
    """Marks a channel closed by the navigation filter (the tracker's closure slot)."""


_VECTOR = _VectorClosure()


class VectorSampleTracker(SampleTracker):
    """Scalar tracking, then vector tracking from the first fix (see the module text).

    Parameters
    ----------
    recording, config, acquisition, backend
        As `SampleTracker`.
    vector
        `VectorConfig`.
    rinex
        Ephemerides for satellites whose own have not been decoded yet (as ``--ephemeris``).
    ionosphere
        Apply the decoded Klobuchar model in the first fix and in the predictions.
    reference_week
        Full GPS week near the recording (resolves the decoded 10-bit week).
    assist
        `Assistance`: hand over without LNAV, as soon as four channels are bit-aligned,
        each replica's transmit time from the approximate position and start time
        (`_try_assisted_handover`).
    iono_fallback
        Klobuchar coefficients (a RINEX header's) for the LNAV hand-over where no page 18 is decoded.
    """

    def __init__(self, recording: Recording, config: TrackingConfig, acquisition: Acquisition,
                 vector: VectorConfig | None = None, *, rinex: Ephemerides | None = None, ionosphere: bool = True,
                 reference_week: int | None = None, assist: Assistance | None = None,
                 backend: str | None = None, iono_fallback: IonoUtc | None = None) -> None:
        super().__init__(recording, config, acquisition, backend=backend)
        if assist is not None and rinex is None:
            raise ConfigError("approx_position", "an assisted start needs the ephemerides of a RINEX navigation "
                                                 "file (--ephemeris)")
        self.vector = vector or VectorConfig()
        self.rinex = rinex
        self.assist = assist
        self.ionosphere = ionosphere
        self.reference_week = reference_week
        self.iono_fallback = iono_fallback  # Klobuchar where no page 18 is decoded (a RINEX header's)
        v = self.vector
        check_composition(registry.create("channel_filter", v.channel_filter, **v.channel_params),
                          registry.create("nav_filter", v.nav_filter, **v.nav_params))

    def run(self, acquisitions: list[AcquisitionResult], duration_s: float | None = None,
            progress: Any = None) -> TrackingResult:
        """As `SampleTracker.run`; the navigation filter's states go to ``self.solution``."""
        self.solution = VectorSolution()
        self.nav = None
        self.vslots = np.zeros(0, int)
        self.pending: dict[int, tuple] = {}
        self.next_try = max(self.vector.earliest_s, self.vector.try_every_s)
        self.next_assist = self.vector.earliest_s
        self.acq_doppler = np.zeros(32)
        self.held: dict[int, Ephemerides] = {}  # the records of dropped vector channels, by slot
        result = super().run(acquisitions, duration_s, progress)
        if self.nav is not None:  # what dates the vector channels' rows (`observables.assisted_timing`)
            tx = self._replica_tx(self.vslots)
            self.solution.replica_tx = {int(i) + 1: (float(self.start_sample[i]) / self.fs, float(t))
                                        for i, t in zip(self.vslots, tx)}
        return result

    # --- the tracker's hooks -------------------------------------------------------------

    def _add(self, prn: int, acq: AcquisitionResult, first_sample: int) -> None:
        super()._add(prn, acq, first_sample)
        self.acq_doppler[prn - 1] = acq.doppler_hz

    def _advance(self, c, t0: float) -> None:
        if c.stage == "vector":
            c.unlocked_ms = 0 if c.locked else c.unlocked_ms + c.coherent_ms
            # Only an estimate over a full window counts (a rejoined channel's first ones are short).
            low = (self.n_prompts[c.slot] >= self.config.cn0_window_ms
                   and c.cn0_dbhz < self.vector.loss_cn0_dbhz)
            c.low_cn0_ms = c.low_cn0_ms + c.coherent_ms if low else 0
            if c.low_cn0_ms >= self.vector.loss_ms:
                self._drop(c, t0)
            return
        if getattr(c, "vector_pending", False):  # closed by the filter at its next aligned boundary, never lost
            n = self.config.coherent_ms
            if (int(self.ms_index[c.slot]) + 1 - c.bit_edge) % n == 0:
                c.vector_pending = False
                c.record.events.append((t0, f"bit edge from the assisted transmit time (ms {c.bit_edge} mod 20)"))
                self._start(c, "extended", float(self.doppler[c.slot]), n)
                self._start_vector(c)
            return
        super()._advance(c, t0)

    def _step(self, filt, closure, slots: np.ndarray, w: np.ndarray) -> None:
        if slots.size == 1 and getattr(self.channels[int(slots[0]) + 1], "vector_pending", False):
            return  # handed over, waiting for its aligned boundary: the NCOs hold the state's prediction
        if closure is not _VECTOR:
            super()._step(filt, closure, slots, w)
            return
        i = int(slots[0])
        out = filt.checked_step({"correlators": Correlators.trusted(w[:, 0], w[:, 1], w[:, 2]),
                                 "nco_shift_chips": self.shift_chips[slots], "nco_shift_hz": self.shift_hz[slots]})
        self.shift_chips[i] = self.shift_hz[i] = 0.0
        end = int(self.start_sample[i])
        mid = 0.5 * (self.acc_t0[i] * self.fs + end)
        # The replica's transmit time at mid-interval: the chips its NCO generated since the
        # hand-over, less the half interval's chips at the rate it ran.
        tx_mid = self._replica_tx(np.array([i]))[0] - (end - mid) / self.fs * self.code_rate[i] / CA_CHIP_RATE_HZ
        self.pending[i] = (mid / self.fs, -float(np.ravel(out["code_error_chips"])[0]),
                           float(np.ravel(out["code_error_var_chips2"])[0]), float(np.ravel(out["freq_error_hz"])[0]),
                           float(np.ravel(out["freq_error_var_hz2"])[0]), tx_mid, float(self.doppler[i]))

    def _after_interval(self, idx: np.ndarray) -> None:
        now = float(self.start_sample[idx].min()) / self.fs
        if self.nav is None:
            if self.assist is not None and now >= self.next_assist:
                self.next_assist = now + _ASSIST_EVERY_S
                self._try_assisted_handover(now)
            elif self.assist is None and now >= self.next_try:
                self.next_try = now + self.vector.try_every_s
                self._try_handover()
        elif self.vslots.size and all(int(s) in self.pending for s in self.vslots):
            self._nav_step()

    # --- hand-over -----------------------------------------------------------------------

    def _replica_tx(self, slots: np.ndarray) -> np.ndarray:
        """Transmit time (GPS s of week, SV time) of the replica at each slot's start sample."""
        chips = self.ms_index[slots] * CA_CODE_LENGTH + self.code_phase[slots]
        return self.tx_anchor[slots] + (chips - self.chip_anchor[slots]) / CA_CHIP_RATE_HZ

    def _try_handover(self) -> None:
        ready = [c for c in self.channels.values() if c.stage == "extended" and c.locked]
        timings = {c.prn: channel_timing(c.record) for c in ready}
        timings = {p: t for p, t in timings.items() if t is not None and t.time_s.size > 1}
        if len(timings) < 4:
            return
        try:
            obs = observables(list(timings.values()), rate_hz=10.0)
        except ConfigError:
            return
        table = solve_epochs(obs, self.rinex, ionosphere=self.ionosphere, reference_week=self.reference_week,
                             iono=None if obs.iono_utc is not None else self.iono_fallback)
        if len(table) == 0:
            return
        records = {p: self._ephemeris(p, obs, float(table.sample_time_s[-1])) for p in timings}
        prns = tuple(sorted(p for p, r in records.items() if r is not None))
        if len(prns) < 4:
            return
        slots = np.array([p - 1 for p in prns])
        # Each replica's transmit time at its current start: from its last decoded row,
        # plus the chips generated since (no code-phase jumps in the extended stage).
        self.tx_anchor = np.zeros(len(self.active))
        self.chip_anchor = np.zeros(len(self.active))
        for p, i in zip(prns, slots):
            tm, rec = timings[p], self.channels[p].record
            t_row = rec.column("time_s")
            j = int(np.searchsorted(t_row, tm.time_s[-1]))
            chips = CA_CODE_LENGTH * rec.column("coherent_ms")[j:].sum() + self.code_phase[i] - rec.rows[j][4]
            self.tx_anchor[i] = tm.transmit_s[-1] + chips / CA_CHIP_RATE_HZ
            self.chip_anchor[i] = self.ms_index[i] * CA_CODE_LENGTH + self.code_phase[i]
        self.eph = _stack([records[p] for p in prns])
        self.iono = (obs.iono_utc or self.iono_fallback) if self.ionosphere else None
        e = len(table) - 1
        t_fix = float(table.sample_time_s[e])
        bias = float(table.columns["clock_bias_m"][e])
        self.rx_offset = float(table.columns["tow_s"][e] + bias / _C - t_fix)
        self._hand_over(prns, slots, table.ecef_m[e], bias, t_fix, full_week(obs.week, self.reference_week),
                        f"first fix with {len(table.used_prns[e])} satellites")

    def _assisted_transmit_times(self, chans: list, now_s: float, r0: np.ndarray
                                 ) -> tuple[list, Ephemerides, np.ndarray] | None:
        r"""The channels of ``chans`` with a healthy RINEX record, their records and each
        replica's transmit time (s of week, satellite time) at its current start sample,
        from the `Assistance`'s start time and position ``r0`` (None with fewer than four
        such channels).

        A replica at a code epoch has sent a whole number of milliseconds plus
        ``code_phase / 1.023 MHz``; the predicted transmit time
        :math:`t_{rx} - \lVert s - r_0\rVert / c + \Delta t_{SV}` from the approximate
        position :math:`r_0` and the start time picks the millisecond (the coarse-time
        resolution of van Diggelen, *A-GPS*, 2009, ch. 4). The receiver clock's offset
        modulo 1 ms is common to every channel: it is taken out first (the circular mean of
        the fractional residuals), so only the geometry's error must stay under 0.5 ms
        (~150 km of range).
        """
        a = self.assist
        records = {}
        for c in chans:
            try:
                records[c.prn] = self.rinex.select([f"G{c.prn:02d}"], a.start_tow_s + now_s)
            except KeyError:  # no healthy record of it in the file
                continue
        chans = [c for c in chans if c.prn in records]
        if len(chans) < 4:
            return None
        slots = np.array([c.slot for c in chans])
        eph = _stack([records[c.prn] for c in chans])
        t_rx = a.start_tow_s + self.start_sample[slots] / self.fs
        tx = t_rx - 0.075
        for _ in range(3):  # the flight time, iterated (it changes by < 1 us after two)
            st = satellite_state(eph, tx)
            pos = _rotate(st.position_m, t_rx - tx)
            tx = t_rx - np.linalg.norm(pos - r0, axis=-1) / _C + st.clock_l1_s
        sub_ms = self.code_phase[slots] / CA_CHIP_RATE_HZ
        residual_ms = (tx - sub_ms) * 1e3
        common = np.angle(np.mean(np.exp(2j * np.pi * residual_ms))) / (2 * np.pi)
        return chans, eph, np.round(residual_ms - common) * 1e-3 + sub_ms

    def _try_assisted_handover(self, now_s: float) -> None:
        """Close every active channel from its assisted transmit time
        (`_assisted_transmit_times`), whatever its scalar stage: the navigation filter
        starts from a least-squares fix on these pseudoranges, once every active channel
        has run `_ASSIST_SETTLE_MS` (its pull-in has narrowed the acquisition's Doppler).

        No lock, bit sync or LNAV is needed: the bit edges follow from the transmit times
        (LNAV bits start where the satellite's time is a whole multiple of 20 ms,
        IS-GPS-200 20.3.2), and a channel in 1 ms pull-in or tracking goes over at its
        next boundary of a ``coherent_ms`` interval within a bit (`_advance`)."""
        active = sorted((c for c in self.channels.values() if self.active[c.slot] and c.stage != "lost"),
                        key=lambda c: c.prn)
        if len(active) < 4 or any(self.ms_index[c.slot] < _ASSIST_SETTLE_MS for c in active):
            return
        a = self.assist
        fix, r0, previous = None, a.position_ecef_m, None
        # Resolve, fix, resolve again from the fix: a consistent resolution is one the fix
        # reproduces (a misresolved millisecond moves the fix, and the next resolution).
        for _ in range(_ASSIST_ITERATIONS):
            found = self._assisted_transmit_times(active, now_s, r0)
            if found is None:
                return
            chans, eph, tx_start = found
            if previous is not None and np.array_equal(previous, tx_start):
                break
            slots = np.array([c.slot for c in chans])
            t_s = self.start_sample[slots] / self.fs
            # Pseudoranges at a common receive epoch (the latest channel's start).
            t_fix = float(t_s.max())
            tx_fix = tx_start + (t_fix - t_s) * self.code_rate[slots] / CA_CHIP_RATE_HZ
            pr = _C * (a.start_tow_s + t_fix - tx_fix)
            # The residual test at the pull-in code phases' noise, not at a tracked code's.
            fix = solve_position(pr, tx_fix, eph, iono=a.iono if self.ionosphere else None, elevation_mask_deg=0.0,
                                 initial_ecef_m=a.position_ecef_m, sigma_m=self.vector.assisted_pseudorange_sigma_m)
            if fix is None:
                break
            previous, r0 = tx_start, fix.position_ecef_m
        else:
            fix = None  # the resolution did not settle
        if (fix is None or not np.all(fix.used) or np.nanmax(np.abs(fix.residuals_m)) > _ASSIST_MAX_RESIDUAL_M
                or np.linalg.norm(fix.position_ecef_m - a.position_ecef_m) > _ASSIST_RADIUS_M):
            self.solution.events.append((now_s, "assisted fix failed (no solution, a satellite excluded, residuals "
                                                "or distance to the approximate position too large): no hand-over"))
            self.next_assist = now_s + self.vector.try_every_s
            return
        prns = tuple(c.prn for c in chans)
        for c, tx_s in zip(chans, tx_start):
            if c.stage != "extended":  # (an extended channel is bit-aligned already)
                whole_ms = int(np.round((tx_s - self.code_phase[c.slot] / CA_CHIP_RATE_HZ) * 1e3))
                # The tracker labels the coming code period ms_index + 1 (`SampleTracker._advance`).
                c.bit_edge = (int(self.ms_index[c.slot]) + 1 - whole_ms) % 20
        self.tx_anchor = np.zeros(len(self.active))
        self.chip_anchor = np.zeros(len(self.active))
        self.tx_anchor[slots] = tx_start
        self.chip_anchor[slots] = self.ms_index[slots] * CA_CODE_LENGTH + self.code_phase[slots]
        self.eph = eph
        self.iono = a.iono if self.ionosphere else None
        self.rx_offset = a.start_tow_s
        vc = self.vector
        # A locked loop's Doppler (averaged over its last 20 ms), else the acquisition's: a
        # 1 ms pull-in loop that has not locked may have wandered tens of Hz from it.
        doppler = np.array([np.mean(c.record.column("doppler_hz")[-20:]) if c.locked else self.acq_doppler[c.slot]
                            for c in chans])
        self._hand_over(prns, slots, fix.position_ecef_m, fix.clock_bias_m, t_fix, a.week,
                        f"assisted fix with {int(np.sum(fix.used))} satellites (approximate position and start "
                        "time, RINEX ephemerides)", vc.assisted_pseudorange_sigma_m, vc.assisted_range_rate_sigma_mps,
                        doppler)

    def _hand_over(self, prns: tuple[int, ...], slots: np.ndarray, r: np.ndarray, bias: float, t_fix: float,
                   week: int, why: str, range_sigma_m: float | None = None,
                   rate_sigma_mps: float | None = None, doppler_hz: np.ndarray | None = None) -> None:
        """Start the navigation filter at fix ``r``, ``bias`` (recording time ``t_fix``) and
        close channels ``slots`` (``self.eph``, ``self.iono``, ``self.rx_offset`` and the
        replicas' transmit-time anchors set); the sigmas of the fix default to the config's."""
        # Velocity and clock drift from the channels' Dopplers (the PLL's, the best there is).
        self.vslots = slots
        v, d, G = self._velocity(slots, r, t_fix, doppler_hz)
        x0 = np.r_[r, v, bias, d]
        # The first fix's covariance from its geometry (G = [-e, 1]), position and clock
        # from the pseudoranges, velocity and drift from the Dopplers.
        info = np.linalg.inv(G.T @ G)
        vc = self.vector
        self.cov0 = np.zeros((8, 8))
        pc, vd = np.r_[0:3, 6], np.r_[3:6, 7]
        self.cov0[np.ix_(pc, pc)] = (range_sigma_m or vc.pseudorange_sigma_m)**2 * info
        self.cov0[np.ix_(vd, vd)] = (rate_sigma_mps or vc.range_rate_sigma_mps)**2 * info
        self.x_fix, self.t_fix = x0, t_fix
        self.iono_m = self._iono(slots, r, t_fix)
        s = self.solution
        s.prns, s.handover_s, s.rx_offset_s, s.week = prns, t_fix, self.rx_offset, week
        s.events.append((t_fix, f"{why}: vector tracking of PRN {', '.join(map(str, prns))}"))
        for p in prns:
            c = self.channels[p]
            if c.stage == "extended":
                self._start_vector(c)
            else:  # 1 ms stages: over at the next interval boundary within a bit (`_advance`)
                c.vector_pending = True  # its scalar loop stops steering (`_step`)
                self._leave_batch(c)
                c.join_tries = 3
        if doppler_hz is not None:  # an assisted start: a 1 ms pull-in loop may have wandered
            self.t_nav = t_fix  # every channel's NCOs from the first state at once
            self._command(slots, x0)
        self.nav = registry.create("nav_filter", self.vector.nav_filter, **self.vector.nav_params)
        self.nav_started = False

    def _ephemeris(self, prn: int, obs, sample_time_s: float) -> Ephemerides | None:
        decoded = [rec for ready, rec in obs.ephemeris.get(prn, []) if ready <= sample_time_s]
        rec = decoded[-1] if decoded else None
        if rec is None and self.rinex is not None:
            try:
                rec = self.rinex.select([f"G{prn:02d}"], float(obs.rx_time_s[-1]))
            except KeyError:
                rec = None
        return rec if rec is not None and rec.health[0] == 0 else None

    def _start_vector(self, c) -> None:
        self._leave_batch(c)
        v, cfg = self.vector, self.config
        T = c.coherent_ms * 1e-3
        c.stage = "vector"
        c.filter = registry.create("channel_filter", v.channel_filter, **v.channel_params)
        c.cn0_ref = max(c.cn0_dbhz, 20.0)
        c.filter.reset((1,), RunContext(coherent_time_s=T, early_late_spacing_chips=cfg.early_late_spacing_chips,
                                        epoch_interval_s=T, cn0_dbhz=c.cn0_ref,
                                        doppler_hz=float(self.doppler[c.slot])))
        c.closure = _VECTOR
        c.batch = None
        c.join_tries = 3  # steps alone: its outputs go to the navigation filter, one channel at a time
        c.stage_ms = 0
        c.unlocked_ms = 0
        c.low_cn0_ms = 0
        self.voting[c.slot] = False
        c.record.events.append((float(self.start_sample[c.slot]) / self.fs, "vector tracking"))

    # --- re-acquisition aided by the solution --------------------------------------------

    def _drop(self, c, t0: float) -> None:
        """Loss of lock of vector channel ``c`` (`VectorConfig.loss_cn0_dbhz` for
        ``loss_ms``): it leaves the navigation filter's updates and the tracker's active
        channels; its ephemeris is kept for the aided search (`_reacquire`), which may try
        it from the next re-acquisition round on."""
        i, v = c.slot, self.vector
        keep = self.vslots != i
        self.held[i] = self.eph.subset(np.flatnonzero(~keep))
        self.eph = self.eph.subset(np.flatnonzero(keep))
        self.iono_m = self.iono_m[keep]
        self.vslots = self.vslots[keep]
        self.pending.pop(i, None)
        self._leave_batch(c)
        c.stage = "lost"
        self.active[i] = False
        c.retry_at = int(self.start_sample[i])
        why = f"C/N0 estimate below {v.loss_cn0_dbhz:g} dB-Hz for {v.loss_ms} ms"
        c.record.events.append((t0, f"lost: {why}; out of the navigation filter, re-acquisition aided by the "
                                    "navigation solution"))
        self.solution.events.append((t0, f"PRN {c.prn} dropped from the vector loop ({why})"))

    def _reacquire(self, at: int, stop: int) -> None:
        """Once the navigation filter runs, every satellite it can predict (a RINEX record,
        or the kept record of a dropped vector channel) that is not in the loop is searched
        in its predicted window (`window_search`) and joins the loop when found; lost
        channels it cannot predict get the full search, as before the hand-over."""
        if self.nav is None or not self.nav_started:
            super()._reacquire(at, stop)
            return
        p = self.vector
        need = int(round(p.reacquire_coherent_ms * 1e-3 * self.fs)) * p.reacquire_noncoherent
        if at + need > stop:
            return
        t_s = at / self.fs
        unpredicted = []
        for prn in range(1, 33):
            c = self.channels.get(prn)
            if (c is not None and (c.stage != "lost" or c.retry_at > at)) or prn - 1 in self.vslots:
                continue
            predicted = self._predict_signal(prn, t_s)
            if predicted is None:
                if c is not None:
                    unpredicted.append(prn)
                continue
            record, window, tx_s, elevation = predicted
            if elevation < p.reacquire_elevation_deg:
                continue
            acq = window_search(self.rec.read(at, need), self.fs, self.if_hz, prn, window,
                                coherent_ms=p.reacquire_coherent_ms, noncoherent=p.reacquire_noncoherent,
                                alternate=p.reacquire_coherent_ms == 10, pfa=p.reacquire_pfa)
            if not acq.detected:
                continue
            per_code = self.fs * CA_CODE_LENGTH / CA_CHIP_RATE_HZ
            code_off = (acq.code_phase_samples - window.code_start_samples + per_code / 2) % per_code - per_code / 2
            self._add(prn, acq, at)
            self.held.pop(prn - 1, None)
            c = self.channels[prn]
            c.record.events.append((t_s, f"re-acquired in the window predicted by the navigation solution "
                                         f"({code_off:+.1f} samples, {acq.doppler_hz - window.doppler_hz:+.1f} Hz "
                                         f"from the prediction; window +-{window.code_halfwidth_samples:.1f} samples, "
                                         f"+-{window.doppler_halfwidth_hz:.1f} Hz)"))
            self.solution.events.append((t_s, f"PRN {prn} re-acquired by the aided search"))
            self._join(c, record, tx_s + acq.code_phase_samples / self.fs * (1 + window.doppler_hz / L1_FREQ_HZ))
        need = self.acquisition.samples_needed(self.fs)
        if unpredicted and at + need <= stop:  # (the scalar search of `SampleTracker._reacquire`)
            for acq in self.acquisition.acquire(self.rec.read(at, need), self.fs, self.if_hz, tuple(unpredicted)):
                if acq.detected:
                    self.records[acq.prn].events.append((t_s, "re-acquired"))
                    self._add(acq.prn, acq, at)

    def _predict_signal(self, prn: int, t_s: float):
        """The solution's prediction for ``prn`` at recording time ``t_s``: its RINEX
        record, the `SearchWindow` (the first code epoch after ``t_s``; half widths
        ``reacquire_sigmas`` standard deviations of the predicted range and rate, from the
        state covariance on the line of sight), the transmit time at ``t_s`` and the
        elevation (deg); None without a healthy record (the kept one of a dropped vector
        channel, else the RINEX file's)."""
        record = self.held.get(prn - 1)
        if record is None:
            if self.rinex is None:
                return None
            try:
                record = self.rinex.select([f"G{prn:02d}"], t_s + self.rx_offset)
            except KeyError:
                return None
        dt = t_s - self.t_nav
        x = self.x
        r, b = x[:3] + x[3:6] * dt, x[6] + x[7] * dt
        t_rx = t_s + self.rx_offset
        tx = t_rx - 0.075
        for _ in range(3):  # the flight time, iterated
            st = satellite_state(record, np.array([tx]))
            pos, vel = _rotate(st.position_m, np.array([t_rx - tx])), _rotate(st.velocity_mps, np.array([t_rx - tx]))
            dist, e = line_of_sight(pos, r)
            tx = t_rx - (float(dist[0]) + b - _C * float(st.clock_l1_s[0])) / _C
        e = e[0]
        rate = float((vel[0] - x[3:6]) @ e + x[7] - _C * st.clock_drift_s_s[0])
        doppler = -rate / L1_WAVELENGTH_M
        h = np.r_[-e, 1.0]
        cov = self.solution.cov[-1]
        pc, vd = np.r_[0:3, 6], np.r_[3:6, 7]
        sigma_range = float(np.sqrt(h @ cov[np.ix_(pc, pc)] @ h))
        sigma_rate = float(np.sqrt(h @ cov[np.ix_(vd, vd)] @ h))
        k = self.vector.reacquire_sigmas
        chips = (tx * 1e3 % 1.0) * CA_CODE_LENGTH  # sent of the current period at t_s
        code_rate = CA_CHIP_RATE_HZ * (1 + doppler / L1_FREQ_HZ)
        window = SearchWindow((CA_CODE_LENGTH - chips) / code_rate * self.fs, doppler,
                              k * sigma_range / CA_CHIP_LENGTH_M * self.fs / CA_CHIP_RATE_HZ,
                              k * sigma_rate / L1_WAVELENGTH_M)
        lat, lon, hgt = pymap3d.ecef2geodetic(*r)
        _, elevation, _ = pymap3d.ecef2aer(*pos[0], lat, lon, hgt)
        return record, window, tx, float(elevation)

    def _join(self, c, record: Ephemerides, tx_start_s: float) -> None:
        """Channel ``c`` (just added at a code epoch) joins the vector loop: its transmit
        time there is a whole millisecond (the predicted one rounded), its bit edge follows,
        and it goes over at its next aligned boundary (`_advance`)."""
        i = c.slot
        whole_ms = int(np.round(tx_start_s * 1e3))
        self.tx_anchor[i] = whole_ms * 1e-3 + self.code_phase[i] / CA_CHIP_RATE_HZ
        self.chip_anchor[i] = self.ms_index[i] * CA_CODE_LENGTH + self.code_phase[i]
        c.bit_edge = (int(self.ms_index[i]) + 1 - whole_ms) % 20
        records = {int(s): self.eph.subset(np.array([k])) for k, s in enumerate(self.vslots)}
        records[i] = record
        self.vslots = np.array(sorted(records))
        self.eph = _stack([records[int(s)] for s in self.vslots])
        r = self.x[:3]
        self.iono_m = self._iono(self.vslots, r, float(self.start_sample[i]) / self.fs)
        self.solution.prns = tuple(sorted(set(self.solution.prns) | {int(s) + 1 for s in self.vslots}))
        c.vector_pending = True
        self._leave_batch(c)
        c.join_tries = 3
        self._command(np.array([i]), self.x)

    # --- the navigation model ------------------------------------------------------------

    def _satellites(self, slots: np.ndarray, tx_s: np.ndarray, r: np.ndarray):
        """Satellite position and velocity (rotated into the receive-time frame), clock (m)
        and clock drift (m/s) at the transmit times ``tx_s`` of the channels ``slots``."""
        eph = self.eph.subset(np.searchsorted(self.vslots, slots))
        # One evaluation at the satellite-time stamp: its GPS time is ``clock`` (< 1 ms)
        # earlier, where the position is ``vel * clock`` back (the neglected acceleration
        # term, |a| dt^2 / 2 < 1e-6 m, and the clock's change over it are far below the
        # loop's noise).
        st = satellite_state(eph, tx_s)
        clock = st.clock_l1_s
        position = st.position_m - st.velocity_mps * clock[:, None]
        tau = np.linalg.norm(position - r, axis=-1) / _C
        return _rotate(position, tau), _rotate(st.velocity_mps, tau), _C * clock, _C * st.clock_drift_s_s

    def _iono(self, slots: np.ndarray, r: np.ndarray, t_s: float) -> np.ndarray:
        """Klobuchar delay (m) of each channel from position ``r`` (0 without page 18)."""
        if self.iono is None:
            return np.zeros(slots.size)
        pos, *_ = self._satellites(slots, self._replica_tx(slots), r)
        lat, lon, h = pymap3d.ecef2geodetic(*r)
        az, el, _ = pymap3d.ecef2aer(pos[:, 0], pos[:, 1], pos[:, 2], lat, lon, h)
        return _C * klobuchar_delay_s(self.iono.alpha, self.iono.beta, lat, lon, np.asarray(az), np.asarray(el),
                                      t_s + self.rx_offset)

    def _velocity(self, slots: np.ndarray, r: np.ndarray, t_s: float, doppler_hz: np.ndarray | None = None
                  ) -> tuple[np.ndarray, float, np.ndarray]:
        """Least-squares velocity and clock drift from the channels' Dopplers (their NCOs',
        or ``doppler_hz``) at position ``r``:
        :math:`-\\lambda f = (v_s - v)\\cdot e + d - c\\,\\Delta\\dot t_{SV}`; and the
        geometry matrix ``G = [-e, 1]``."""
        pos, vel, _, drift = self._satellites(slots, self._replica_tx(slots), r)
        _, e = line_of_sight(pos, r)
        doppler_hz = self.doppler[slots] if doppler_hz is None else doppler_hz
        y = -L1_WAVELENGTH_M * doppler_hz - np.sum(vel * e, axis=1) + drift
        H = np.hstack([-e, np.ones((slots.size, 1))])
        sol = np.linalg.lstsq(H, y, rcond=None)[0]
        return sol[:3], float(sol[3]), H

    def _predict(self, slots: np.ndarray, x: np.ndarray, t_s: np.ndarray, tx_s: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Pseudorange (m) and its rate (m/s) of channels ``slots`` predicted by state ``x``
        (at recording time ``t_s`` per channel, transmit times ``tx_s``)."""
        r = x[:3] + x[3:6] * (t_s - self.t_nav)[:, None]
        b = x[6] + x[7] * (t_s - self.t_nav)
        pos, vel, clock, drift = self._satellites(slots, tx_s, r)
        dist, e = line_of_sight(pos, r)
        rate = np.sum((vel - x[3:6]) * e, axis=-1) + x[7] - drift
        j = np.searchsorted(self.vslots, slots)
        return dist + b - clock + self.iono_m[j], rate

    # --- the loop ------------------------------------------------------------------------

    def _nav_step(self) -> None:
        slots = self.vslots
        meas = [self.pending.pop(int(s)) for s in slots]
        t_mid, code, var_code, freq, var_freq, tx_mid, dop = (np.array(m) for m in zip(*meas))
        T = self.config.coherent_ms * 1e-3
        if not self.nav_started:
            t_nav = float(np.mean(t_mid))
            x = self.x_fix.copy()
            x[:3] += x[3:6] * (t_nav - self.t_fix)
            x[6] += x[7] * (t_nav - self.t_fix)
            self.nav.reset((1,), RunContext(coherent_time_s=T, epoch_interval_s=T, initial_state=x[None],
                                            initial_cov=self.cov0))
            self.nav_started = True
            self.t_nav = t_nav
            self.x = x
        else:
            self.t_nav += T
        # Each replica's pseudorange and rate at the common epoch, in the filter's model
        # (satellite clock and ionosphere removed: h(x) = |s - r| + b).
        rate_rep = -L1_WAVELENGTH_M * dop
        range_rep = _C * (t_mid + self.rx_offset - tx_mid) + rate_rep * (self.t_nav - t_mid)
        tx_nav = tx_mid + (self.t_nav - t_mid) * (1 + dop / L1_FREQ_HZ)
        pos, vel, clock, drift = self._satellites(slots, tx_nav, self.x[:3])
        cn0 = np.array([self.channels[int(s) + 1].cn0_dbhz for s in slots])
        ref = np.array([self.channels[int(s) + 1].cn0_ref for s in slots])
        use = cn0 >= self.vector.min_cn0_dbhz
        lat, lon, _ = pymap3d.ecef2geodetic(*self.x[:3], deg=False)  # below the mask: driven, not used
        up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
        use &= line_of_sight(pos, self.x[:3])[1] @ up >= np.sin(np.radians(self.vector.elevation_mask_deg))
        # The thermal variances grow as 1/(C/N0): scale the ones set at the hand-over C/N0.
        scale = 10 ** ((ref - np.maximum(cn0, self.vector.min_cn0_dbhz)) / 10)
        var_code = np.where(use, var_code * scale, _IGNORE_VAR)
        var_freq = np.where(use, var_freq * scale, _IGNORE_VAR)
        inputs = {names.CODE_ERROR_CHIPS: code[None], names.CODE_ERROR_VAR_CHIPS2: var_code[None],
                  names.FREQ_ERROR_HZ: freq[None], names.FREQ_ERROR_VAR_HZ2: var_freq[None],
                  names.SAT_POS_M: pos, names.SAT_VEL_M_S: vel, names.NEXT_SAT_POS_M: pos,
                  names.NEXT_SAT_VEL_M_S: vel, names.REPLICA_RANGE_M: (range_rep + clock - self.iono_m)[None],
                  names.REPLICA_RATE_M_S: (rate_rep + drift)[None]}
        out = self.nav.checked_step(inputs)
        x = np.concatenate([out[names.POSITION_M][0], out[names.VELOCITY_M_S][0], out[names.CLOCK_M][0]])
        if not np.all(np.isfinite(x)):
            raise NumericalError(self.vector.nav_filter, [(0,)], len(self.solution.sample_time_s),
                                 f"non-finite state at the vector epoch {self.t_nav:.3f} s of the recording")
        self.x = x
        s = self.solution
        s.sample_time_s.append(self.t_nav)
        s.state.append(x)
        s.cov.append(np.array(out[names.COV])[0])
        mask = np.zeros(32, bool)
        mask[slots] = use
        s.used.append(mask)
        s.used_sat_pos_m.append(pos[use])
        self._command(slots, x)

    def _command(self, slots: np.ndarray, x: np.ndarray) -> None:
        """Move every vector channel's NCOs to the state's prediction at its next interval."""
        t = self.start_sample[slots] / self.fs
        tx = self._replica_tx(slots)
        rho, rate = self._predict(slots, x, t, tx)
        replica = _C * (t + self.rx_offset - tx)
        # Fewer metres of range = more chips generated.
        shift = (replica - rho) / CA_CHIP_LENGTH_M
        doppler = -rate / L1_WAVELENGTH_M
        self.code_phase[slots] += shift
        self.shift_chips[slots] = shift
        self.shift_hz[slots] = doppler - self.doppler[slots]
        self.doppler[slots] = doppler
        self.code_rate[slots] = CA_CHIP_RATE_HZ * (1 + doppler / L1_FREQ_HZ)


def _dops(sat_pos: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    """HDOP and VDOP of satellites ``sat_pos`` seen from ``r`` (NaN with fewer than four)."""
    if sat_pos.shape[0] < 4:
        return np.nan, np.nan
    _, e = line_of_sight(sat_pos, r)
    lat, lon, _ = pymap3d.ecef2geodetic(*r)
    east, north, up = pymap3d.ecef2enuv(e[:, 0], e[:, 1], e[:, 2], lat, lon)
    _, _, hdop, vdop = dop(np.stack([east, north, up], axis=-1))
    return hdop, vdop


def _rotate(v: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """ECEF vectors of transmit time expressed in the ECEF frame ``tau_s`` later (Earth rotation)."""
    th = _OMEGA_E * tau_s
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=-1)


def _stack(records: list[Ephemerides]) -> Ephemerides:
    return Ephemerides(np.concatenate([r.sv for r in records]), np.concatenate([r.toc_s for r in records]),
                       {k: np.concatenate([r.elements[k] for r in records]) for k in records[0].elements},
                       np.concatenate([r.health for r in records]), np.concatenate([r.iode for r in records]))
