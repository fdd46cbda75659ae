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

from ...signal.gps_l1ca import GPS_L1CA
from ...signal.spec import SignalSpec
from .search import AcquisitionResult

__all__ = [
    "MAX_VISIBLE_GPS",
    "MAX_DOPPLER_SPREAD_HZ",
    "MIN_PRNS_FOR_FLOOR",
    "implausible_acquisition",
    "format_hint",
    "check_acquisition",
    "unrepeated",
    "check_samples",
]

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
        reasons.append(
            f"{len(found)} of {len(results)} PRNs found, more than the {MAX_VISIBLE_GPS} GPS satellites "
            "an antenna can see at once"
        )
    if len(results) >= MIN_PRNS_FOR_FLOOR:
        stats = np.array([r.test_statistic for r in results], dtype=float)
        threshold = float(np.median([r.threshold for r in results]))
        median = float(np.median(stats)) if np.all(np.isfinite(stats)) else float("nan")
        if not median < threshold:
            reasons.append(
                f"the median peak statistic over the PRNs searched ({median:.1f}) is at or above the "
                f"detection threshold ({threshold:.1f}), so the samples are not the noise the threshold "
                "assumes"
            )
    if len(found) >= 2:
        dopplers = np.array([r.doppler_hz for r in found])
        spread = float(dopplers.max() - dopplers.min())
        if spread > MAX_DOPPLER_SPREAD_HZ:
            reasons.append(
                f"the found Dopplers span {spread:.0f} Hz, more than the {MAX_DOPPLER_SPREAD_HZ:.0f} Hz "
                "satellite motion allows"
            )
    return "; ".join(reasons) if reasons else None


def _component_bytes(source) -> float:
    """Bytes of one real component (I, Q or a real sample) of a ``sample_source``."""
    per_sample = source.bytes_per_chunk / source.samples_per_chunk
    return per_sample / (2 if source.is_complex else 1)


def _integer_format(is_complex: bool, width: int) -> str | None:
    """A registered ``sample_source`` of integer components ``width`` bytes wide, one
    sample a chunk, complex or real as asked (found by what the formats are, not by name)."""
    from ... import registry

    for name in registry.names("sample_source"):
        cls = registry.get("sample_source", name)
        if (
            cls.is_complex == is_complex
            and cls.samples_per_chunk == 1
            and "i" in cls.sigmf_datatype
            and _component_bytes(cls) == width
        ):
            return name
    return None


def format_hint(path: str | Path, source, offset: int = 0) -> str:
    """The likely cause of an implausible acquisition, read from the recording's bytes.

    Looks at up to 64 KiB from byte ``offset`` of a recording read with ``source`` (its
    ``sample_source``): samples of a few ADC levels (1-4 bits, as front ends record)
    stored one byte each but declared 16-bit show few levels in *both* bytes of each
    16-bit word; 16-bit samples of small values declared 8-bit show every second byte 0
    or -1 (the sign extension); integers declared as 32-bit floats decode to non-finite,
    huge or subnormal values.

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
    name, width = source.name, _component_bytes(source)
    floating = "f" in source.sigmf_datatype
    if not floating and width == 2 and levels_low <= 16 and levels_high <= 16 and sign_extension < 0.9:
        eight = _integer_format(source.is_complex, 1)
        return (
            f"the bytes look like 8-bit samples ({levels_low} and {levels_high} levels in the low and high bytes "
            f"of each 16-bit value, no sign extension) read as {name}" + (f": --format {eight}?" if eight else "")
        )
    if not floating and width == 1 and sign_extension > 0.99 and np.isin(low, (0, -1)).mean() < 0.5:
        sixteen = _integer_format(source.is_complex, 2)
        return f"every second byte is 0 or -1 (the sign bits of small 16-bit values) read as {name}" + (
            f": --format {sixteen}?" if sixteen else ""
        )
    if floating and width == 4:
        values = raw.view("<f4").astype(np.float64)
        odd = ~np.isfinite(values) | (np.abs(values) > 1e20) | ((values != 0) & (np.abs(values) < 1e-30))
        if odd.mean() > 0.01:
            return (
                f"{100 * odd.mean():.0f} % of the values read as {name} are non-finite, huge or subnormal: "
                "integer samples (an integer --format)?"
            )
    return general


#: Fewest satellites found for the repeat check to judge (one or two weak ones may miss).
MIN_FOUND_FOR_REPEAT = 3

#: Largest Doppler change between the two searches of a satellite found again (Hz): the
#: fine search's resolution, as the real recording shows (tests/receiver/test_acquisition.py).
REPEAT_DOPPLER_TOL_HZ = 250.0

#: Largest code-phase miss of a satellite found again (chips): about two samples at
#: 2 MHz, the coarsest rate a C/A search runs at.
REPEAT_CODE_TOL_CHIPS = 1.0


def unrepeated(
    recording, acquisition, results: Sequence[AcquisitionResult], signal: SignalSpec = GPS_L1CA
) -> str | None:
    """Search the found satellites again on the samples right after the first search's
    and count those not found where the first search predicts them: same Doppler, code
    phase moved by the code Doppler, ``cp1 = cp0 + dt f_c (1 + f_d / f_L) mod L`` (the
    ``signal``'s chip rate, carrier and code length; ``dt`` a whole number of code periods:
    the ``dt f_c`` part is whole periods). A
    satellite is there twice; a detection of noise that breaks the detector's model is
    not. ``None`` when most are found again, or too few were found or the recording is too
    short for a second search."""
    from .report import acquire_recording

    found = [r for r in results if r.detected]
    fs = recording.info.sample_rate_hz
    need = acquisition.samples_needed(fs, signal)
    if len(found) < MIN_FOUND_FOR_REPEAT or recording.n_samples < 2 * need:
        return None
    again = {r.prn: r for r in acquire_recording(recording, acquisition, tuple(r.prn for r in found), need, signal)}
    dt = need / fs
    missed = []
    for r in found:
        s = again.get(r.prn)
        expect = r.code_phase_chips + dt * signal.code_freq_hz(r.doppler_hz)
        length = signal.code_length_chips
        miss = abs((s.code_phase_chips - expect + length / 2) % length - length / 2)
        if not (
            s.detected and miss <= REPEAT_CODE_TOL_CHIPS and abs(s.doppler_hz - r.doppler_hz) <= REPEAT_DOPPLER_TOL_HZ
        ):
            missed.append(r.prn)
    if 2 * len(missed) <= len(found):
        return None
    return (
        f"{len(missed)} of the {len(found)} satellites found (PRN {', '.join(map(str, missed))}) are not found "
        f"again {1e3 * dt:.0f} ms later at the Doppler and code phase the first search predicts"
    )


def check_acquisition(
    results: Sequence[AcquisitionResult], recording, acquisition=None, signal: SignalSpec = GPS_L1CA
) -> None:
    """Refuse ``results`` of ``recording`` (a `Recording`) when `implausible_acquisition`
    finds them impossible or, given the ``acquisition`` that made them, `unrepeated` finds
    most of them missing from a second search: a `DataFileError` naming the file, what is
    wrong and the likely cause (`format_hint`).

    Raises
    ------
    DataFileError
        ``"REC: not a GPS sky read as format ci16_le, ...: 31 of 32 PRNs found, ...;
        the bytes look like 8-bit samples ...: --format ci8?"``
    """
    from ...errors import DataFileError

    why = implausible_acquisition(results)
    if why is None and acquisition is not None:
        why = unrepeated(recording, acquisition, results, signal)
    if why is not None:
        raise DataFileError(
            str(recording.path),
            None,
            f"not a GPS sky when read as {recording.info.describe()}: {why}; "
            f"{format_hint(recording.path, recording.source)}",
        )


def check_samples(recording, acquisition, signal: SignalSpec = GPS_L1CA) -> None:
    """Refuse a recording whose samples the search of ``signal`` would read are all one
    value (a blank, zero-filled or unwritten file, a stuck ADC): there is neither signal nor
    the noise the detector's threshold is built on, and the search would divide by a zero
    noise floor.

    Raises
    ------
    DataFileError
        ``"REC: the 32000 samples the search reads are all 0 ..."``
    """
    from ...errors import DataFileError

    fs = recording.info.sample_rate_hz
    need = acquisition.samples_needed(fs, signal)
    if recording.n_samples < need:
        return  # too short: the search says so, naming what it needs
    counted = recording.nonfinite_zeroed
    x = recording.read(0, need)
    recording.nonfinite_zeroed = counted  # the search reads these again and counts them then
    if x.size and np.all(x == x[0]):
        raise DataFileError(
            str(recording.path),
            None,
            f"the {x.size} samples the search reads (read as "
            f"{recording.info.describe()}) are all {x[0]:g}: no noise and no signal (a blank or "
            "zero-filled file, or a stuck front end)",
        )
