"""Several signals of one recording to one set of fixes (GPS L1 C/A with Galileo E1-B, or
with BeiDou B1I on its own carrier).

:func:`receive_signals` acquires and tracks each signal of a `SignalSet` in turn over the
same recording (one scalar `SampleTracker` per signal), dates each channel from its own
message (`decoded.NavMessage.timing`: LNAV subframes, the I/NAV GST), puts every channel's rows on the same receiver epochs (`observables.observables`)
and solves each epoch with `pvt.solve_position`, which estimates one receiver clock per
time system (GPS time, Galileo System Time: the inter-system offset, GGTO plus the
receiver's inter-system bias, is a state; module text of `gnssframework.navigation.pvt`).
With ``broadcast_ggto`` the GGTO decoded from I/NAV word type 10 (`inav_params.Ggto`) is
taken as known instead (`broadcast_time_offsets`): Galileo joins GPS's clock, one state
fewer, but any receiver inter-system bias (between its L1 C/A and E1-B paths) then goes
into the fixes unmodelled.

A satellite of the ``i``-th signal is numbered ``i x KEY_STEP + PRN`` in the observables
and the fixes (`SignalSet.key`): GPS PRN 5 is 5 and Galileo E11 is 1011 in
``GPS+Galileo``; `SignalSet.rinex_satellite` names it (``G05``, ``E11``).

Signals on different carriers (GPS L1 C/A at 1575.42 MHz with BeiDou B1I at 1561.098 MHz)
are taken from one wide-band recording: its IF (``--if``, the SigMF centre frequency) is the
first signal's, and each other signal is searched and tracked at that IF plus the
difference of the carriers (`Recording.tuned`). Each satellite's Doppler, group delay and
ionospheric scale are then its own signal's (`SignalSet.carrier_freq_hz_of`, read by
`pvt.solve_position`); a block that takes one wavelength for all (a navigation filter)
refuses such a set in one line (`SignalSet.wavelength_m`).

Two signals of one system are one observable when they share the carrier and the RINEX
observation codes and no PRN: BeiDou B1I from the D1 satellites (`beidou-b1i`, NH20) and from
the GEOs (`beidou-b1i-geo`, D2), two descriptions because a description holds one symbol
period. Each is searched and dated on its own (D1's SOW, D2's); the satellites share the
system's receiver clock, and the outputs that list a system once (the RINEX observation
header, NMEA GSA/GSV, RTCM MSM) take them together (`SignalSet.groups`). Two observables of
one system (GPS L1 C/A with L2C) are refused: that is the ionosphere-free mode's
(`dual_observables`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ...errors import ConfigError
from ...navigation.ephemeris import Ephemerides
from ...navigation.bds_iono import BdsKlobuchar
from ...navigation.lnav import IonoUtc
from ...signal.spec import SignalSpec
from ..acquisition.report import acquire_recording
from ..acquisition.search import Acquisition
from ..channels import TrackingConfig, TrackingResult
from ..channels.groups import track_in_groups
from ..frontend.recording import Recording
from .fixes import full_week, solve_epochs
from .decoded import MESSAGES, navigation_message
from .observables import ChannelTiming, Observables, observables
from .receive import ReceiveResult

__all__ = ["SignalSet", "KEY_STEP", "receive_signals", "broadcast_time_offsets"]

#: The satellite numbers of one signal of a `SignalSet` (every signal's PRNs are below it).
KEY_STEP = 1000


@dataclass(frozen=True)
class SignalSet:
    """Signals positioned together: the `SignalSpec` attributes the fixes and the RINEX
    observation file ask of a signal (``rinex_satellite``, ``wavelength_m``, ``system``,
    ``name``), over the numbering ``index x KEY_STEP + PRN`` (module text). One signal per
    system, or several of one observable (`groups`; module text)."""

    signals: tuple[SignalSpec, ...]

    def __post_init__(self) -> None:
        if len(self.signals) < 2:
            raise ConfigError("signal", "a signal set holds two signals or more")
        names = [s.name for s in self.signals]
        if len(set(names)) != len(names):
            raise ConfigError("signal", f"a signal given twice: {', '.join(names)}")
        for i, a in enumerate(self.signals):
            for b in self.signals[i + 1 :]:
                if a.system == b.system and not _one_observable(a, b):
                    raise ConfigError(
                        "signal",
                        f"{a.name} and {b.name}: two signals of system {a.system} are positioned together "
                        "only as one observable (one carrier, the same RINEX observation codes, no PRN in "
                        "both, as BeiDou B1I's D1 and GEO satellites); give one of them",
                    )
        for s in self.signals:
            if not any(m.carried_by(s) for m in MESSAGES):
                raise ConfigError(
                    "signal",
                    f"{s.name}: not positioned here (a signal whose message the receiver decodes: LNAV, "
                    "I/NAV, CNAV, F/NAV or D1)",
                )

    @property
    def name(self) -> str:
        return "+".join(s.name for s in self.signals)

    @property
    def system(self) -> str:
        """``"M"`` (mixed, RINEX 3.04 4.4)."""
        return "M"

    @property
    def wavelength_m(self) -> float:
        """The signals' one carrier wavelength; refused, in one line, for signals on
        different carriers (a block asking for one wavelength would scale some Dopplers
        wrongly: `carrier_freq_hz_of` gives each satellite's)."""
        carriers = {s.carrier_freq_hz for s in self.signals}
        if len(carriers) != 1:
            raise ConfigError(
                "signal",
                f"{self.name}: on different carriers ({', '.join(f'{c / 1e6:g} MHz' for c in sorted(carriers))}); "
                "this block takes one wavelength for every satellite: give signals on one carrier",
            )
        return self.signals[0].wavelength_m

    @property
    def groups(self) -> tuple[tuple[SignalSpec, tuple[int, ...]], ...]:
        """Each system's signals, in the set's order of systems: ``(first signal, indices of
        the system's signals)``. Signals of one system are one observable (``__post_init__``):
        the outputs that list a system once (a RINEX header's observation types, NMEA's
        GSA/GSV, an RTCM MSM) take the first signal for all of its satellites."""
        out: dict[str, tuple[SignalSpec, list[int]]] = {}
        for i, s in enumerate(self.signals):
            out.setdefault(s.system, (s, []))[1].append(i)
        return tuple((s, tuple(idx)) for s, idx in out.values())

    def carrier_freq_hz_of(self, letters: np.ndarray) -> np.ndarray:
        """Each satellite's carrier (Hz), by its RINEX system letter (a system's signals share
        one carrier)."""
        by_system = {s.system: s.carrier_freq_hz for s in self.signals}
        letters = np.asarray(letters).astype("U1")
        unknown = sorted(set(letters.tolist()) - set(by_system))
        if unknown:
            raise ConfigError("systems", f"{self.name} holds no signal of system {', '.join(unknown)}")
        systems, index = np.unique(letters, return_inverse=True)
        return np.array([by_system[str(x)] for x in systems], float)[index].reshape(letters.shape)

    def if_offset_hz(self, index: int) -> float:
        """Where the ``index``-th signal lies from the first in a recording of both: the
        difference of their carriers (Hz)."""
        return self.signals[index].carrier_freq_hz - self.signals[0].carrier_freq_hz

    def key(self, index: int, prn: int) -> int:
        """The number of PRN ``prn`` of the ``index``-th signal."""
        return index * KEY_STEP + int(prn)

    def signal_of(self, key: int) -> SignalSpec:
        return self.signals[int(key) // KEY_STEP]

    def rinex_satellite(self, key: int) -> str:
        """The RINEX 3 satellite name of ``key`` (``G05``, ``E11``)."""
        return self.signal_of(key).rinex_satellite(int(key) % KEY_STEP)


def _one_observable(a: SignalSpec, b: SignalSpec) -> bool:
    """Whether two signals of one system make one observable: the same carrier and RINEX
    observation codes, disjoint PRNs (BeiDou B1I from the D1 satellites and from the GEOs)."""
    return (
        a.carrier_freq_hz == b.carrier_freq_hz
        and a.rinex_obs_types == b.rinex_obs_types
        and not set(a.prns) & set(b.prns)
    )


def broadcast_time_offsets(obs: Observables, reference_week: int | None = None) -> dict[str, float] | None:
    """``{"E": GGTO}`` (s, GST - GPST; Galileo OS SIS ICD 5.1.8) from the decoded word type 10
    (`Observables.galileo`) at the middle epoch of ``obs`` (the receiver clock, its bias of
    at most a millisecond or so is nothing to a drift A1G of 1e-14 s/s), in the GPS week of
    `fixes.full_week`; None without a decoded GGTO or a known week."""
    ggto = obs.galileo.ggto if obs.galileo is not None else None
    week = full_week(obs.week, reference_week, obs.week_bits)
    if ggto is None or week < 0 or obs.rx_time_s.size == 0:
        return None
    return {"E": ggto.offset_s(week, float(obs.rx_time_s[obs.rx_time_s.size // 2]))}


def receive_signals(
    recording: Recording,
    acquisition: Acquisition,
    configs: list[TrackingConfig],
    signals: SignalSet,
    *,
    duration_s: float | None = None,
    rate_hz: float = 1.0,
    rinex: Ephemerides | None = None,
    ionosphere: bool = True,
    troposphere: bool = False,
    reference_week: int | None = None,
    weighting: str | None = None,
    iono_fallback: IonoUtc | BdsKlobuchar | None = None,
    progress: Any = None,
    broadcast_ggto: bool = False,
    workers: int | str | None = None,
) -> ReceiveResult:
    """Acquire, track and date every signal of ``signals`` (``configs[i]`` tracks the
    ``i``-th) and solve their satellites together (module text). ``rinex`` holds the
    records of every system (`read_rinex_nav` with ``systems="GE"``); the Klobuchar
    coefficients of a decoded LNAV page 18 (else ``iono_fallback``) correct every satellite,
    scaled to its own carrier. A signal on another carrier than the first is read at the
    recording's IF plus the carriers' difference (module text). The result's tracking and observables are keyed by
    `SignalSet.key`. ``broadcast_ggto``: take the decoded GGTO as known
    (`broadcast_time_offsets`; estimated as before when no word type 10 was decoded).
    ``workers``: each signal's channels tracked in that many processes (`receive.receive`'s)."""
    if len(configs) != len(signals.signals):
        raise ConfigError("configs", f"one tracking config per signal: {len(configs)} for {len(signals.signals)}")
    channels: dict = {}
    found_all: list = []
    timings: list[ChannelTiming | None] = []
    duration = 0.0
    for i, (signal, config) in enumerate(zip(signals.signals, configs)):
        shift = signals.if_offset_hz(i)
        rec = recording if shift == 0.0 else recording.tuned(recording.info.if_hz + shift)
        found = [r for r in acquire_recording(rec, acquisition, None, signal=signal) if r.detected]
        found_all += found
        tracking = track_in_groups(
            rec, config, acquisition, found, duration_s, workers=workers, signal=signal, progress=progress
        )
        duration = max(duration, tracking.duration_s)
        for prn, ch in tracking.channels.items():
            key = signals.key(i, prn)
            channels[key] = ch
            t = navigation_message(signal).timing(ch, signal)
            if t is not None:
                timings.append(replace(t, prn=key))
    tracking_all = TrackingResult(channels, found_all, duration, configs[0].channel_filter)
    if not any(t is not None and t.time_s.size > 1 for t in timings):
        return ReceiveResult(tracking_all, None, None)
    obs = observables(timings, rate_hz)
    iono = iono_fallback if obs.iono_utc is None and obs.bds_iono is None else None
    offsets = broadcast_time_offsets(obs, reference_week) if broadcast_ggto else None
    table = solve_epochs(
        obs,
        rinex,
        ionosphere=ionosphere,
        troposphere=troposphere,
        iono=iono,
        reference_week=reference_week,
        weighting=weighting,
        signal=signals,  # type: ignore[arg-type]
        time_offsets_s=offsets,
    )
    return ReceiveResult(tracking_all, obs, table, table)
