"""Regenerated docs tables against the committed ones, within the precision they print.

    python docs/check_tables_diff.py [--warn-only] [FOLDER ...]   # default: docs/experiments/generated

CI runs it after the steps that regenerate the tables from fresh runs (`.ci/run`): every
Markdown table under the folders must equal its committed version (``git show HEAD:``)
except for numbers, and each number must agree to the precision the table states for it:

- a mean printed with its standard error, ``a ± s`` (a metric's mean, a paired
  difference, a ratio of means): ``a`` within `SE_TOLERANCE` standard errors (the larger
  ``s`` of the two versions), ``s`` within a factor of `SE_FACTOR`;
- a mean whose standard error is above `HEAVY` (a quarter) of it, in either version: its
  sign only, where both are 2 standard errors from 0 (a heavy-tailed metric, dominated by
  its worst run, or a difference within noise of 0);
- a detectable difference (after ``>=``): within `SE_FACTOR`, as a standard error;
- a p-value (after ``p=``): not compared (it follows from the difference and its standard
  error, compared above; the verdict beside it, ``holds`` or ``fails``, is text); nor what
  follows from the p-values alone and is reported only, the multiple-comparison adjustment's
  verdicts (`ADJUSTED`: a claim's ``(not significant after adjustment)`` and the count of
  ``N of the M tests hold after Holm's adjustment``, whose ``M`` is compared): a p-value
  near 0.05 crosses it under another arithmetic (on an AMD EPYC, reference 002's
  g-sensitivity and misalignment claims moved from a Holm-adjusted p of 0.052 to 0.046
  while their differences moved by a fifth of a standard error);
- an integer (counts of runs, trials, channels; ``n=24``; a lock fraction of 0): equal;
- any other number: within one unit in the last digit either version prints (``0.0412``
  against ``0.0413`` passes, against ``0.0415`` fails).

Why standard errors and not the last digit: the seeds are fixed, so on one machine the
tables come out identical, but another x86 arithmetic (numba's target, NumPy's SIMD loops,
OpenBLAS's kernel) rounds differently, and a closed loop carries a rounding difference into
every later step. Regenerated under two other arithmetics (numba for generic x86-64 with
NumPy's AVX2 loops off; numba for haswell with OpenBLAS's Prescott kernel), 74 and 96 table
lines (in 8 of 42 tables) moved beyond their last digit: a well-behaved loop's means by a
few hundredths of their standard error, those of a loop that loses lock or of a UKF at
alpha 1e-3 on the prompt's kink (chaotic, docs/experiments/deep-integration.md) by up to
about 2 standard errors, their standard errors by up to a factor of 3, and the
heavy-tailed means of a diverging loop by far more (`HEAVY`). A mean is only claimed to its standard error, so that
is the tolerance. One claim's verdict moved, a t interval on such a heavy-tailed mean; it is
now stated by sign (examples/deep_integration_elevation_ci.toml).

A new table that is not committed, or a committed one that was not regenerated as a file,
fails too. It prints one line per difference and a one-line summary; exit status 1 if any
table differs (0 with ``--warn-only``, which reports without failing). JSON files beside
the tables (full-precision data behind them) are not compared.
"""

from __future__ import annotations

import re
import subprocess
import sys
from decimal import Decimal
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ("docs/experiments/generated",)

#: A number as a table prints it: not part of a word (``S4``, and ``e-05`` after a mantissa
#: in parentheses stays text: a decade is never "one unit"), an optional sign, digits with
#: an optional point, an exponent.
NUMBER = re.compile(r"(?<![A-Za-z_\d.])(?<![A-Za-z][-+])[-+−]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


#: A mean ``a ± s`` may move by this many standard errors (the larger ``s`` of the two
#: versions): another arithmetic moved the means of loops that lose lock by up to about 2.
SE_TOLERANCE = 3
#: ... and ``s`` itself by this factor either way (up to about 3 seen), as a detectable
#: difference (``detects differences >= 0.47``), a multiple of it.
SE_FACTOR = 4
#: A mean whose standard error is above this fraction of it, in either version, is known to
#: no better than about ±50 %: a heavy-tailed metric (the errors of a loop that loses lock,
#: dominated by its worst run), or a difference within noise of 0. Only its sign is compared
#: (where both versions are 2 standard errors from 0), not its size or its error: under
#: another arithmetic one diverged run of such a loop moved a mean from 21.9 ± 3.9 to
#: 49.7 ± 27 m/s and a NEES from 1.2e5 ± 6.5e4 to 1.7e6 ± 1.6e6.
HEAVY = Decimal("0.25")


#: The adjustment's reported-only verdicts (see the module text), taken out of a line before
#: it is compared: the suffix of a claim that holds but not after the adjustment, and the
#: number of tests that hold after it (the family's size stays).
ADJUSTED = (
    (re.compile(r" \(not significant after adjustment\)"), ""),
    (re.compile(r"\d+ of the (\d+) tests hold after"), r"N of the \1 tests hold after"),
)


def reported_only_removed(line: str) -> str:
    """``line`` without the adjustment's reported-only verdicts (`ADJUSTED`)."""
    for pattern, replacement in ADJUSTED:
        line = pattern.sub(replacement, line)
    return line


def tokens(text: str) -> list[str | Decimal]:
    """``text`` as alternating text (whitespace runs collapsed to one space) and numbers."""
    out: list[str | Decimal] = []
    pos = 0
    for m in NUMBER.finditer(text):
        out.append(re.sub(r"\s+", " ", text[pos : m.start()]))
        out.append(Decimal(m.group().replace("−", "-")))
        pos = m.end()
    out.append(re.sub(r"\s+", " ", text[pos:]))
    return out


def last_digit_unit(number: Decimal) -> Decimal:
    """One unit in the last printed digit of ``number`` (``2.93`` -> 0.01, ``1.5E-5`` -> 1E-6)."""
    return Decimal(1).scaleb(number.as_tuple().exponent)


def _close(x: str | Decimal, y: str | Decimal) -> bool:
    """Text equal; integers (counts: runs, trials, ``n=12``, a lock fraction of 0) equal,
    also to a number printed with decimals; other numbers within one unit in the last
    digit either prints."""
    if isinstance(x, str) or isinstance(y, str):
        return x == y
    if x.as_tuple().exponent >= 0 or y.as_tuple().exponent >= 0:
        return x == y
    return abs(x - y) <= max(last_digit_unit(x), last_digit_unit(y))


def _same(old: str, new: str) -> bool:
    """``old`` and ``new`` equal to the precision the table prints (the module's rules):
    text equal, token by token; each number by its role (a mean with its standard error,
    that standard error, a p-value, a count, any other number)."""
    a, b = tokens(reported_only_removed(old)), tokens(reported_only_removed(new))
    if len(a) != len(b):
        return False
    heavy: set[int] = set()  # standard errors of heavy-tailed means: not compared
    for i, (x, y) in enumerate(zip(a, b)):
        if isinstance(x, str) or isinstance(y, str):
            if x != y:
                return False
            continue
        if i + 2 < len(a) and str(a[i + 1]).strip() == "±":  # a mean with its standard error
            sx, sy = a[i + 2], b[i + 2]
            if not (isinstance(sx, Decimal) and isinstance(sy, Decimal)):
                return False
            if abs(sx) > HEAVY * abs(x) or abs(sy) > HEAVY * abs(y):
                heavy.add(i + 2)
                significant = abs(x) > 2 * abs(sx) and abs(y) > 2 * abs(sy)
                if significant and (x > 0) != (y > 0):
                    return False
                continue
        if _close(x, y) or i in heavy:
            continue
        before = str(a[i - 1]) if i else ""
        if before.strip() == "±" or before.rstrip().endswith(">="):  # a standard error, or a multiple
            if min(abs(x), abs(y)) * SE_FACTOR < max(abs(x), abs(y)):  # of one (a detectable difference)
                return False
        elif i + 2 < len(a) and str(a[i + 1]).strip() == "±":  # a mean with its standard error
            sx, sy = a[i + 2], b[i + 2]
            if isinstance(sx, str) or isinstance(sy, str) or abs(x - y) > SE_TOLERANCE * max(abs(sx), abs(sy)):
                return False
        elif not before.rstrip().endswith("p="):  # a count or another number, beyond _close
            return False
    return True


def differences(committed: str, regenerated: str) -> list[str]:
    """Where ``regenerated`` differs from ``committed`` beyond the precision the table
    prints, one line each (``line N: 'a' -> 'b'``)."""
    found = []
    old_lines, new_lines = committed.splitlines(), regenerated.splitlines()
    if len(old_lines) != len(new_lines):
        found.append(f"{len(old_lines)} lines committed, {len(new_lines)} regenerated")
    for i, (old, new) in enumerate(zip(old_lines, new_lines), start=1):
        if old != new and not _same(old, new):
            found.append(f"line {i}: {old.strip()!r} -> {new.strip()!r}")
    return found


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)


def check(folders: list[str]) -> tuple[int, list[str]]:
    """(tables compared, lines of failure) for the Markdown tables under ``folders``."""
    committed = set(_git("ls-files", "--", *folders).stdout.split())
    present = {str(p.relative_to(ROOT)) for f in folders for p in (ROOT / f).rglob("*.md")}
    failures = [f"{path}: regenerated but not committed" for path in sorted(present - committed)]
    n = 0
    for path in sorted(p for p in committed if p.endswith(".md")):
        if path not in present:
            failures.append(f"{path}: committed but missing from the regenerated folder")
            continue
        n += 1
        old = _git("show", f"HEAD:{path}").stdout
        new = (ROOT / path).read_text(encoding="utf-8")
        failures += [f"{path}: {line}" for line in differences(old, new)]
    return n, failures


def main(argv: list[str]) -> int:
    warn_only = "--warn-only" in argv
    folders = [a for a in argv if a != "--warn-only"] or list(DEFAULT)
    n, failures = check(folders)
    for line in failures:
        print(line)
    if failures:
        print(
            f"check_tables_diff: {len(failures)} difference(s) beyond the precision they print in {n} tables "
            f"under {', '.join(folders)}; regenerate and commit them with the change that moves them"
            + (" (--warn-only: not failing)" if warn_only else "")
        )
        return 0 if warn_only else 1
    print(f"check_tables_diff: {n} regenerated tables equal the committed ones within the precision they print")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
