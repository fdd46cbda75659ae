"""Galileo I/NAV word types 0-6 and 10 (Galileo OS SIS ICD Issue 2.0/2.1, 4.3.5): fields,
scale factors and the ephemeris they carry.

An I/NAV word is 128 bits, its first 6 the word type. Types 1-4 hold the ephemeris and
clock of the transmitting satellite under one IODnav (5.1.1, 5.1.3, 5.1.9.2), type 3 the
SISA(E1,E5b) index (the SISA section of ICD 5.1), type 5 the NeQuick coefficients ai0-ai2
and disturbance flags (5.1.6), BGD(E1,E5a) and BGD(E1,E5b) (5.1.5), the E1-B and E5b
signal health and data validity (5.1.9.3) and the GST week and time of week (5.1.2); type
0, with its time field ``10``, GST only; type 6 the GST-UTC conversion (A0, A1, Delta t_LS,
t0t, WN0t, WN_LSF, DN, Delta t_LSF; 5.1.7) and a TOW, type 10 the GST-GPS conversion
(A0G, A1G, t0G, WN0G; 5.1.8) after the second half of an almanac (its IODa and the
health bits of its satellite are read here, the almanac fields are not). Scale factors are those of the ICD's parameter
tables in 5.1.1-5.1.9 (ephemeris, GST, clock, BGD, ionosphere, health); angles are in
semicircles, converted with the ICD's value of pi (5.1.1: 3.1415926535898, as IS-GPS-200's).

:func:`ephemeris_to_words` writes one :class:`~gnssframework.navigation.ephemeris.Ephemerides`
record (angles in radians, as RINEX) into the field values of words 1-5, and
:func:`words_to_ephemeris` reads decoded words back into the same form, so
:func:`~gnssframework.navigation.ephemeris.satellite_state` serves both. The record's
``TGD`` is BGD(E1,E5b), the E1 single-frequency user's delay of an I/NAV clock
(`read_rinex_nav`); its ``health`` the RINEX 3 Galileo SV health word (bit 0 E1-B DVS,
bits 1-2 E1-B HS, bits 3-5 E5a's, not in I/NAV, bit 6 E5b DVS, bits 7-8 E5b HS).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .bit_fields import Layout, decode_fields, encode_fields, field_integer
from .ephemeris import KEPLER_TO_RINEX, SEMICIRCLE_FIELDS, Ephemerides

__all__ = [
    "PI_GALILEO",
    "WORD_BITS",
    "WORD_LAYOUTS",
    "encode_word",
    "decode_word",
    "ephemeris_to_words",
    "words_to_ephemeris",
    "sisa_m",
    "sisa_index",
    "record_fields",
    "galileo_record",
    "LSB",
]

#: pi of the Galileo user algorithm (ICD 5.1.1), semicircles to radians.
PI_GALILEO = 3.1415926535898
#: Bits of an I/NAV word (ICD 4.3.5).
WORD_BITS = 128

# name -> (first bit, 1-based within the word; length; scale; signed). Word type: bits 1-6.
WORD_LAYOUTS: dict[int, Layout] = {
    0: {"time": (7, 2, 1, False), "wn": (97, 12, 1, False), "tow_s": (109, 20, 1, False)},
    1: {
        "iodnav": (7, 10, 1, False),
        "toe_s": (17, 14, 60, False),
        "m0_sc": (31, 32, 2.0**-31, True),
        "e": (63, 32, 2.0**-33, False),
        "sqrt_a_sqrtm": (95, 32, 2.0**-19, False),
    },
    2: {
        "iodnav": (7, 10, 1, False),
        "omega0_sc": (17, 32, 2.0**-31, True),
        "i0_sc": (49, 32, 2.0**-31, True),
        "omega_sc": (81, 32, 2.0**-31, True),
        "idot_sc_s": (113, 14, 2.0**-43, True),
    },
    3: {
        "iodnav": (7, 10, 1, False),
        "omega_dot_sc_s": (17, 24, 2.0**-43, True),
        "delta_n_sc_s": (41, 16, 2.0**-43, True),
        "cuc_rad": (57, 16, 2.0**-29, True),
        "cus_rad": (73, 16, 2.0**-29, True),
        "crc_m": (89, 16, 2.0**-5, True),
        "crs_m": (105, 16, 2.0**-5, True),
        "sisa_index": (121, 8, 1, False),
    },
    4: {
        "iodnav": (7, 10, 1, False),
        "svid": (17, 6, 1, False),
        "cic_rad": (23, 16, 2.0**-29, True),
        "cis_rad": (39, 16, 2.0**-29, True),
        "toc_s": (55, 14, 60, False),
        "af0_s": (69, 31, 2.0**-34, True),
        "af1_s_s": (100, 21, 2.0**-46, True),
        "af2_s_s2": (121, 6, 2.0**-59, True),
    },
    5: {
        "ai0_sfu": (7, 11, 2.0**-2, False),
        "ai1_sfu_deg": (18, 11, 2.0**-8, True),
        "ai2_sfu_deg2": (29, 14, 2.0**-15, True),
        "region1": (43, 1, 1, False),
        "region2": (44, 1, 1, False),
        "region3": (45, 1, 1, False),
        "region4": (46, 1, 1, False),
        "region5": (47, 1, 1, False),
        "bgd_e1e5a_s": (48, 10, 2.0**-32, True),
        "bgd_e1e5b_s": (58, 10, 2.0**-32, True),
        "e5b_hs": (68, 2, 1, False),
        "e1b_hs": (70, 2, 1, False),
        "e5b_dvs": (72, 1, 1, False),
        "e1b_dvs": (73, 1, 1, False),
        "wn": (74, 12, 1, False),
        "tow_s": (86, 20, 1, False),
    },
    # GST-UTC conversion (ICD 4.3.5 word type 6; 5.1.7): A0 2^-30 s, A1 2^-50 s/s, t0t 3600 s.
    6: {
        "a0_s": (7, 32, 2.0**-30, True),
        "a1_s_s": (39, 24, 2.0**-50, True),
        "dt_ls_s": (63, 8, 1, True),
        "tot_s": (71, 8, 3600, False),
        "wnt": (79, 8, 1, False),
        "wn_lsf": (87, 8, 1, False),
        "dn": (95, 3, 1, False),
        "dt_lsf_s": (98, 8, 1, True),
        "tow_s": (106, 20, 1, False),
    },
    # Almanac of SVID3 (2/2; its IODa and health only here) and GST-GPS conversion (ICD 4.3.5
    # word type 10; 5.1.8): A0G 2^-35 s, A1G 2^-51 s/s, t0G 3600 s, WN0G the week's low 6 bits.
    10: {
        "iod_a": (7, 4, 1, False),
        "e5b_hs": (83, 2, 1, False),
        "e1b_hs": (85, 2, 1, False),
        "a0g_s": (87, 16, 2.0**-35, True),
        "a1g_s_s": (103, 12, 2.0**-51, True),
        "t0g_s": (115, 8, 3600, False),
        "wn0g": (123, 6, 1, False),
    },
}
#: The LSB of each scaled field (its scale factor), for quantisation bounds.
LSB = {name: scale for layout in WORD_LAYOUTS.values() for name, (_, _, scale, _) in layout.items()}
_SEMICIRCLES = SEMICIRCLE_FIELDS
_TO_RINEX = {**KEPLER_TO_RINEX, "bgd_e1e5b_s": "TGD"}
# RINEX 3 Galileo SV health bits of the I/NAV fields (RINEX 3.04 Table A8).
_HEALTH_SHIFT = {"e1b_dvs": 0, "e1b_hs": 1, "e5b_dvs": 6, "e5b_hs": 7}


def sisa_m(index: int) -> float:
    """SISA value of an index (the ICD's SISA index table, chapter 5.1): 0-49 by 1 cm from 0, 50-74 by 2 cm from 0.5 m,
    75-99 by 4 cm from 1 m, 100-125 by 16 cm from 2 m; -1 for 255 (no accuracy prediction
    available, NAPA) and the spare indices."""
    for first, base_m, step_m in ((100, 2.0, 0.16), (75, 1.0, 0.04), (50, 0.5, 0.02), (0, 0.0, 0.01)):
        if first <= index <= 125:
            return round(base_m + (index - first) * step_m, 2)
    return -1.0


def sisa_index(value_m: float) -> int:
    """The smallest SISA index whose value holds ``value_m`` (255, NAPA, for a negative or
    non-finite value or one above 6 m)."""
    if not np.isfinite(value_m) or value_m < 0:
        return 255
    for k in range(126):
        if sisa_m(k) >= value_m - 1e-9:
            return k
    return 255


def encode_word(word_type: int, values: dict[str, float]) -> np.ndarray:
    """The 128 bits (0/1) of one word: ``values`` quantised with the ICD's scale factors to
    the nearest integer (fields not given are 0, as reserved and spare bits)."""
    if word_type not in WORD_LAYOUTS:
        raise ConfigError("word_type", f"I/NAV word types {sorted(WORD_LAYOUTS)} are encoded, got {word_type}")
    layout = {"word_type": (1, 6, 1.0, False), **WORD_LAYOUTS[word_type]}
    values = {**values, "word_type": word_type}
    return encode_fields(WORD_BITS, layout, values, f"inav.word{word_type}", "Galileo OS SIS ICD 4.3.5")


def decode_word(bits: np.ndarray) -> tuple[int, dict[str, float]]:
    """Word type and scaled field values (physical units) of 128 bits; types without a
    layout here (7-9, 16-22, 63, ...) give their type and no fields."""
    b = np.asarray(bits)
    if b.shape != (WORD_BITS,):
        raise ConfigError("word", f"an I/NAV word is {WORD_BITS} bits, got shape {b.shape}")
    word_type = field_integer(b, 1, 6)
    return word_type, decode_fields(b, WORD_LAYOUTS.get(word_type, {}))


def ephemeris_to_words(
    record: Ephemerides,
    wn: int,
    tow_s: float,
    bgd_e1e5a_s: float = 0.0,
    ai_sfu: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> dict[int, dict[str, float]]:
    """Field values of words 1-5 of one Galileo record: ephemeris, clock (with the record's
    ``TGD`` as BGD(E1,E5b)), SISA, health, and word 5's GST week ``wn`` (12 bits sent) and
    ``tow_s``; ``bgd_e1e5a_s`` and the NeQuick ``ai_sfu`` (ai0, ai1, ai2) are not in an
    :class:`Ephemerides` record and are given apart."""
    fields = record_fields(record, _TO_RINEX)
    iodnav = int(record.iode[0])
    health = int(record.health[0])
    acc = float(record.accuracy_m[0]) if record.accuracy_m is not None else np.nan
    words = {t: {k: fields[k] for k in WORD_LAYOUTS[t] if k in fields} | {"iodnav": iodnav} for t in (1, 2, 3, 4)}
    words[3]["sisa_index"] = sisa_index(acc)
    words[4]["svid"] = int(str(record.sv[0])[1:])
    words[5] = {
        "ai0_sfu": ai_sfu[0],
        "ai1_sfu_deg": ai_sfu[1],
        "ai2_sfu_deg2": ai_sfu[2],
        "bgd_e1e5a_s": bgd_e1e5a_s,
        "bgd_e1e5b_s": fields["bgd_e1e5b_s"],
        "wn": wn % 4096,
        "tow_s": tow_s,
    }
    words[5].update({k: (health >> s) & (3 if k.endswith("hs") else 1) for k, s in _HEALTH_SHIFT.items()})
    return words


def words_to_ephemeris(words: dict[int, dict[str, float]]) -> Ephemerides:
    """One :class:`Ephemerides` record (georinex names, radians) from decoded words 1-5 (the
    four ephemeris words of one IODnav; word 5 for BGD(E1,E5b) and the health word).

    Raises
    ------
    ConfigError
        Naming the word missing or the word whose IODnav differs from word 1's.
    """
    for t in (1, 2, 3, 4, 5):
        if t not in words:
            raise ConfigError(f"inav.word{t}", "missing: an I/NAV ephemeris needs word types 1-5")
    iod = words[1]["iodnav"]
    for t in (2, 3, 4):
        if words[t]["iodnav"] != iod:
            raise ConfigError(
                f"inav.word{t}.iodnav",
                f"{words[t]['iodnav']} differs from word 1's {iod} (ICD 5.1.9.2: one IODnav per ephemeris set)",
            )
    merged = {k: v for t in (1, 2, 3, 4, 5) for k, v in words[t].items()}
    return galileo_record(merged, _TO_RINEX, _HEALTH_SHIFT, fnav=False)


def record_fields(record: Ephemerides, to_rinex: dict[str, str]) -> dict[str, float]:
    """The broadcast values (semicircles for `SEMICIRCLE_FIELDS`) of one Galileo record's
    elements named by ``to_rinex`` (broadcast name -> georinex name), with its ``toc_s``."""
    if record.sv.size != 1 or not str(record.sv[0]).startswith("E"):
        raise ConfigError("record", f"one Galileo record is encoded at a time, got {list(record.sv)}")
    e = {k: float(v[0]) for k, v in record.elements.items()}
    fields = {name: e[rinex] / PI_GALILEO if name in _SEMICIRCLES else e[rinex] for name, rinex in to_rinex.items()}
    fields["toc_s"] = float(record.toc_s[0])
    return fields


def galileo_record(
    merged: dict[str, float], to_rinex: dict[str, str], health_shift: dict[str, int], fnav: bool
) -> Ephemerides:
    """One `Ephemerides` record (georinex names, radians) from the decoded fields of one
    ephemeris set (``svid``, ``toc_s``, ``iodnav``, ``sisa_index``, the health fields of
    ``health_shift`` at their RINEX 3 bits, and ``to_rinex``'s elements); ``fnav`` whether its
    clock is for E1,E5a (F/NAV) or E1,E5b (I/NAV; `ephemeris.GALILEO_FIELDS`)."""
    elements = {
        rinex: np.array([merged[name] * (PI_GALILEO if name in _SEMICIRCLES else 1.0)])
        for name, rinex in to_rinex.items()
    }
    elements["FNAV"] = np.array([1.0 if fnav else 0.0])
    health = sum(int(merged[k]) << s for k, s in health_shift.items())
    return Ephemerides(
        np.array([f"E{int(merged['svid']):02d}"]),
        np.array([float(merged["toc_s"])]),
        elements,
        np.array([float(health)]),
        np.array([float(merged["iodnav"])]),
        np.array([sisa_m(int(merged["sisa_index"]))]),
    )
