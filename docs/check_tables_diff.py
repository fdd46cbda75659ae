"""Regenerated docs tables against the committed ones, within their printed digits.

    python docs/check_tables_diff.py [--warn-only] [FOLDER ...]   # default: docs/experiments/generated

CI runs it after the steps that regenerate the tables from fresh runs (`.ci/run`): every
Markdown table under the folders must equal its committed version (``git show HEAD:``)
except for numbers, and each number must be within one unit in the last digit either
version prints (``0.0412`` against ``0.0413`` passes, against ``0.0415`` fails); integers
(counts of runs, trials, channels) must be equal. The seeds
are fixed, so on one machine the tables come out identical; the tolerance allows what
another CPU's arithmetic moves in the last printed digit. A new table that is not
committed, or a committed one that was not regenerated as a file, fails too. It prints one
line per difference and a one-line summary; exit status 1 if any table differs
(0 with ``--warn-only``, which reports without failing).
JSON files beside the tables (full-precision data behind them) are not compared.
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
    """Text equal; integers (counts: runs, trials, ``n=12``) equal; other numbers within
    one unit in the last digit either prints."""
    if isinstance(x, str) or isinstance(y, str):
        return x == y
    if x.as_tuple().exponent >= 0 and y.as_tuple().exponent >= 0:
        return x == y
    return abs(x - y) <= max(last_digit_unit(x), last_digit_unit(y))


def differences(committed: str, regenerated: str) -> list[str]:
    """Where ``regenerated`` differs from ``committed`` beyond the printed digits, one
    line each (``line N: 'a' -> 'b'``)."""
    found = []
    old_lines, new_lines = committed.splitlines(), regenerated.splitlines()
    if len(old_lines) != len(new_lines):
        found.append(f"{len(old_lines)} lines committed, {len(new_lines)} regenerated")
    for i, (old, new) in enumerate(zip(old_lines, new_lines), start=1):
        if old == new:
            continue
        a, b = tokens(old), tokens(new)
        same = len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b))
        if not same:
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
            f"check_tables_diff: {len(failures)} difference(s) beyond the printed digits in {n} tables "
            f"under {', '.join(folders)}; regenerate and commit them with the change that moves them"
            + (" (--warn-only: not failing)" if warn_only else "")
        )
        return 0 if warn_only else 1
    print(f"check_tables_diff: {n} regenerated tables equal the committed ones within their printed digits")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
