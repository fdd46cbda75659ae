"""SBAS-corrected fixes of a receiver's GPS L1 C/A observables, from SBAS messages read from
a file (`navigation.sbas_files`: RTKLIB's ``.sbs`` log or EGNOS Message Server ``.ems``), or
decoded from the recording's own SBAS L1 GEOs (``SbasOptions.from_signal``: `receive` tracks
them beside GPS and dates each message with `signal_records`).

At each epoch `fixes.solve_epochs` replays the GEO's messages up to the epoch's time
(`sbas_files.SbasReplay`) and solves with `sbas_pvt.solve_position_sbas` (DO-229's
corrections, weights and protection levels); the velocity and clock drift are those of the
epoch's broadcast fix (SBAS corrects ranges, not Dopplers). An epoch the corrections do not
cover (fewer than four satellites corrected, the ionospheric grid missing) keeps its
broadcast fix, marked by ``sbas_sats`` 0 and protection levels NaN (`SBAS_COLUMNS`).
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field

import numpy as np

from ...errors import ConfigError
from ...navigation.sbas_files import SbasRecord, SbasReplay, busiest_prn
from ...navigation.sbas_message import MESSAGE_SYMBOLS
from ...navigation.sbas_pvt import SBAS_MODES
from ...navigation.weeks import gps_calendar
from ...signal.sbas_l1 import SBAS_L1
from ...signal.spec import SignalSpec
from .sbas_stream import SbasChannel

__all__ = ["SbasOptions", "SBAS_COLUMNS", "day_of_year", "sbas_corrects", "signal_records", "merged_records"]

#: Columns ``positions.csv`` adds with SBAS: DO-229's protection levels (m; NaN where the
#: fix is the broadcast one) and the number of satellites corrected (0: not corrected).
SBAS_COLUMNS = ("hpl_m", "vpl_m", "sbas_sats")
#: One message's time on the signal: its 500 symbols of 2 ms (DO-229 A.4.2, 250 bit/s at rate 1/2).
_MESSAGE_S = MESSAGE_SYMBOLS * 0.002


@dataclass(frozen=True)
class SbasOptions:
    """SBAS corrections for a receiver's fixes: the messages ``records`` (of any GEOs), the
    GEO ``prn`` followed (default: the one with the most messages), the protection
    levels' ``mode`` (`sbas_pvt.SBAS_MODES`) and the receiver's code noise ``sigma_noise_m``
    in σ_air (0.36 m, DO-229's airborne bound for a receiver that smooths its code with the
    carrier; this receiver's unsmoothed code at 45 dB-Hz has about 1.7 m, and protection
    levels made with less do not bound its errors). ``from_signal``: `receive` also tracks the
    recording's SBAS L1 GEOs (``prn``'s only, when given) and adds the messages they carry
    (`signal_records`; ``records`` may then be empty).

    Raises
    ------
    ConfigError
        For no messages (and not ``from_signal``), a PRN without messages in ``records``, or
        an unknown mode.
    """

    records: tuple[SbasRecord, ...] = field(repr=False)
    prn: int | None = None
    mode: str = "pa"
    sigma_noise_m: float = 0.36
    from_signal: bool = False

    def __post_init__(self) -> None:
        if not self.records and not self.from_signal:
            raise ConfigError("sbas_messages", "the file holds no SBAS message")
        if self.prn is not None and self.prn not in SBAS_L1.prns:
            raise ConfigError("sbas_prn", f"an SBAS GEO's PRN is {SBAS_L1.prns[0]}-{SBAS_L1.prns[-1]}, got {self.prn}")
        if self.mode not in SBAS_MODES:
            raise ConfigError("sbas_mode", f"one of {', '.join(SBAS_MODES)}, got {self.mode!r}")
        if not self.sigma_noise_m > 0:
            raise ConfigError("sbas_sigma_noise", f"must be positive, got {self.sigma_noise_m}")
        prns = sorted({r.prn for r in self.records})
        if self.prn is not None and self.prn not in prns and not self.from_signal:
            raise ConfigError("sbas_prn", f"no message of PRN {self.prn} in the file (it has {prns})")

    def replay(self) -> SbasReplay | None:
        """A fresh replay of the followed GEO's messages (None: no message of it, e.g. none
        decoded from the signal)."""
        prn = busiest_prn(list(self.records)) if self.prn is None and self.records else self.prn
        if not any(r.prn == prn for r in self.records):
            return None
        return SbasReplay(list(self.records), prn)


def signal_records(
    channel: SbasChannel,
    sample_time_s: np.ndarray,
    rx_time_s: np.ndarray,
    week: int,
) -> list[SbasRecord]:
    """The messages one SBAS L1 channel decoded with a good CRC (`sbas_stream.channel_sbas`),
    each dated at the GPS time its last symbol arrived (when a receiver has it whole, as
    RTKLIB's ``.sbs`` logs date a message, and as `SbasReplay` applies it: from then on): its
    first symbol's recording time (`SbasChannel.times_s`) plus the message's second, on the
    line through the observables' epochs (``sample_time_s`` against ``rx_time_s``; the
    receiver clock's bias, milliseconds at most, is left in: DO-229 times its corrections
    to the second) in GPS ``week`` (a time past the week's end rolls it).

    Raises
    ------
    ConfigError
        For no epoch to date them by.
    """
    sample_time_s, rx_time_s = np.asarray(sample_time_s, float), np.asarray(rx_time_s, float)
    if sample_time_s.size == 0:
        raise ConfigError("observables", "no epoch dates the SBAS messages (no GPS channel decoded its time)")
    if sample_time_s.size == 1:
        slope, offset = 1.0, float(rx_time_s[0] - sample_time_s[0])
    else:
        slope, offset = (float(v) for v in np.polyfit(sample_time_s, rx_time_s, 1))
    out = []
    for m, t_s in zip(channel.messages, channel.times_s):
        if not m.crc_ok:
            continue
        t = offset + slope * (float(t_s) + _MESSAGE_S)
        w = week + int(np.floor(t / 604_800.0))
        bits = np.asarray(m.bits, np.uint8)
        out.append(SbasRecord(w, t - 604_800.0 * (w - week), channel.prn, int(m.message_type), bits))
    return out


def merged_records(*groups: list[SbasRecord] | tuple[SbasRecord, ...]) -> tuple[SbasRecord, ...]:
    """Messages of several sources (a file, the signal) in time order, a message both hold
    (same GEO and bits, less than 1 s apart: logged and decoded) kept once, the earlier."""
    every = sorted((r for g in groups for r in g), key=lambda r: (604_800.0 * r.week + r.tow_s, r.prn))
    kept: list[SbasRecord] = []
    last: dict[tuple[int, bytes], float] = {}
    for r in every:
        key, t = (r.prn, bytes(np.asarray(r.bits, np.uint8))), 604_800.0 * r.week + r.tow_s
        if key in last and t - last[key] < 1.0:
            continue
        last[key] = t
        kept.append(r)
    return tuple(kept)


def day_of_year(week: int, tow_s: float) -> float:
    """Day of the year of a GPS time, 1.0 at 1 January 00:00 (as RTKLIB's ``time2doy``)."""
    t = gps_calendar(week, tow_s)
    return 1.0 + (t - dt.datetime(t.year, 1, 1)).total_seconds() / 86_400.0


def sbas_corrects(signal: SignalSpec) -> bool:
    """Whether SBAS L1 corrects ``signal``'s ranges: GPS's signal on SBAS L1's own carrier,
    chip rate and code length, BPSK (L1 C/A; DO-229's corrections are for it, not for L1C)."""
    return (
        signal.system == "G"
        and signal.carrier_freq_hz == SBAS_L1.carrier_freq_hz
        and signal.chip_rate_hz == SBAS_L1.chip_rate_hz
        and signal.code_length_chips == SBAS_L1.code_length_chips
        and signal.subcarrier == SBAS_L1.subcarrier
    )
