"""Is an acquisition's result one a GPS antenna can give? A check of the found satellites
against what the sky allows and of the search's noise floor against its own noise model.

A recording read with the wrong format, sample rate or IF does not, as a rule, give
"nothing found": the wrongly decoded samples are not white noise, the detector's noise
model (the threshold from the false-alarm probability) no longer holds, and satellites
are "found" by the dozen. The checks here turn such a result into a one-line error naming
the likely cause:

* count: a receiver near the Earth's surface sees at most about 12-14 of the ~31 GPS
  satellites above its horizon (the constellation's 55-degree orbits at 20,200 km put
  under half of it above any horizon: e.g. Kaplan & Hegarty, *Understanding GPS*, 2nd
  ed., sec. 2.3); more than `MAX_VISIBLE_GPS` found is not a sky.
* noise floor: under the noise-only hypothesis a PRN's peak statistic exceeds the
  threshold with the false-alarm probability (0.1 % or less), so the median peak over the
  PRNs searched lies below it whenever at most half of them are present. A median above
  the threshold, with at least `MIN_PRNS_FOR_FLOOR` PRNs searched, says the statistic's
  noise model does not describe these samples.
* Doppler spread: satellites' Dopplers at a receiver near the ground lie within about
  +-4.9 kHz (satellite range rate up to ~930 m/s at L1) plus a common receiver-clock
  offset, so the found ones span at most `MAX_DOPPLER_SPREAD_HZ`.

The likely cause is read from the bytes themselves (`format_hint`): 8-bit samples read
as 16-bit ones, 16-bit ones read as 8-bit, integers read as floats.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .search import AcquisitionResult

__all__ = ["MAX_VISIBLE_GPS", "MAX_DOPPLER_SPREAD_HZ", "MIN_PRNS_FOR_FLOOR", "implausible_acquisition",
           "format_hint", "check_acquisition"]

#: More satellites than this found at once is not a GPS sky seen from near the ground
#: (12-14 is the most the full constellation puts above a horizon; margin for a few at
#: negative elevation seen from a height).
MAX_VISIBLE_GPS = 16

#: Largest spread of the found satellites' Dopplers: 2 x 4.9 kHz of satellite motion
#: plus 2 kHz for a moving receiver (about 380 m/s along opposite lines of sight).
MAX_DOPPLER_SPREAD_HZ = 11_800.0

#: Fewest PRNs searched for the median statistic to be read as the noise floor.
MIN_PRNS_FOR_FLOOR = 8

_BYTES_FOR_HINT = 1 << 16


def implausible_acquisition(results: Sequence[AcquisitionResult]) -> str | None:
    """What makes ``results`` (one per PRN searched) impossible for a GPS sky, or ``None``.

    Parameters
    ----------
    results
        The acquisition's results, one per PRN searched, detected or not.

    Returns
    -------
    str or None
        One sentence ("31 of 32 PRNs found, more than ...") or ``None`` when the result is
        plausible.
    """
    found = [r for r in results if r.detected]
    reasons = []
    if len(found) > MAX_VISIBLE_GPS:
        reasons.append(f"{len(found)} of {len(results)} PRNs found, more than the {MAX_VISIBLE_GPS} GPS satellites "
                       "an antenna can see at once")
    if len(results) >= MIN_PRNS_FOR_FLOOR:
        stats = np.array([r.test_statistic for r in results], dtype=float)
        threshold = float(np.median([r.threshold for r in results]))
        median = float(np.median(stats)) if np.all(np.isfinite(stats)) else float("nan")
        if not median < threshold:
            reasons.append(f"the median peak statistic over the PRNs searched ({median:.1f}) is at or above the "
                           f"detection threshold ({threshold:.1f}), so the samples are not the noise the threshold "
                           "assumes")
    if len(found) >= 2:
        dopplers = np.array([r.doppler_hz for r in found])
        spread = float(dopplers.max() - dopplers.min())
        if spread > MAX_DOPPLER_SPREAD_HZ:
            reasons.append(f"the found Dopplers span {spread:.0f} Hz, more than the {MAX_DOPPLER_SPREAD_HZ:.0f} Hz "
                           "satellite motion allows")
    return "; ".join(reasons) if reasons else None


def format_hint(path: str | Path, format: str, offset: int = 0) -> str:
    """The likely cause of an implausible acquisition, read from the recording's bytes.

    Looks at up to 64 KiB from byte ``offset``: samples of a few ADC levels (1-4 bits, as
    front ends record) stored one byte each but declared 16-bit show few levels in *both*
    bytes of each 16-bit word; 16-bit samples of small values declared 8-bit show every
    second byte 0 or -1 (the sign extension); integers declared as 32-bit floats decode to
    non-finite, huge or subnormal values.

    Returns
    -------
    str
        ``"the bytes look like ...: --format X?"``, or a general pointer to ``--format``,
        ``--fs`` and ``--if`` when the bytes say nothing.
    """
    raw = np.fromfile(Path(path), dtype=np.int8, count=_BYTES_FOR_HINT, offset=offset)
    general = "check --format, --fs and --if (or the SigMF metadata that gave them)"
    if raw.size < 64:
        return general
    raw = raw[: raw.size // 8 * 8]
    low, high = raw[0::2], raw[1::2]
    levels_low, levels_high = np.unique(low).size, np.unique(high).size
    sign_extension = np.isin(high, (0, -1)).mean()
    if "16" in format and levels_low <= 16 and levels_high <= 16 and sign_extension < 0.9:
        eight = "ci8" if format.startswith("c") else "ri8"
        return (f"the bytes look like 8-bit samples ({levels_low} and {levels_high} levels in the low and high bytes "
                f"of each 16-bit value, no sign extension) read as {format}: --format {eight}?")
    if format in ("ci8", "ri8") and sign_extension > 0.99 and np.isin(low, (0, -1)).mean() < 0.5:
        sixteen = "ci16_le" if format == "ci8" else "ri16_le"
        return (f"every second byte is 0 or -1 (the sign bits of small 16-bit values) read as {format}: "
                f"--format {sixteen}?")
    if "f32" in format:
        values = raw.view("<f4").astype(np.float64)
        odd = ~np.isfinite(values) | (np.abs(values) > 1e20) | ((values != 0) & (np.abs(values) < 1e-30))
        if odd.mean() > 0.01:
            return (f"{100 * odd.mean():.0f} % of the values read as {format} are non-finite, huge or subnormal: "
                    "integer samples (--format ci8, ci16_le...)?")
    return general


def check_acquisition(results: Sequence[AcquisitionResult], recording) -> None:
    """Refuse ``results`` of ``recording`` (a `Recording`) when `implausible_acquisition`
    finds them impossible: a `DataFileError` naming the file, what is wrong and the likely
    cause (`format_hint`).

    Raises
    ------
    DataFileError
        ``"REC: not a GPS sky read as format ci16_le, ...: 31 of 32 PRNs found, ...;
        the bytes look like 8-bit samples ...: --format ci8?"``
    """
    from ...errors import DataFileError

    why = implausible_acquisition(results)
    if why is not None:
        raise DataFileError(str(recording.path), None,
                            f"not a GPS sky when read as {recording.info.describe()}: {why}; "
                            f"{format_hint(recording.path, recording.info.format)}")
