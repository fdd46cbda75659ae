"""SBAS-corrected fixes of a receiver's GPS L1 C/A observables, from SBAS messages read from
a file (`navigation.sbas_files`: RTKLIB's ``.sbs`` log or EGNOS Message Server ``.ems``).

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

from ...errors import ConfigError
from ...navigation.sbas_files import SbasRecord, SbasReplay, busiest_prn
from ...navigation.sbas_pvt import SBAS_MODES
from ...navigation.weeks import gps_calendar
from ...signal.sbas_l1 import SBAS_L1
from ...signal.spec import SignalSpec

__all__ = ["SbasOptions", "SBAS_COLUMNS", "day_of_year", "sbas_corrects"]

#: Columns ``positions.csv`` adds with SBAS: DO-229's protection levels (m; NaN where the
#: fix is the broadcast one) and the number of satellites corrected (0: not corrected).
SBAS_COLUMNS = ("hpl_m", "vpl_m", "sbas_sats")


@dataclass(frozen=True)
class SbasOptions:
    """SBAS corrections for a receiver's fixes: the messages ``records`` (of any GEOs), the
    GEO ``prn`` followed (default: the one with the most messages), the protection
    levels' ``mode`` (`sbas_pvt.SBAS_MODES`) and the receiver's code noise ``sigma_noise_m``
    in σ_air (0.36 m, DO-229's airborne bound for a receiver that smooths its code with the
    carrier; this receiver's unsmoothed code at 45 dB-Hz has about 1.7 m, and protection
    levels made with less do not bound its errors).

    Raises
    ------
    ConfigError
        For no messages, a PRN without messages or an unknown mode.
    """

    records: tuple[SbasRecord, ...] = field(repr=False)
    prn: int | None = None
    mode: str = "pa"
    sigma_noise_m: float = 0.36

    def __post_init__(self) -> None:
        if not self.records:
            raise ConfigError("sbas_messages", "the file holds no SBAS message")
        if self.mode not in SBAS_MODES:
            raise ConfigError("sbas_mode", f"one of {', '.join(SBAS_MODES)}, got {self.mode!r}")
        if not self.sigma_noise_m > 0:
            raise ConfigError("sbas_sigma_noise", f"must be positive, got {self.sigma_noise_m}")
        prns = sorted({r.prn for r in self.records})
        if self.prn is not None and self.prn not in prns:
            raise ConfigError("sbas_prn", f"no message of PRN {self.prn} in the file (it has {prns})")

    def replay(self) -> SbasReplay:
        """A fresh replay of the followed GEO's messages."""
        return SbasReplay(list(self.records), busiest_prn(list(self.records)) if self.prn is None else self.prn)


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
