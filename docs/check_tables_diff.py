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

One kind of column is held to its standard errors instead: a candidate whose closed loop is
chaotic at the scale of rounding (`CHAOTIC_COLUMNS`), whose per-run values are one
realisation of that chaos and whose means another arithmetic moves by about a standard
error. Under its column, and in every row that names it (a claim or paired difference
against it), text and counts must still be equal, each ``a ± s`` must lie within
`SE_TOLERANCE` times the larger ``s`` of the two versions and ``s`` within a factor of
`SE_FACTOR`; its other decimals (the p-values of those differences) are not compared.
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


#: Tables holding a candidate whose closed loop is chaotic at the scale of rounding: table path
#: -> (the candidate's name, where the page measures and explains it). Its means are good to
#: their standard errors, not to their last digit, on another x86 arithmetic.
CHAOTIC_COLUMNS: dict[str, tuple[str, str]] = {
    "docs/experiments/generated/deep_integration_nees_ci.md": (
        "deep",
        "docs/experiments/deep-integration.md, 'Reproducible on one arithmetic': the UKF at "
        "alpha = 1e-3 on the prompt's kink; means moved by up to about 2 paired SE",
    ),
}
#: A chaotic cell's ``a ± s``: ``a`` may move by this many standard errors (the larger ``s``
#: of the two versions: two realisations of the chaos on common random numbers move
#: far less than independent runs, whose difference is sqrt(2) s wide)...
SE_TOLERANCE = 5
#: ... and ``s`` itself by this factor either way (24 runs estimate it to about 15 %).
SE_FACTOR = 2


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


def _same(old: str, new: str) -> bool:
    """``old`` and ``new`` equal within their printed digits (`_close`, token by token)."""
    a, b = tokens(old), tokens(new)
    return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b))


def _within_standard_errors(old: str, new: str) -> bool:
    """A chaotic cell: text and integers equal, each ``a ± s`` within `SE_TOLERANCE` of the
    larger ``s`` and ``s`` within `SE_FACTOR`, other decimals not compared."""
    a, b = tokens(old), tokens(new)
    if len(a) != len(b):
        return False
    for i, (x, y) in enumerate(zip(a, b)):
        if isinstance(x, str) or isinstance(y, str):
            if x != y:
                return False
        elif i >= 2 and str(a[i - 1]).strip() == "±":  # a standard error
            if min(abs(x), abs(y)) * SE_FACTOR < max(abs(x), abs(y)):
                return False
        elif i + 2 < len(a) and str(a[i + 1]).strip() == "±":  # a mean
            sx, sy = a[i + 2], b[i + 2]
            if not (isinstance(sx, Decimal) and isinstance(sy, Decimal)):
                return False
            if abs(x - y) > SE_TOLERANCE * max(abs(sx), abs(sy)):
                return False
        elif x.as_tuple().exponent >= 0 or y.as_tuple().exponent >= 0:  # a count (n=24, 0)
            if x != y:
                return False
    return True


def _cells(line: str) -> list[str] | None:
    """The cells of a Markdown table row, or None for a line that is not one."""
    stripped = line.strip()
    if not (stripped.startswith("|") and stripped.endswith("|")):
        return None
    return stripped[1:-1].split("|")


def differences(committed: str, regenerated: str, chaotic: str | None = None) -> list[str]:
    """Where ``regenerated`` differs from ``committed`` beyond the printed digits, one
    line each (``line N: 'a' -> 'b'``). ``chaotic``: a candidate whose column, and the
    rows naming it, are held to their standard errors (`CHAOTIC_COLUMNS`)."""
    found = []
    old_lines, new_lines = committed.splitlines(), regenerated.splitlines()
    if len(old_lines) != len(new_lines):
        found.append(f"{len(old_lines)} lines committed, {len(new_lines)} regenerated")
    names = re.compile(rf"(?<![\w-]){re.escape(chaotic)}(?![\w-])") if chaotic else None
    columns: set[int] = set()  # the chaotic candidate's columns in the current table
    for i, (old, new) in enumerate(zip(old_lines, new_lines), start=1):
        old_cells, new_cells = _cells(old), _cells(new)
        if old_cells is None:
            columns = set()
        elif chaotic and i < len(old_lines) and old_lines[i].strip().startswith("| ---"):
            columns = {k for k, cell in enumerate(old_cells) if cell.strip() == f"`{chaotic}`"}
        if old == new:
            continue
        if names is None or old_cells is None or new_cells is None or len(old_cells) != len(new_cells):
            same = _same(old, new)
        else:
            whole_row = bool(names.search(old))
            same = all(
                _within_standard_errors(x, y) if whole_row or k in columns else _same(x, y)
                for k, (x, y) in enumerate(zip(old_cells, new_cells))
            )
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
        chaotic = CHAOTIC_COLUMNS.get(path, (None, ""))[0]
        failures += [f"{path}: {line}" for line in differences(old, new, chaotic)]
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
