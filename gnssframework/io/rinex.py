"""RINEX files: the line-level check of RINEX 3 observation files, and minimal RINEX 3.04 writers.

The writers exist so the project can generate its own small test files (a simulated GPS
pass); reading goes through georinex (`gnssframework.io.observations`), which handles the
real-world variety of files, after `check_rinex3_obs` has named every bad line.
"""

from __future__ import annotations

import datetime as dt
import re
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Callable

import numpy as np

from ..errors import ConfigError, DataFileError
from .text import read_input_text

__all__ = [
    "RinexScan",
    "write_rinex3_obs",
    "write_rinex3_nav",
    "check_rinex3_obs",
    "PSEUDORANGE_MIN_M",
    "PSEUDORANGE_MAX_M",
]


def write_rinex3_obs(
    path: str | Path,
    start: dt.datetime,
    interval_s: float,
    observations: dict[str, tuple[np.ndarray, np.ndarray]],
    approx_position_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> None:
    """Write a RINEX 3.04 GPS observation file with C1C (m) and L1C (cycles).

    ``observations`` maps a satellite (``"G08"``) to its pseudorange (m) and carrier phase
    (cycles) arrays, NaN where there is no observation.
    """
    sats = sorted(observations)
    n = len(next(iter(observations.values()))[0])

    def hdr(text: str, label: str) -> str:
        return f"{text:<60}{label:<20}"

    lines = [
        hdr("     3.04           OBSERVATION DATA    G (GPS)", "RINEX VERSION / TYPE"),
        hdr(f"{'gnssframework':<20}{'gnssframework':<20}{start:%Y%m%d %H%M%S} UTC", "PGM / RUN BY / DATE"),
        hdr("SIMULATED", "MARKER NAME"),
        hdr(f"{'gnssframework':<20}{'':<40}", "OBSERVER / AGENCY"),
        hdr(f"{'0':<20}{'SIMULATOR':<20}{'1':<20}", "REC # / TYPE / VERS"),
        hdr(f"{'0':<20}{'NONE':<20}", "ANT # / TYPE"),
        hdr("".join(f"{c:14.4f}" for c in approx_position_m), "APPROX POSITION XYZ"),
        hdr("".join(f"{c:14.4f}" for c in (0.0, 0.0, 0.0)), "ANTENNA: DELTA H/E/N"),
        hdr("G    2 C1C L1C", "SYS / # / OBS TYPES"),
        hdr(f"{interval_s:10.3f}", "INTERVAL"),
        hdr(f"{start:  %Y    %m    %d    %H    %M}   {start.second:10.7f}     GPS", "TIME OF FIRST OBS"),
        hdr("", "END OF HEADER"),
    ]
    for k in range(n):
        t = start + dt.timedelta(seconds=k * interval_s)
        present = [s for s in sats if np.isfinite(observations[s][0][k]) and np.isfinite(observations[s][1][k])]
        sec = t.second + t.microsecond * 1e-6
        lines.append(f"> {t:%Y %m %d %H %M}{sec:11.7f}  0{len(present):3d}")
        for s in present:
            code, phase = observations[s][0][k], observations[s][1][k]
            lines.append(f"{s:<3}{code:14.3f}  {phase:14.3f}  ")
    Path(path).write_text("\n".join(lines) + "\n")


_EPOCH = re.compile(r"^> \d{4} [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d\.\d{7}  \d[ \d]{2}\d")
_OBS = re.compile(r"^[GRECJIS][ \d]\d")

#: Plausibility bounds of a GPS pseudorange (m), for a receiver on or near the Earth:
#: geometric ranges to GPS satellites lie between about 20,000 and 26,000 km, and a receiver
#: clock offset of up to 1 ms adds +-300 km. Receivers that let their clock run further, or
#: in orbit, need other bounds (``read_code_carrier``'s parameters).
PSEUDORANGE_MIN_M = 1.0e7
PSEUDORANGE_MAX_M = 5.0e7


@dataclass
class RinexScan:
    """What :func:`check_rinex3_obs` found in a RINEX 3 observation file.

    Attributes
    ----------
    lines
        The file's lines, with skipped epochs removed and skipped observations blanked:
        what georinex is given.
    line_numbers
        Original line number of each entry of ``lines``.
    epoch_starts
        Index into ``lines`` of each kept epoch's header line.
    header_end
        Index into ``lines`` of END OF HEADER.
    skipped
        ``(line, reason)`` of every epoch or observation skipped, in line order.
    truncated
        Why the file looks cut (an epoch with fewer observation lines than it declares,
        or a last line without its newline), or ``None``.
    """

    lines: list[str]
    line_numbers: list[int]
    epoch_starts: list[int]
    header_end: int
    skipped: list[tuple[int, str]] = field(default_factory=list)
    truncated: str | None = None

    @property
    def changed(self) -> bool:
        return bool(self.skipped)


def _epoch_time(line: str) -> tuple[dt.datetime, float]:
    """``(minute, seconds)`` of an epoch line; columns of RINEX 3.04 table A13."""
    minute = dt.datetime(int(line[2:6]), int(line[7:9]), int(line[10:12]), int(line[13:15]), int(line[16:18]))
    seconds = float(line[18:29])
    if not 0.0 <= seconds < 61.0:  # 60.x only in a leap second
        raise ValueError(f"seconds {seconds:g} outside [0, 61)")
    return minute, seconds


def _fmt_time(t: tuple[dt.datetime, float]) -> str:
    return f"{t[0]:%Y-%m-%d %H:%M}:{t[1]:010.7f}"


def check_rinex3_obs(
    path: str | Path,
    pseudorange_min_m: float = PSEUDORANGE_MIN_M,
    pseudorange_max_m: float = PSEUDORANGE_MAX_M,
    text: str | None = None,
) -> RinexScan:
    """Check a RINEX 3 observation file line by line, before georinex reads it.

    georinex reports parse failures without a line number and accepts epochs out of order;
    this pass names the line of every problem:

    - malformed header, epoch or observation lines are refused (:class:`DataFileError`);
    - a file cut inside an epoch (fewer observation lines than the epoch declares, or a
      last line without its newline) is marked ``truncated`` and the cut epoch skipped;
    - an epoch with the time of an earlier one (duplicate) or before the last kept epoch
      (backwards) is skipped with its observations;
    - a pseudorange (``C`` observation types of any system) outside
      [``pseudorange_min_m``, ``pseudorange_max_m``] is blanked (read as missing) and
      counted as skipped. An epoch declaring fewer observation lines than it has is refused.

    Epochs with event flags 2-5 (header records inside the data) are passed over.
    ``text``, when given, is the file's content (a Hatanaka file decompressed): line
    numbers are then those of that text, and ``path`` only names it in errors.

    Raises
    ------
    DataFileError
        Naming the file and the line.
    """
    _check_bounds(pseudorange_min_m, pseudorange_max_m)
    where = str(Path(path))
    if text is None:
        text = read_input_text(Path(path), errors="replace")
    lines = text.splitlines()
    end = _header_end(lines, where)
    types_of = _observation_types(lines, end, where)
    cut = _cut_inside_last_line(text, lines, end)
    epochs = _group_epochs(lines, end, cut, where)
    verdict = _judge_epochs(lines, epochs, types_of, cut, (pseudorange_min_m, pseudorange_max_m), where)
    out_lines, numbers, starts = _kept_lines(lines, epochs, verdict, types_of)
    return RinexScan(out_lines, numbers, starts, end, sorted(verdict.skipped), verdict.truncated)


# -- the steps of check_rinex3_obs, in order -------------------------------------------------------


def _check_bounds(pseudorange_min_m: float, pseudorange_max_m: float) -> None:
    if not 0 <= pseudorange_min_m < pseudorange_max_m:  # also NaN
        raise ConfigError(
            "pseudorange_min_m/pseudorange_max_m",
            f"need 0 <= min < max, got [{pseudorange_min_m!r}, {pseudorange_max_m!r}] m",
        )


def _header_end(lines: list[str], where: str) -> int:
    """Index of END OF HEADER, after checking that the file is RINEX version 3 or 4 (whose
    observation records are 3.05's: RINEX 4.00 changed the header and navigation files)."""
    if not lines or "RINEX VERSION / TYPE" not in lines[0]:
        raise DataFileError(where, 1, "not a RINEX file: first line lacks 'RINEX VERSION / TYPE'")
    if not lines[0][:9].strip().startswith(("3", "4")):
        raise DataFileError(where, 1, f"RINEX version {lines[0][:9].strip()!r}: this reader checks versions 3 and 4")
    try:
        return next(i for i, line in enumerate(lines) if "END OF HEADER" in line)
    except StopIteration:
        raise DataFileError(where, len(lines), "no END OF HEADER line") from None


def _observation_types(lines: list[str], end: int, where: str) -> dict[str, list[str]]:
    """System letter -> its observation types in order (SYS / # / OBS TYPES records)."""
    types_of: dict[str, list[str]] = {}
    system = ""
    for i, line in enumerate(lines[1:end], 2):
        if "SYS / # / OBS TYPES" not in line:
            continue
        system = line[0] if line[0] != " " else system  # continuation lines start blank
        if line[0] != " ":
            try:
                int(line[3:6])
            except ValueError:
                raise DataFileError(where, i, "bad number of observation types") from None
        types_of.setdefault(system, []).extend(line[7:60].split())
    return types_of


def _cut_inside_last_line(text: str, lines: list[str], end: int) -> str | None:
    """Why the file looks cut inside its last data line (no newline after it), or None."""
    if lines[-1:] and not text.endswith(("\n", "\r")) and len(lines) - 1 > end:
        return f"the last line ({len(lines)}) has no newline: the file was cut inside it"
    return None


def _group_epochs(lines: list[str], end: int, cut: str | None, where: str) -> list[tuple[int, int, list[int]]]:
    """The data part as epochs: (header index, declared count, observation indices).

    Event records (flags 2-5) are passed over; a cut last epoch line is kept with count -1
    so that `_judge_epochs` drops it as truncated.
    """
    epochs: list[tuple[int, int, list[int]]] = []
    i = end + 1
    while i < len(lines):
        line, no = lines[i], i + 1
        if not line.strip():
            i += 1
            continue
        if not line.startswith(">"):
            raise DataFileError(where, no, "observation line outside an epoch (or more than its count)")
        if not _EPOCH.match(line):
            if cut and i == len(lines) - 1:
                epochs.append((i, -1, []))  # the cut epoch line itself: dropped as truncated below
                break
            raise DataFileError(where, no, f"malformed epoch line {line!r}")
        flag, count = int(line[31]), int(line[32:35])
        if flag > 1:  # event records: header lines, no observations
            i += 1 + count
            continue
        body = _epoch_body(lines, i, count, cut, where)
        epochs.append((i, count, body))
        i += 1 + len(body)
    return epochs


def _epoch_body(lines: list[str], i: int, count: int, cut: str | None, where: str) -> list[int]:
    """Indices of the observation lines of the epoch at ``i``: ``count`` lines, fewer only
    where the file is cut (an earlier epoch line is refused)."""
    body = list(range(i + 1, min(i + 1 + count, len(lines))))
    for k, j in enumerate(body):
        if lines[j].startswith(">"):
            if j < len(lines) - 1 or not cut:
                raise DataFileError(
                    where,
                    i + 1,
                    f"epoch declares {count} satellites but has only {k} "
                    f"observation lines (next epoch at line {j + 1})",
                )
            return body[:k]
    return body


@dataclass
class _Verdict:
    """What `_judge_epochs` decided: lines to drop, pseudoranges to blank, and why."""

    skipped: list[tuple[int, str]] = field(default_factory=list)  # (line, reason)
    drop: set[int] = field(default_factory=set)  # line indices
    blank: dict[int, list[int]] = field(default_factory=dict)  # line index -> observation fields
    truncated: str | None = None

    def drop_epoch(self, head: int, body: list[int]) -> None:
        """Drop an epoch with its observations, whose blanked values then no longer count."""
        self.drop.update([head, *body])
        for j in body:
            if j in self.blank:
                del self.blank[j]
                self.skipped[:] = [s for s in self.skipped if s[0] != j + 1]


def _judge_epochs(
    lines: list[str],
    epochs: list[tuple[int, int, list[int]]],
    types_of: dict[str, list[str]],
    cut: str | None,
    bounds_m: tuple[float, float],
    where: str,
) -> _Verdict:
    """Drop a truncated last epoch and duplicate or backward epochs; blank implausible pseudoranges."""
    verdict = _Verdict()
    code_fields_of = {sys_: {j for j, t in enumerate(ts) if t.startswith("C")} for sys_, ts in types_of.items()}
    kept_times: dict[tuple, int] = {}
    last = None
    for n_epoch, (h, count, body) in enumerate(epochs):
        if n_epoch == len(epochs) - 1 and (len(body) < count or cut):
            verdict.truncated = cut or (
                f"the file ends inside the epoch at line {h + 1}: it declares {count} "
                f"satellites, the file holds {len(body)}"
            )
            verdict.skipped.append((h + 1, f"truncated epoch dropped: {verdict.truncated}"))
            verdict.drop.update([h, *body])
            break
        for j in body:
            _check_observation_line(lines[j], j, types_of, code_fields_of, bounds_m, where, verdict)
        t = _epoch_time_at(lines[h], h, where)
        reason = _out_of_order(t, kept_times, last)
        if reason is None:
            kept_times[t] = h + 1
            last = t
        else:
            verdict.skipped.append((h + 1, reason))
            verdict.drop_epoch(h, body)
    return verdict


def _check_observation_line(
    line: str,
    j: int,
    types_of: dict[str, list[str]],
    code_fields_of: dict[str, set[int]],
    bounds_m: tuple[float, float],
    where: str,
    verdict: _Verdict,
) -> None:
    """Refuse a bad satellite id or a value that is not a number; blank a pseudorange
    outside ``bounds_m`` and record it as skipped."""
    if not _OBS.match(line):
        raise DataFileError(where, j + 1, f"bad satellite id {line[:3]!r}")
    lo, hi = bounds_m
    types = types_of.get(line[0], [])
    code_fields = code_fields_of.get(line[0], set())
    for f in range(len(types)):
        value = line[3 + 16 * f : 3 + 16 * f + 14]
        if not value.strip():
            continue
        try:
            x = float(value)
        except ValueError:
            raise DataFileError(where, j + 1, f"observation {f + 1} is not a number: {value!r}") from None
        if f in code_fields and not lo <= x <= hi:
            verdict.blank.setdefault(j, []).append(f)
            verdict.skipped.append(
                (
                    j + 1,
                    f"{line[:3]} {types[f]} = {x:.6g} m outside [{lo:g}, {hi:g}] m "
                    "(pseudorange_min_m/pseudorange_max_m): observation skipped",
                )
            )


def _epoch_time_at(line: str, h: int, where: str) -> tuple[dt.datetime, float]:
    try:
        return _epoch_time(line)
    except ValueError as exc:  # month 13, day 32, hour 24, ...: a corrupted epoch line
        raise DataFileError(where, h + 1, f"impossible epoch time {line[2:29].strip()!r}: {exc}") from None


def _out_of_order(t: tuple[dt.datetime, float], kept_times: dict[tuple, int], last: tuple | None) -> str | None:
    """Why the epoch at time ``t`` is skipped (a duplicate, or backwards), or None to keep it."""
    if t in kept_times:
        return f"duplicate epoch {_fmt_time(t)} (first at line {kept_times[t]}): epoch skipped"
    if last is not None and t < last:
        return f"epoch {_fmt_time(t)} goes backwards (after {_fmt_time(last)}): epoch skipped"
    return None


def _kept_lines(
    lines: list[str], epochs: list[tuple[int, int, list[int]]], verdict: _Verdict, types_of: dict[str, list[str]]
) -> tuple[list[str], list[int], list[int]]:
    """The lines georinex is given (dropped ones removed, implausible pseudoranges blanked),
    their original line numbers, and the index of each kept epoch's header."""
    out_lines: list[str] = []
    numbers: list[int] = []
    starts: list[int] = []
    epoch_heads = {h for h, _, _ in epochs}
    for idx, line in enumerate(lines):
        if idx in verdict.drop:
            continue
        if idx in verdict.blank:
            chars = list(line.ljust(3 + 16 * len(types_of[line[0]])))
            for f in verdict.blank[idx]:
                chars[3 + 16 * f : 3 + 16 * f + 16] = " " * 16
            line = "".join(chars).rstrip()
        if idx in epoch_heads:
            starts.append(len(out_lines))
        out_lines.append(line)
        numbers.append(idx + 1)
    return out_lines, numbers, starts


def _locate_georinex_failure_with(scan: RinexScan, tmp: Path, load: Callable[[Path], object]) -> int | None:
    """Original line of the first epoch ``load`` (georinex) fails on, or ``None`` if no
    single epoch makes it fail. Chunks of epochs are loaded one by one (about the cost of
    one full load), then the failing chunk is bisected."""
    head = scan.lines[: scan.header_end + 1]
    starts = scan.epoch_starts + [len(scan.lines)]

    def fails(a: int, b: int) -> bool:  # epochs a .. b-1 with the header
        tmp.write_text("\n".join(head + scan.lines[starts[a] : starts[b]]) + "\n")
        try:
            load(tmp)
        except Exception:  # noqa: BLE001 - any failure counts
            return True
        return False

    n, size = len(scan.epoch_starts), 64
    for a in range(0, n, size):
        b = min(a + size, n)
        if fails(a, b):
            lo, hi = a + 1, b  # the shortest failing prefix a .. hi-1 ends with the culprit
            while lo < hi:
                mid = (lo + hi) // 2
                if fails(a, mid):
                    hi = mid
                else:
                    lo = mid + 1
            return scan.line_numbers[starts[lo - 1]]
    return None


def _first_skipped(skipped: list[tuple[int, str]]) -> str:
    """What was skipped, for an error that would otherwise blame the file's content alone."""
    if not skipped:
        return ""
    line, reason = skipped[0]
    return f" left after the checks: {len(skipped)} epochs or observations skipped, the first at line {line}: {reason}"


def _d19(x: float) -> str:
    return f"{x:19.12E}".replace("E", "D")


def write_rinex3_nav(
    path: str | Path, epoch: dt.datetime, ephemerides: dict[int, dict[str, float]], gps_week: int = 2103
) -> None:
    """Write a RINEX 3.04 GPS navigation file (one record per satellite, clock terms zero).

    ``ephemerides`` maps a PRN to the IS-GPS-200 elements under georinex's names
    (``sqrtA``, ``Eccentricity``, ``Io``, ``Omega0``, ``omega``, ``M0``, ``Toe`` and,
    optionally, ``DeltaN``, ``OmegaDot``, ``IDOT`` and the six harmonic corrections).
    """

    def hdr(text: str, label: str) -> str:
        return f"{text:<60}{label:<20}"

    lines = [
        hdr("     3.04           N: GNSS NAV DATA    G: GPS", "RINEX VERSION / TYPE"),
        hdr(f"{'gnssframework':<20}{'gnssframework':<20}{epoch:%Y%m%d %H%M%S} UTC", "PGM / RUN BY / DATE"),
        hdr("", "END OF HEADER"),
    ]
    for prn in sorted(ephemerides):
        e = {k: 0.0 for k in ("DeltaN", "OmegaDot", "IDOT", "Cuc", "Cus", "Crc", "Crs", "Cic", "Cis")}
        e.update(ephemerides[prn])
        lines.append(f"G{prn:02d} {epoch:%Y %m %d %H %M %S}" + _d19(0.0) * 3)
        for row in (
            [1.0, e["Crs"], e["DeltaN"], e["M0"]],
            [e["Cuc"], e["Eccentricity"], e["Cus"], e["sqrtA"]],
            [e["Toe"], e["Cic"], e["Omega0"], e["Cis"]],
            [e["Io"], e["Crc"], e["omega"], e["OmegaDot"]],
            [e["IDOT"], 0.0, float(gps_week), 0.0],
            [2.0, 0.0, 0.0, 1.0],
            [e["Toe"], 4.0],
        ):
            lines.append("    " + "".join(_d19(v) for v in row))
    Path(path).write_text("\n".join(lines) + "\n")
