"""What I/NAV word types 5, 6 and 10 say besides the ephemeris: the NeQuick coefficients,
GST-UTC and GST-GPS (GGTO) conversions (Galileo OS SIS ICD Issue 2.0/2.1, 5.1.6-5.1.8).

``ai_sfu`` are the effective ionisation level coefficients ai0 (sfu), ai1 (sfu/deg), ai2
(sfu/deg^2) of word type 5 (5.1.6). `GstUtc` is word type 6 (5.1.7):

    t_UTC = t_E - (Delta t_LS + A0 + A1 (t_E - t0t + 604800 (WN - WN0t)))

away from a leap second. `Ggto` is word type 10 (5.1.8): the GPS-Galileo time offset

    GGTO = t_E - t_GPS = A0G + A1G (t_E - t0G + 604800 (WN - WN0G))

whose week WN0G is sent modulo 64 (6 bits), as WN0t and WN_LSF are modulo 256 (8 bits):
`Ggto.offset_s` places it within half a 64-week cycle of the week it is asked at. GST
weeks count from GPS week 1024 (5.1.2), a multiple of 64 and 256, so the sent low bits are
those of the GPS week as well. The I/NAV weeks here are those low bits (the words' own);
RINEX wants full weeks (`weeks.full_week`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from .lnav import WEEK_S
from .weeks import full_week

__all__ = ["GstUtc", "Ggto", "InavIonoTime", "iono_time_from_words", "merge_iono_time"]


@dataclass(frozen=True)
class GstUtc:
    """Word type 6 (ICD 5.1.7): ``a0_s``, ``a1_s_s`` the GST-UTC polynomial, ``tot_s`` its
    reference time of week, ``wnt`` its week (8 bits), ``dt_ls_s`` the leap seconds now,
    ``wn_lsf`` (8 bits) and ``dn`` (1-7) the week and day at whose end ``dt_lsf_s`` applies."""

    a0_s: float
    a1_s_s: float
    dt_ls_s: int
    tot_s: float
    wnt: int
    wn_lsf: int
    dn: int
    dt_lsf_s: int

    def fields(self) -> dict[str, float]:
        """The field values of word type 6 (weeks modulo 256)."""
        return {
            "a0_s": self.a0_s,
            "a1_s_s": self.a1_s_s,
            "dt_ls_s": self.dt_ls_s,
            "tot_s": self.tot_s,
            "wnt": self.wnt % 256,
            "wn_lsf": self.wn_lsf % 256,
            "dn": self.dn,
            "dt_lsf_s": self.dt_lsf_s,
        }


@dataclass(frozen=True)
class Ggto:
    """Word type 10's GST-GPS conversion (ICD 5.1.8): ``a0g_s``, ``a1g_s_s``, its reference
    time of week ``t0g_s`` and week ``wn0g`` (6 bits as sent)."""

    a0g_s: float
    a1g_s_s: float
    t0g_s: float
    wn0g: int

    def fields(self) -> dict[str, float]:
        """The GGTO field values of word type 10 (the week modulo 64)."""
        return {"a0g_s": self.a0g_s, "a1g_s_s": self.a1g_s_s, "t0g_s": self.t0g_s, "wn0g": self.wn0g % 64}

    def offset_s(self, week: int, tow_s: float) -> float:
        """GST - GPST (s) at GPS time ``(week, tow_s)`` (module text; WN0G placed by
        `full_week` nearest ``week``): the ``time_offsets_s["E"]`` of `pvt.solve_position`."""
        w0 = full_week(self.wn0g, 6, week)
        return self.a0g_s + self.a1g_s_s * (tow_s - self.t0g_s + WEEK_S * (week - w0))


@dataclass(frozen=True)
class InavIonoTime:
    """The NeQuick coefficients, GST-UTC and GGTO a receiver decoded (each None until its
    word type arrived)."""

    ai_sfu: tuple[float, float, float] | None = None
    utc: GstUtc | None = None
    ggto: Ggto | None = None


def iono_time_from_words(words: dict[int, dict[str, float]]) -> InavIonoTime | None:
    """`InavIonoTime` of decoded words (`inav_words.decode_word` fields by word type; word
    types 5, 6 and 10 used); None when none of them is there."""
    w5, w6, w10 = words.get(5), words.get(6), words.get(10)
    if w5 is None and w6 is None and w10 is None:
        return None
    ai = None if w5 is None else (float(w5["ai0_sfu"]), float(w5["ai1_sfu_deg"]), float(w5["ai2_sfu_deg2"]))
    utc = None
    if w6 is not None:
        utc = GstUtc(
            float(w6["a0_s"]),
            float(w6["a1_s_s"]),
            int(w6["dt_ls_s"]),
            float(w6["tot_s"]),
            int(w6["wnt"]),
            int(w6["wn_lsf"]),
            int(w6["dn"]),
            int(w6["dt_lsf_s"]),
        )
    ggto = None
    if w10 is not None:
        ggto = Ggto(float(w10["a0g_s"]), float(w10["a1g_s_s"]), float(w10["t0g_s"]), int(w10["wn0g"]))
    return InavIonoTime(ai, utc, ggto)


def merge_iono_time(older: InavIonoTime | None, newer: InavIonoTime | None) -> InavIonoTime | None:
    """``newer``'s parts where it has them, ``older``'s where it does not."""
    if older is None or newer is None:
        return newer if older is None else older
    return replace(
        older,
        **{k: getattr(newer, k) for k in ("ai_sfu", "utc", "ggto") if getattr(newer, k) is not None},
    )
