"""Recorded observations as receivers write them: RINEX 2.1x, 3.0x and 4.0x (Android's
GnssLogger writes 4.01), plain or Hatanaka-compressed, every constellation georinex reads,
with loss-of-lock indicators, signal strength and the arcs they delimit.

Reading goes through georinex (2 and 3; a RINEX 4 file's observation records are 3.05's,
so it is handed to georinex as 3.05) after ``hatanaka`` has decompressed a
``.crx``/``.crx.gz``/``.??d`` file; RINEX 3 files are first checked line by line
(:func:`~gnssframework.io.rinex.check_rinex3_obs`) so that every problem names its line.
"""

from __future__ import annotations

import re
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ConfigError, DataFileError
from ..signal.galileo_e1 import GALILEO_E1C
from ..signal.gps_l1ca import GPS_L1CA
from ..signal.spec import SignalSpec
from .rinex import PSEUDORANGE_MAX_M, PSEUDORANGE_MIN_M, RinexScan, _check_bounds, check_rinex3_obs
from .skipped import refuse_or_keep
from .text import check_input_file

__all__ = [
    "Observations",
    "normalise_select",
    "primary_signals",
    "SECOND_SIGNALS",
    "SPEED_OF_LIGHT_MPS",
    "LLI_LOST_LOCK",
    "read_observations",
    "arc_starts",
    "glonass_l1_frequency_hz",
    "GEORINEX_TIME_TOLERANCE",
    "CodeCarrier",
    "read_code_carrier",
]

SPEED_OF_LIGHT_MPS = 299_792_458.0
#: Bit 0 of the loss-of-lock indicator: "lost lock between previous and current
#: observation: cycle slip possible" (RINEX 3.04 section 5.3; the same bit in RINEX 2.11).
#: Bit 1 (half-cycle ambiguity, or wavelength factor in RINEX 2) and bit 2 (anti-spoofing
#: in RINEX 2, BOC tracking in RINEX 3) do not break the carrier's continuity.
LLI_LOST_LOCK = 1

# Carrier frequencies (Hz) of the signals without a description here: IS-GPS-200 (L2
# 1227.60), Galileo OS SIS ICD (E5a 1176.45), BDS-SIS-ICD-B1I (1561.098) and B2I (1207.14).
_F = {"L2": 1227.60e6, "E5a": 1176.45e6, "B1I": 1561.098e6, "B2I": 1207.14e6}


def primary_signals(
    gps: SignalSpec = GPS_L1CA, galileo: SignalSpec = GALILEO_E1C
) -> dict[str, list[tuple[str, str, str, float | None]]]:
    """Per system, the (code, phase, signal-strength) observation codes of the primary
    signal, tried in order (RINEX 3 names first, then RINEX 2), with the carrier frequency
    (Hz): GPS L1 C/A's and Galileo E1's from their descriptions (``gps``, ``galileo``).
    GLONASS's frequency depends on the satellite's channel (:func:`glonass_l1_frequency_hz`).
    RINEX 3.02 wrote BDS B1I as ``C1I``; 3.03 and later as ``C2I``.
    """
    f_gps, f_gal = gps.carrier_freq_hz, galileo.carrier_freq_hz
    return {
        "G": [("C1C", "L1C", "S1C", f_gps), ("C1", "L1", "S1", f_gps)],
        "E": [("C1C", "L1C", "S1C", f_gal), ("C1X", "L1X", "S1X", f_gal), ("C1", "L1", "S1", f_gal)],
        "C": [("C2I", "L2I", "S2I", _F["B1I"]), ("C1I", "L1I", "S1I", _F["B1I"])],
        "R": [("C1C", "L1C", "S1C", None), ("C1", "L1", "S1", None)],
    }


#: Per system, the phase of a second frequency (for the ionosphere-free combinations),
#: tried in order, with its frequency (Hz); GLONASS L2 is 1246 + k 0.4375 MHz.
SECOND_SIGNALS: dict[str, list[tuple[str, float | None]]] = {
    "G": [("L2W", _F["L2"]), ("L2L", _F["L2"]), ("L2X", _F["L2"]), ("L2", _F["L2"])],
    "E": [("L5Q", _F["E5a"]), ("L5X", _F["E5a"]), ("L5", _F["E5a"])],
    "C": [("L7I", _F["B2I"])],
    "R": [("L2P", None), ("L2C", None), ("L2", None)],
}


def glonass_l1_frequency_hz(channel: np.ndarray) -> np.ndarray:
    """GLONASS L1 FDMA carrier, 1602 MHz + k 0.5625 MHz (GLONASS ICD 5.1, section 3.3.1.4)."""
    return 1602.0e6 + np.asarray(channel, float) * 0.5625e6


def _glonass_l2_frequency_hz(channel: np.ndarray) -> np.ndarray:
    return 1246.0e6 + np.asarray(channel, float) * 0.4375e6


@dataclass
class Observations:
    """Observations of the selected satellites, batch-first: ``(epochs, satellites)``.

    Attributes
    ----------
    epoch
        ``(T,)`` epoch times as the file states them (``datetime64[ns]``).
    time_s
        ``(T,)`` seconds since the first epoch.
    sv
        ``(S,)`` satellites (``"G08"``, ``"C11"``, ``"E24"``, ``"R05"``).
    pseudorange_m, carrier_m
        ``(T, S)`` primary signal's code and carrier phase (cycles times its wavelength);
        NaN where the file has no value.
    lli
        ``(T, S)`` loss-of-lock indicator of the carrier (0 where blank or missing).
    snr_dbhz
        ``(T, S)`` the signal-strength observation (dB-Hz when the header says DBHZ, as
        RINEX 3 recommends), NaN where the file has none.
    ssi
        ``(T, S)`` the carrier's signal-strength indicator digit 1-9 (0 where blank).
    wavelength_m
        ``(S,)`` primary carrier wavelength.
    second_carrier_m, second_wavelength_m
        A second frequency's phase (metres) and wavelength, NaN where absent.
    signal
        Per system, the observation codes used (``{"G": ("C1C", "L1C", "L2W")}``).
    interval_s
        The file's INTERVAL, or the median epoch step.
    version
        RINEX version.
    position_m
        APPROX POSITION XYZ (ECEF, m) or NaNs.
    dropped
        Satellites or systems selected but not read, with the reason.
    skipped, truncated
        As for :func:`read_code_carrier` (RINEX 3 files).
    """

    epoch: np.ndarray
    time_s: np.ndarray
    sv: np.ndarray
    pseudorange_m: np.ndarray
    carrier_m: np.ndarray
    lli: np.ndarray
    snr_dbhz: np.ndarray
    ssi: np.ndarray
    wavelength_m: np.ndarray
    second_carrier_m: np.ndarray
    second_wavelength_m: np.ndarray
    signal: dict[str, tuple[str, ...]]
    interval_s: float
    version: float
    position_m: np.ndarray
    dropped: dict[str, str] = field(default_factory=dict)
    skipped: list[tuple[int, str]] = field(default_factory=list)
    truncated: str | None = None

    @property
    def valid(self) -> np.ndarray:
        """``(T, S)``: both code and carrier present."""
        return np.isfinite(self.pseudorange_m) & np.isfinite(self.carrier_m)

    def satellite(self, sv: str) -> int:
        """Column of satellite ``sv``."""
        hits = np.flatnonzero(self.sv == sv)
        if not hits.size:
            raise KeyError(sv)
        return int(hits[0])


def arc_starts(time_s: np.ndarray, valid: np.ndarray, lli: np.ndarray, max_gap_s: float) -> np.ndarray:
    """``(T, S)`` True at the first epoch of every continuous carrier arc.

    An arc starts at a satellite's first valid epoch, at an epoch whose loss-of-lock
    indicator has bit 0 set (:data:`LLI_LOST_LOCK`), and after a gap: more than
    ``max_gap_s`` since the satellite's previous valid epoch (a receiver that stopped
    writing a satellite may have lost lock without flagging it).

    Parameters
    ----------
    time_s
        ``(T,)`` epoch times.
    valid
        ``(T, S)`` epochs where the satellite has code and carrier.
    lli
        ``(T, S)`` loss-of-lock indicators.
    max_gap_s
        Longest step between two valid epochs of one arc.
    """
    if not max_gap_s > 0:
        raise ConfigError("max_gap_s", f"must be a positive number of seconds, got {max_gap_s!r}")
    t = np.asarray(time_s, float)
    valid = np.asarray(valid, bool)
    k = np.arange(t.size)[:, None]
    last = np.maximum.accumulate(np.where(valid, k, -1), axis=0)  # latest valid epoch up to k
    previous = np.vstack([np.full((1, valid.shape[1]), -1), last[:-1]])  # ... strictly before k
    gap = t[:, None] - t[np.maximum(previous, 0)]
    flagged = (np.asarray(lli).astype(np.int64) & LLI_LOST_LOCK) != 0
    return valid & ((previous < 0) | (gap > max_gap_s) | flagged)


_SYSTEMS = "GECR"
_PRN = re.compile(r"^[GECR]\d{2}$")


def normalise_select(select: str) -> str:
    """A satellite selection written as the RINEX file writes it: ``"g08"``, ``"G8"`` and
    ``"8"`` (a bare number is a GPS PRN) all become ``"G08"``; systems (``"gc"`` -> ``"GC"``)
    and ``"all"`` are kept.

    Examples
    --------
    >>> normalise_select("g08"), normalise_select("8"), normalise_select(" e24, c1 "), normalise_select("ALL")
    ('G08', 'G08', 'E24,C01', 'all')
    """
    text = str(select).strip()
    if text.upper() == "ALL":
        return "all"
    items = []
    for item in (x.strip().upper() for x in text.split(",")):
        m = re.fullmatch(r"([GECR]?)0*(\d{1,2})", item)
        items.append(f"{m.group(1) or 'G'}{int(m.group(2)):02d}" if m else item)
    return ",".join(items)


def _parse_select(select: str) -> tuple[set[str], list[str] | None]:
    """``"G08"`` or ``"G08,C11"`` (satellites), ``"G"``, ``"GC"`` or ``"all"`` (systems);
    written as `normalise_select` accepts (``"g8"``, ``"8"``)."""
    text = normalise_select(select).upper()
    if text == "ALL":
        return set(_SYSTEMS), None
    items = [x.strip() for x in text.split(",") if x.strip()]
    if items and all(_PRN.match(x) for x in items):
        return {x[0] for x in items}, items
    if len(items) == 1 and items[0] and set(items[0]) <= set(_SYSTEMS):
        return set(items[0]), None
    raise ConfigError(
        "select", f"{select!r} is neither satellites (G08, C11,E24) nor systems (G, GC, all) of {', '.join(_SYSTEMS)}"
    )


def _decompress(path: Path) -> str:
    """The RINEX text of ``path``, Hatanaka- and gzip-decompressed by ``hatanaka`` if needed."""
    import hatanaka

    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataFileError(str(path), None, f"cannot read: {exc.strerror}") from None
    try:
        data = hatanaka.decompress(raw)
    except Exception as exc:  # noqa: BLE001 - a corrupt archive or CRINEX stream: one line naming the file
        raise DataFileError(
            str(path), None, f"Hatanaka/gzip decompression failed: {type(exc).__name__}: {exc}"
        ) from None
    return data.decode("ascii", errors="replace") if isinstance(data, bytes) else data


#: RINEX types other than observations, as a user would name the file.
_OTHER_RINEX = {
    **dict.fromkeys("NGHLEBJ", "a navigation file (broadcast ephemeris, RINEX type N)"),
    "M": "a meteorological file (RINEX type M)",
    "C": "a clock file (RINEX type C)",
}


def _version(path: Path, text: str) -> float:
    first = text.split("\n", 1)[0]
    if "RINEX VERSION / TYPE" not in first:
        raise DataFileError(str(path), 1, "not a RINEX file: first line lacks 'RINEX VERSION / TYPE'")
    try:
        version = float(first[:9])
    except ValueError:
        raise DataFileError(str(path), 1, f"unreadable RINEX version {first[:9].strip()!r}") from None
    if first[20] != "O":
        what = _OTHER_RINEX.get(first[20], f"a RINEX file of type {first[20]!r}")
        raise DataFileError(
            str(path), 1, f"{what}, not an observation file (RINEX type O, with the code and carrier this reads)"
        )
    if not (2.0 <= version < 2.2 or 3.0 <= version < 5.0):
        raise DataFileError(str(path), 1, f"RINEX version {version:g}: this reader reads 2.1x, 3.0x and 4.0x")
    return version


def _georinex_load(path: Path, systems: set[str], meas: list[str]):
    import georinex

    with warnings.catch_warnings():  # georinex's xarray calls emit FutureWarnings
        warnings.simplefilter("ignore", FutureWarning)
        return georinex.load(path, use=systems, meas=meas, useindicators=True)


# RINEX 2.11 table A2 epoch line: " yy mm dd hh mm ss.sssssss  f nnn", then PRNs.
_EPOCH2 = re.compile(r"^ [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d\.\d{7}  ([0-6])([ \d]{2}\d)")


def _rinex2_epochs(text: str) -> list[tuple[int, np.datetime64, str]]:
    """``(line, time)`` of every observation epoch (flag 0 or 1) of a RINEX 2 file."""
    lines = text.splitlines()
    end = next((i for i, line in enumerate(lines) if "END OF HEADER" in line), len(lines))
    out = []
    for i in range(end + 1, len(lines)):
        m = _EPOCH2.match(lines[i])
        if m and m[1] in "01":
            yy = int(lines[i][1:3])
            year = yy + (1900 if yy >= 80 else 2000)  # RINEX 2.11 section 6.5: 80-99 are 1980-1999
            sec = float(lines[i][16:26])
            t = np.datetime64(
                f"{year:04d}-{int(lines[i][4:6]):02d}-{int(lines[i][7:9]):02d}T"
                f"{int(lines[i][10:12]):02d}:{int(lines[i][13:15]):02d}",
                "ns",
            ) + np.timedelta64(int(round(sec * 1e9)), "ns")
            out.append(
                (
                    i + 1,
                    t,
                    f"{year:04d}-{lines[i][4:6].strip():0>2}-{lines[i][7:9].strip():0>2} "
                    f"{lines[i][10:12].strip():0>2}:{lines[i][13:15].strip():0>2}:{sec:010.7f}",
                )
            )
    return out


def _refuse_rinex2_time_order(path: Path, stated: list[tuple[int, np.datetime64, str]]) -> None:
    """RINEX 2 files get no line-level repair: a duplicate or backwards epoch is refused."""
    for (line0, t0, _), (line, t, when) in zip(stated, stated[1:]):
        if t <= t0:
            what = "repeats the epoch" if t == t0 else "goes backwards from the epoch"
            raise DataFileError(
                str(path), line, f"epoch {when} {what} at line {line0} (RINEX 2 epochs are not skipped, only refused)"
            )


def _rinex3_epochs(scan: RinexScan, systems: set[str]) -> list[tuple[int, np.datetime64, str]]:
    """``(line, time, as written)`` of every kept epoch with an observation of a selected system."""
    from .rinex import _epoch_time, _fmt_time

    out = []
    starts = scan.epoch_starts + [len(scan.lines)]
    for n, start in enumerate(scan.epoch_starts):
        if not any(line[:1] in systems and line[3:].strip() for line in scan.lines[start + 1 : starts[n + 1]]):
            continue
        minute, seconds = _epoch_time(scan.lines[start])
        out.append(
            (
                scan.line_numbers[start],
                np.datetime64(minute, "ns") + np.timedelta64(int(round(seconds * 1e9)), "ns"),
                _fmt_time((minute, seconds)),
            )
        )
    return out


#: How far georinex's epoch may lie from the file's: it reads the seconds as a float and
#: truncates them, to milliseconds in RINEX 2 (30.0020000 s comes back as 30.001 s) and to
#: microseconds in RINEX 3 (15.0002755 s as 15.000275 s).
GEORINEX_TIME_TOLERANCE = np.timedelta64(1001, "us")


def _match_epochs(path: Path, stated: list[tuple[int, np.datetime64, str]], returned: np.ndarray) -> np.ndarray:
    """The file's own epoch times (to the 100 ns it states), in georinex's order; refuse
    the file if georinex lost any.

    Each epoch georinex returns is matched to the nearest epoch the file states, within
    :data:`GEORINEX_TIME_TOLERANCE`. georinex also stops, without an error, at an epoch it
    cannot parse (seconds of 60.0, for one): the first epoch missing is named.
    """
    exact = np.array([t for _, t, _ in stated], dtype="datetime64[ns]")
    order = np.argsort(exact, kind="stable")
    ref = exact[order]
    have = np.asarray(returned).astype("datetime64[ns]")
    hi = np.clip(np.searchsorted(ref, have), 0, ref.size - 1)
    lo = np.clip(hi - 1, 0, ref.size - 1)
    nearest = np.where(np.abs(ref[lo] - have) <= np.abs(ref[hi] - have), lo, hi)
    close = np.abs(ref[nearest] - have) <= GEORINEX_TIME_TOLERANCE
    found = np.zeros(ref.size, bool)
    found[nearest[close]] = True
    if not found.all():
        line, _, when = stated[int(order[np.argmin(found)])]
        missing = int((~found).sum())
        raise DataFileError(
            str(path),
            line,
            f"georinex did not return the epoch at this line ({when}), nor "
            f"{missing - 1} later epochs: it stops without an error at an epoch it cannot parse",
        )
    if not close.all() or np.unique(nearest).size != nearest.size:
        raise DataFileError(
            str(path),
            None,
            "georinex returned epochs the file does not state, or two of its "
            f"epochs within {GEORINEX_TIME_TOLERANCE} of one stated epoch",
        )
    return ref[nearest]


def _header_position(obs) -> np.ndarray:
    pos = obs.attrs.get("position")
    return np.asarray(pos, float) if pos is not None and len(pos) == 3 else np.full(3, np.nan)


def _glonass_channels(source: Path) -> dict[str, int]:
    """``{"R01": 1, ...}`` from the header's GLONASS SLOT / FRQ # records (RINEX 3.02+)."""
    import georinex

    text = georinex.rinexheader(source).get("GLONASS SLOT / FRQ #", "")
    return {f"R{int(s):02d}": int(k) for s, k in re.findall(r"R\s?(\d{1,2})\s+(-?\d+)", text)}


def read_observations(
    path: str | Path,
    select: str = "G",
    pseudorange_min_m: float = PSEUDORANGE_MIN_M,
    pseudorange_max_m: float = PSEUDORANGE_MAX_M,
    strict: bool = False,
) -> Observations:
    """Read a RINEX 2.1x or 3.0x observation file (plain, ``.gz``, ``.crx``, ``.crx.gz``).

    Parameters
    ----------
    path
        The file; Hatanaka and gzip compression are undone with the ``hatanaka`` package.
    select
        Satellites (``"G08"``, ``"G08,C11"``) or systems (``"G"``, ``"GEC"``, ``"all"``):
        GPS L1 C/A, Galileo E1, BDS B1I, GLONASS L1 C/A (:func:`primary_signals`).
    pseudorange_min_m, pseudorange_max_m
        Plausibility bounds of a pseudorange (RINEX 3 line checks).
    strict
        Refuse the file at the first skipped line instead.

    Returns
    -------
    Observations
        Every selected satellite with at least one observation of its primary signal; the
        others are in ``dropped`` with the reason.

    Raises
    ------
    DataFileError
        A file that is not RINEX observations, malformed (naming the line), an error inside
        georinex (naming the epoch it fails on), an epoch georinex lost, or no observation
        of the selection.
    """
    _check_bounds(pseudorange_min_m, pseudorange_max_m)  # inverted or NaN bounds: before reading anything
    path = check_input_file(path)  # not a device, a pipe or a directory: read whole below
    systems, prns = _parse_select(select)
    text = _decompress(path)
    version = _version(path, text)
    scan: RinexScan | None = None
    stated: list[tuple[int, np.datetime64, str]] = []
    if version >= 3:
        scan = check_rinex3_obs(path, pseudorange_min_m, pseudorange_max_m, text=text)
        refuse_or_keep(path, scan.skipped, strict)
    else:  # before georinex, which fails on a repeated epoch without saying where
        stated = _rinex2_epochs(text)
        _refuse_rinex2_time_order(path, stated)
    width = 3 if version >= 3 else 2  # georinex matches meas by prefix: "C1" would pull C1W, C1P...
    meas = sorted(
        code
        for code in (
            {c for s in systems for sig in primary_signals()[s] for c in sig[:3]}
            | {c for s in systems for c, _ in SECOND_SIGNALS[s]}
        )
        if len(code) == width
    )
    with tempfile.TemporaryDirectory(prefix="gnssframework-rinex-") as tmpdir:
        source = Path(tmpdir) / (path.name.split(".")[0] + (".rnx" if version >= 3 else ".obs"))
        lines = list(scan.lines) if scan is not None else []
        if version >= 4 and lines:  # georinex reads up to 3: RINEX 4's records are 3.05's
            lines[0] = f"{'3.05':>9}" + lines[0][9:]
        body = "\n".join(lines) + "\n" if scan is not None else text
        source.write_text(body)
        try:
            obs = _georinex_load(source, systems, meas)
        except Exception as exc:  # noqa: BLE001 - georinex raises many types; report them as file errors
            line = None
            if scan is not None:
                from .rinex import _locate_georinex_failure_with

                line = _locate_georinex_failure_with(
                    scan, Path(tmpdir) / ("probe-" + source.name), lambda p: _georinex_load(p, systems, meas)
                )
            where = "in the epoch starting at this line" if line else "(no single epoch reproduces it)"
            raise DataFileError(
                str(path), line, f"georinex could not read it {where}: {type(exc).__name__}: {exc}"
            ) from None
        channels = _glonass_channels(source) if "R" in systems else {}
    stated = _rinex3_epochs(scan, systems) if scan is not None else stated
    epochs = _match_epochs(path, stated, obs.time.values) if obs.time.size else np.array([], "datetime64[ns]")
    out = _assemble(path, obs, epochs, version, systems, prns, channels, scan)
    if scan is None:  # RINEX 2: the bounds RINEX 3's line checks apply, applied to the read values
        out.skipped = _rinex2_out_of_bounds(out, stated, (pseudorange_min_m, pseudorange_max_m))
        refuse_or_keep(path, out.skipped, strict)
    return out


def _rinex2_out_of_bounds(
    obs: Observations, stated: list[tuple[int, np.datetime64, str]], bounds_m: tuple[float, float]
) -> list[tuple[int, str]]:
    """Blank (in place) the pseudoranges of a RINEX 2 file outside ``bounds_m`` and list
    them as ``(line of their epoch, reason)``, worded as `check_rinex3_obs` words them."""
    lo, hi = bounds_m
    code = obs.pseudorange_m
    bad = np.isfinite(code) & ~((code >= lo) & (code <= hi))
    line_of = {t: line for line, t, _ in stated}
    skipped = []
    for k, j in zip(*np.nonzero(bad)):
        sv = str(obs.sv[j])
        name = obs.signal.get(sv[0], ("code",))[0]
        skipped.append(
            (
                line_of.get(obs.epoch[k], 0),
                f"{sv} {name} = {code[k, j]:.6g} m outside [{lo:g}, {hi:g}] m "
                "(pseudorange_min_m/pseudorange_max_m): observation skipped",
            )
        )
    code[bad] = np.nan
    return sorted(skipped)


def _names(system: str, version: float) -> tuple[str, str]:
    """The first code and phase names of ``system``'s signal in a file of ``version``."""
    width = 3 if version >= 3 else 2
    code, phase, _, _ = next(sig for sig in primary_signals()[system] if len(sig[0]) == width)
    return code, phase


def _both(obs, code: str, phase: str, sv: str) -> bool:
    """Whether ``sv`` has an epoch with both ``code`` and ``phase``."""
    c, p = _column(obs, code, sv), _column(obs, phase, sv)
    return c is not None and p is not None and bool((np.isfinite(c) & np.isfinite(p)).any())


def _column(obs, name: str, sv: str) -> np.ndarray | None:
    if name not in obs.data_vars:
        return None
    values = obs[name].sel(sv=sv).values.astype(float)
    return values if np.isfinite(values).any() else None


def _assemble(
    path: Path,
    obs,
    epochs: np.ndarray,
    version: float,
    systems: set[str],
    prns: list[str] | None,
    channels: dict[str, int],
    scan: RinexScan | None,
) -> Observations:
    present = [str(s) for s in obs.sv.values] if obs.time.size else []
    wanted = prns if prns is not None else sorted(s for s in present if s[0] in systems)
    dropped: dict[str, str] = {}
    columns: dict[str, list] = {k: [] for k in ("sv", "code", "phase", "lli", "snr", "ssi", "wl", "phase2", "wl2")}
    signal: dict[str, tuple[str, ...]] = {}
    nan = np.full(epochs.size, np.nan)
    for sv in wanted:
        if sv not in present:
            dropped[sv] = "no observations in the file"
            continue
        pair = next(((c, p, s, f) for c, p, s, f in primary_signals()[sv[0]] if _both(obs, c, p, sv)), None)
        if pair is None:
            dropped[sv] = "no epoch with both {} and {}".format(*_names(sv[0], version))
            continue
        code, phase, strength, freq = pair
        second = next(((p2, f2) for p2, f2 in SECOND_SIGNALS[sv[0]] if _column(obs, p2, sv) is not None), None)
        if sv[0] == "R":
            if sv not in channels:
                dropped[sv] = "GLONASS frequency channel unknown (no GLONASS SLOT / FRQ # for it in the header)"
                continue
            freq = float(glonass_l1_frequency_hz(channels[sv]))
            if second is not None:
                second = (second[0], float(_glonass_l2_frequency_hz(channels[sv])))
        wl = SPEED_OF_LIGHT_MPS / freq
        signal.setdefault(sv[0], (code, phase) + ((second[0],) if second else ()))
        lli = _column(obs, f"{phase}lli", sv)
        ssi = _column(obs, f"{phase}ssi", sv)
        snr = _column(obs, strength, sv)
        columns["sv"].append(sv)
        columns["code"].append(_column(obs, code, sv))
        columns["phase"].append(_column(obs, phase, sv) * wl)
        columns["lli"].append(np.nan_to_num(lli, nan=0.0) if lli is not None else np.zeros(epochs.size))
        columns["ssi"].append(np.nan_to_num(ssi, nan=0.0) if ssi is not None else np.zeros(epochs.size))
        columns["snr"].append(snr if snr is not None else nan)
        if second is not None:
            wl2 = SPEED_OF_LIGHT_MPS / second[1]
            columns["phase2"].append(_column(obs, second[0], sv) * wl2)
            columns["wl2"].append(wl2)
        else:
            columns["phase2"].append(nan)
            columns["wl2"].append(np.nan)
        columns["wl"].append(wl)
    skipped = scan.skipped if scan is not None else []
    if not columns["sv"]:
        from .rinex import _first_skipped

        if prns is not None and len(prns) == 1 and prns[0] not in present:
            raise DataFileError(str(path), None, f"no observations of {prns[0]}; satellites: {', '.join(present)}")
        if prns is not None and len(prns) == 1:
            code, phase = _names(prns[0][0], version)
            raise DataFileError(
                str(path), None, f"{prns[0]} has no epoch with both {code} and {phase}" + _first_skipped(skipped)
            )
        reasons = (
            "; ".join(f"{k}: {v}" for k, v in list(dropped.items())[:3])
            or f"no satellite of {''.join(sorted(systems))} in the file"
        )
        raise DataFileError(str(path), None, f"no observations of the selection ({reasons})" + _first_skipped(skipped))

    def stack(key: str, dtype=float) -> np.ndarray:
        return np.stack(columns[key], axis=-1).astype(dtype)

    t = (epochs - epochs[0]) / np.timedelta64(1, "s")
    interval = obs.attrs.get("interval")
    steps = np.diff(t)
    if interval is None or not np.isfinite(interval):
        interval = float(np.median(steps)) if steps.size else np.nan
    return Observations(
        epochs,
        t.astype(float),
        np.array(columns["sv"]),
        stack("code"),
        stack("phase"),
        stack("lli", np.int64),
        stack("snr"),
        stack("ssi", np.int64),
        np.array(columns["wl"]),
        stack("phase2"),
        np.array(columns["wl2"], float),
        signal,
        float(interval),
        version,
        _header_position(obs),
        dropped,
        skipped,
        scan.truncated if scan is not None else None,
    )


@dataclass
class CodeCarrier:
    """Pseudorange and carrier phase of one satellite, epochs where both exist."""

    time_s: np.ndarray  # seconds since the first epoch
    epoch: np.ndarray  # numpy datetime64
    pseudorange_m: np.ndarray
    carrier_m: np.ndarray  # carrier phase times the L1 wavelength
    skipped: list[tuple[int, str]] = field(default_factory=list)  # (line, reason), see check_rinex3_obs
    truncated: str | None = None  # why the file looks cut, or None
    lli: np.ndarray | None = None  # loss-of-lock indicator of the carrier, 0 where blank
    snr_dbhz: np.ndarray | None = None  # signal-strength observation, NaN where absent
    wavelength_m: float = field(kw_only=True)  # the carrier's (read_code_carrier: the file's signal)


def read_code_carrier(
    path: str | Path,
    prn: str,
    pseudorange_min_m: float = PSEUDORANGE_MIN_M,
    pseudorange_max_m: float = PSEUDORANGE_MAX_M,
    strict: bool = False,
) -> CodeCarrier:
    """Pseudorange and carrier (metres) of satellite ``prn`` (``"G08"``, ``"C11"``...).

    One satellite of :func:`read_observations` (RINEX 2.1x
    or 3.0x, plain or Hatanaka-compressed; the signal of :func:`primary_signals`),
    at the epochs where both code and carrier exist, with its loss-of-lock indicators and
    signal strength. RINEX 3 files are first checked by :func:`~gnssframework.io.rinex.check_rinex3_obs`:
    duplicated, backwards and truncated epochs and implausible pseudoranges are skipped
    and listed in the result's ``skipped`` (``truncated`` says why the file looks cut).

    Parameters
    ----------
    pseudorange_min_m, pseudorange_max_m
        Plausibility bounds of a pseudorange (defaults :data:`~gnssframework.io.rinex.PSEUDORANGE_MIN_M`,
        :data:`~gnssframework.io.rinex.PSEUDORANGE_MAX_M`).
    strict
        Refuse the file at the first skipped line (or truncation) instead.

    Raises
    ------
    DataFileError
        For a malformed file (naming the line), an error inside georinex (naming the first
        epoch line it fails on), or when ``prn`` has no code and carrier.
    """
    obs = read_observations(path, prn, pseudorange_min_m, pseudorange_max_m, strict)
    j = obs.satellite(prn)
    ok = obs.valid[:, j]
    times = obs.epoch[ok]
    t = (times - times[0]) / np.timedelta64(1, "s")
    return CodeCarrier(
        t.astype(float),
        times,
        obs.pseudorange_m[ok, j],
        obs.carrier_m[ok, j],
        obs.skipped,
        obs.truncated,
        obs.lli[ok, j],
        obs.snr_dbhz[ok, j],
        wavelength_m=float(obs.wavelength_m[j]),
    )
