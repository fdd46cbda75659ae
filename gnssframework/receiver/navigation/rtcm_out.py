"""RTCM 3 MSM7 observation messages of a receiver's observables (``observations.rtcm3``).

One Multiple Signal Message of type 7 per epoch (RTCM 10403.3 section 3.5.12: 1077 GPS,
1117 QZSS, 1097 Galileo, 1127 BeiDou), in a transport frame (preamble 0xD3, 6 reserved
bits, 10-bit length, the message, CRC-24Q of section 4). Its fields:

* header: DF002 message number, DF003 station 0, DF004 epoch time (the receiver clock's
  time of week in whole ms, 30 bits; BeiDou's DF427 is in BDT, 14 s less), DF393 multiple
  message 0, DF409 IODS 0, 7 reserved bits, DF411 clock steering 0, DF412 external clock 0,
  DF417 smoothing 0, DF418 interval 0, DF394 the 64-bit satellite mask, DF395 the 32-bit
  signal mask (one signal: L1 C/A is signal ID 2, table 3.5-91; B1I's 2I is 2 too,
  table 3.5-108) and DF396 the cell mask (one bit per satellite);
* per satellite: DF397 whole ms of rough range (8 bits), DF419 extended information
  (4 bits, 0), DF398 rough range modulo 1 ms (10 bits, 2^-10 ms), DF399 rough phase range
  rate (14 bits, m/s);
* per cell: DF405 fine pseudorange (20 bits, 2^-29 ms), DF406 fine phase range (24 bits,
  2^-31 ms), DF407 lock time indicator (10 bits, table 3.5-79), DF420 half-cycle ambiguity,
  DF408 C/N0 (10 bits, 2^-4 dB-Hz), DF404 fine phase range rate (15 bits, 0.0001 m/s).

Ranges are in light milliseconds (299 792.458 m). The epoch time of an MSM is a whole
millisecond; an observables epoch between two (the receiver clock's grid need not fall on
one) is moved to the nearest with its Doppler, pr(t + dt) = pr(t) - λ D dt and
φ(t + dt) = φ(t) - D dt (the phase in RINEX's sign, growing with range), exact for a
constant range rate and within λ |dD/dt| dt² / 2 (under a micrometre) otherwise. The
carrier phase, whose accumulated count starts anywhere, is offset by whole cycles at the
start of each arc (lock lost or no phase before) to lie on the pseudorange, as the fine
phase range field (±2^-8 ms, ±1171 m about the rough range) requires; a phase that drifts
outside it is sent invalid. The lock time is the time since that arc's start (a slip
restarts it, so a decoder sees the loss of lock). A signal without a phase or a Doppler
sends those fields invalid (the spec's most negative values).

Several signals (`multi_receive.SignalSet`) send one MSM7 per system and epoch (1077 and
1097), all but the epoch's last with DF393 1; two signals of one system (BeiDou B1I from its
D1 and GEO satellites: one observable) share their system's. The bits are packed here
(pyrtcm, the reference decoder of the tests, reads MSMs but does not build them).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...navigation.fec import crc24q_bits
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .observables import SPEED_OF_LIGHT_MPS, Observables

__all__ = ["msm7_frames", "write_rtcm", "crc24q", "lock_time_indicator", "MSM7_MESSAGE"]

#: MSM7 message number per RINEX system letter (RTCM 10403.3 table 3.5-75).
MSM7_MESSAGE = {"G": 1077, "E": 1097, "J": 1117, "C": 1127}
#: MSM signal ID of a RINEX observation code, per system (tables 3.5-91, 3.5-99, 3.5-105).
_SIGNAL_ID = {"G": {"1C": 2}, "E": {"1C": 2, "1B": 4, "1X": 5}, "J": {"1C": 2}, "C": {"2I": 2}}
#: MSM satellite ID = PRN - this (QZSS PRN 193 is satellite 1).
_SATELLITE_OFFSET = {"G": 0, "E": 0, "J": 192, "C": 0}
#: The epoch time's scale: GPS time less this (ms); BeiDou's DF427 is BDT, GPST - 14 s.
_EPOCH_OFFSET_MS = {"C": 14_000}
_LIGHT_MS_M = SPEED_OF_LIGHT_MPS * 1e-3
_WEEK_MS = 604_800_000

#: The longest message an RTCM 3 frame carries: its 10-bit length field.
MAX_MESSAGE_BYTES = 2**10 - 1


def crc24q(data: bytes) -> int:
    """CRC-24Q of ``data`` (RTCM 10403.3 section 4.2: polynomial 0x1864CFB, initial 0), by
    `gnssframework.navigation.fec.crc24q_bits` (the same code as Galileo I/NAV's)."""
    if not data:
        return 0
    return int(crc24q_bits(np.unpackbits(np.frombuffer(bytes(data), dtype=np.uint8))))


def lock_time_indicator(lock_ms: float) -> int:
    """DF407 of a lock time (ms): RTCM 10403.3 table 3.5-79 (1 ms steps up to 64 ms, then
    steps doubling every doubling of the time, 704 from 67 108 864 ms on)."""
    t = int(round(max(lock_ms, 0.0)))
    if t < 64:
        return t
    for k in range(1, 21):  # [2^(k+5), 2^(k+6)) in steps of 2^k from indicator 32 k + 32
        if t < 2 ** (k + 6):
            return (t >> k) + 32 * k
    return 704


class _Bits:
    def __init__(self) -> None:
        self.value, self.size = 0, 0

    def put(self, value: int, width: int) -> None:
        self.value = (self.value << width) | (int(value) & ((1 << width) - 1))
        self.size += width

    def to_bytes(self) -> bytes:
        pad = -self.size % 8
        return (self.value << pad).to_bytes((self.size + pad) // 8, "big")


def _frame(message: bytes) -> bytes:
    if len(message) > MAX_MESSAGE_BYTES:
        raise ConfigError("observables", f"an MSM of {len(message)} bytes is longer than a frame's {MAX_MESSAGE_BYTES}")
    head = bytes([0xD3, (len(message) >> 8) & 0x03, len(message) & 0xFF])
    return head + message + crc24q(head + message).to_bytes(3, "big")


def _aligned_phase_m(obs: Observables, pr_m: np.ndarray, phase_m: np.ndarray, wavelength_m: float) -> tuple:
    """The phase (m) offset per arc by whole cycles onto the pseudorange, and each cell's
    arc start time (s of the receiver clock, NaN without phase)."""
    E, N = pr_m.shape
    out = np.full((E, N), np.nan)
    start = np.full((E, N), np.nan)
    offset = np.full(N, np.nan)
    arc_t = np.full(N, np.nan)
    t = np.unwrap(np.asarray(obs.rx_time_s, float), period=604_800.0)
    lost = (obs.lli.astype(int) & 1).astype(bool) if obs.lli is not None else np.zeros((E, N), bool)
    for e in range(E):
        ok = np.isfinite(phase_m[e]) & np.isfinite(pr_m[e])
        new = ok & (lost[e] | np.isnan(offset))
        offset[new] = np.round((pr_m[e, new] - phase_m[e, new]) / wavelength_m) * wavelength_m
        arc_t[new] = t[e]
        out[e, ok] = phase_m[e, ok] + offset[ok]
        start[e, ok] = arc_t[ok]
        offset[~ok] = np.nan  # a gap ends the arc
    return out, start


def msm7_frames(obs: Observables, signal: SignalSpec = GPS_L1CA, station_id: int = 0) -> list[bytes]:
    """One framed MSM7 per epoch of ``obs`` with a pseudorange (see the module text); of
    several signals (``signal`` a `multi_receive.SignalSet`), one per system and epoch, the
    epoch's messages in the set's order, each but the last with DF393 (multiple message) 1.

    Raises
    ------
    ConfigError
        For a system or observation code without an MSM7 signal here.
    """
    groups = getattr(signal, "groups", None)
    if groups is None:
        return [frame for _, frame in _msm7(obs, signal, station_id)]
    from .multi_receive import KEY_STEP

    index = np.asarray(obs.prn, int) // KEY_STEP
    # A system's signals in one MSM (one observable: `SignalSet.groups`).
    parts = [_columns(obs, np.flatnonzero(np.isin(index, members)), KEY_STEP) for _, members in groups]
    signals = [first for first, _ in groups]
    sent = [_msm7_epochs(p) for p in parts]
    frames = []
    for i, (part, one) in enumerate(zip(parts, signals)):
        later = np.zeros(obs.rx_time_s.size, bool)
        for s in sent[i + 1 :]:
            later |= s
        frames += [(e, i, f) for e, f in _msm7(part, one, station_id, later)]
    return [f for _, _, f in sorted(frames, key=lambda x: (x[0], x[1]))]


def _columns(obs: Observables, cols: np.ndarray, key_step: int) -> Observables:
    """The satellites ``cols`` of ``obs``, their keys back to PRNs (``key mod key_step``)."""
    from dataclasses import replace

    return replace(
        obs,
        prn=np.asarray(obs.prn, int)[cols] % key_step,
        transmit_s=obs.transmit_s[:, cols],
        pseudorange_m=obs.pseudorange_m[:, cols],
        doppler_hz=obs.doppler_hz[:, cols],
        carrier_cycles=obs.carrier_cycles[:, cols],
        cn0_dbhz=obs.cn0_dbhz[:, cols],
        lli=None if obs.lli is None else obs.lli[:, cols],
    )


def _msm7_epochs(obs: Observables) -> np.ndarray:
    """Which epochs of ``obs`` get an MSM: those with a pseudorange an MSM can carry."""
    pr = np.asarray(obs.pseudorange_m, float)
    return np.any(np.isfinite(pr) & (pr > 0) & (pr < 255 * _LIGHT_MS_M), axis=1)


def _msm7(
    obs: Observables, signal: SignalSpec, station_id: int = 0, more: np.ndarray | None = None
) -> list[tuple[int, bytes]]:
    """``(epoch, frame)`` of `msm7_frames` for one signal, DF393 set at the epochs of ``more``."""
    system = signal.system
    if system not in MSM7_MESSAGE or signal.rinex_code not in _SIGNAL_ID[system]:
        raise ConfigError("signal", f"no MSM7 signal for {signal.name} (RINEX {system} {signal.rinex_code})")
    wavelength_m = SPEED_OF_LIGHT_MPS / signal.carrier_freq_hz
    t = np.asarray(obs.rx_time_s, float)
    t_ms = np.round(t * 1e3)
    dt = t_ms * 1e-3 - t  # to the epoch's whole millisecond
    dop = np.asarray(obs.doppler_hz, float)
    pr = obs.pseudorange_m - wavelength_m * dop * dt[:, None]
    phase = np.asarray(obs.carrier_cycles, float) * wavelength_m - wavelength_m * dop * dt[:, None]
    phase, arc_start = _aligned_phase_m(obs, pr, phase, wavelength_m)
    lock_ms = (np.unwrap(t, period=604_800.0)[:, None] - arc_start) * 1e3
    rate = -wavelength_m * dop  # m/s, positive as the range grows
    sat_id = np.asarray(obs.prn, int) - _SATELLITE_OFFSET[system]
    if np.any((sat_id < 1) | (sat_id > 64)):
        raise ConfigError("observables", f"PRNs {list(obs.prn)} are not MSM satellites 1-64 of {signal.name}")
    frames = []
    for e in range(t.size):
        sats = np.flatnonzero(np.isfinite(pr[e]) & (pr[e] > 0) & (pr[e] < 255 * _LIGHT_MS_M))
        if not sats.size:
            continue
        sats = sats[np.argsort(sat_id[sats])]
        b = _Bits()
        for value, width in (
            (MSM7_MESSAGE[system], 12),
            (station_id, 12),
            ((int(t_ms[e]) - _EPOCH_OFFSET_MS.get(system, 0)) % _WEEK_MS, 30),
            (int(more is not None and more[e]), 1),
            (0, 3),
            (0, 7),
            (0, 2),
            (0, 2),
            (0, 1),
            (0, 3),
        ):
            b.put(value, width)
        b.put(sum(1 << (64 - int(s)) for s in sat_id[sats]), 64)
        b.put(1 << (32 - _SIGNAL_ID[system][signal.rinex_code]), 32)
        b.put((1 << sats.size) - 1, sats.size)  # every satellite has the one signal
        range_ms = pr[e, sats] / _LIGHT_MS_M
        rough = np.round(range_ms * 1024.0) / 1024.0  # whole ms and 2^-10 ms
        r = rate[e, sats]
        rough_rate = np.where(np.isfinite(r), np.round(np.nan_to_num(r)), np.nan)
        for value in np.floor(rough):
            b.put(int(value), 8)
        for _ in sats:
            b.put(0, 4)
        for value in rough:
            b.put(int(round((value - np.floor(value)) * 1024.0)), 10)
        for value in rough_rate:
            b.put(-8192 if not np.isfinite(value) or abs(value) > 8191 else int(value), 14)
        fine_pr = np.round((range_ms - rough) / 2.0**-29)
        for value in fine_pr:
            b.put(int(value) if abs(value) < 2**19 else -(2**19), 20)
        fine_phase = np.round((phase[e, sats] / _LIGHT_MS_M - rough) / 2.0**-31)
        for value in fine_phase:
            b.put(int(value) if np.isfinite(value) and abs(value) < 2**23 else -(2**23), 24)
        for value in lock_ms[e, sats]:
            b.put(lock_time_indicator(value) if np.isfinite(value) else 0, 10)
        half = ((obs.lli[e, sats].astype(int) >> 1) & 1) if obs.lli is not None else np.zeros(sats.size, int)
        for value in half:
            b.put(int(value), 1)
        cn0 = obs.cn0_dbhz[e, sats]
        for value in cn0:
            b.put(int(np.clip(np.round(value * 16.0), 0, 2**10 - 1)) if np.isfinite(value) else 0, 10)
        fine_rate = np.round((r - rough_rate) / 1e-4)
        for value in fine_rate:
            b.put(int(value) if np.isfinite(value) and abs(value) < 2**14 else -(2**14), 15)
        frames.append((e, _frame(b.to_bytes())))
    return frames


def write_rtcm(path: str | Path, obs: Observables, week: int | None = None, signal: SignalSpec = GPS_L1CA) -> Path:
    """``observations.rtcm3``: `msm7_frames` one after the other (``week`` is not sent:
    MSMs carry the time of week only; it is taken for the callers' symmetry with
    `rinex_obs.write_rinex_obs`)."""
    frames = msm7_frames(obs, signal)
    if not frames:
        raise ConfigError("observables", "no epoch holds a pseudorange: nothing to write")
    path = Path(path)
    path.write_bytes(b"".join(frames))
    return path
