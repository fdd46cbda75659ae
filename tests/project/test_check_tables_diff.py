"""docs/check_tables_diff.py: regenerated tables against the committed ones (issue 37)."""

from __future__ import annotations

import importlib.util
import subprocess
from decimal import Decimal
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("check_tables_diff", ROOT / "docs" / "check_tables_diff.py")
check = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check)

TABLE = """| metric | unit | `ackf` | `kf` |
| --- | --- | --- | --- |
| code_phase_error_rmse | chips | 0.0008082 ± 4.6e-05 | (6.56 ± 0.39)e-07 |
| nees_velocity | - | 2.262 ± 0.1 | 30.75 ± 0.28 |
| holds | 45dBHz-S4-0.9 | difference -0.00341 ± 0.00030, ratio 0.8908 ± 0.0088, n=12 |
"""


def test_the_last_printed_digit_sets_the_tolerance():
    assert check.last_digit_unit(Decimal("2.93")) == Decimal("0.01")
    assert check.last_digit_unit(Decimal("4.6e-05")) == Decimal("1e-06")
    assert check.last_digit_unit(Decimal("30")) == 1


def test_one_unit_in_the_last_digit_passes_and_two_fail():
    assert check.differences(TABLE, TABLE) == []
    moved = TABLE.replace("2.262 ± 0.1", "2.263 ± 0.1").replace("0.8908", "0.8907").replace("4.6e-05", "4.7e-05")
    assert check.differences(TABLE, moved) == []
    assert check.differences(TABLE, TABLE.replace("0.8908", "0.8906")) != []  # two units
    assert check.differences(TABLE, TABLE.replace("30.75", "30.85")) != []
    # the exponent after a parenthesised mantissa is text: a decade is never "one unit"
    assert check.differences(TABLE, TABLE.replace(")e-07", ")e-06")) != []
    # words, outcomes and structure must match exactly
    assert check.differences(TABLE, TABLE.replace("holds", "fails")) != []
    assert check.differences(TABLE, TABLE.replace("n=12", "n=11")) != []  # counts are exact
    assert check.differences(TABLE, TABLE + "| extra | row |\n") != []
    # a number printed with one digit more or fewer is compared at the coarser digit
    assert check.differences(TABLE, TABLE.replace("2.262 ± 0.1", "2.26 ± 0.1")) == []
    assert check.differences(TABLE, TABLE.replace("2.262 ± 0.1", "2.28 ± 0.1")) != []


def test_a_repository_table_regenerated_differently_fails_with_a_summary(tmp_path):
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    folder = tmp_path / "generated"
    folder.mkdir()
    (folder / "t.md").write_text(TABLE)
    (folder / "data.json").write_text('{"x": 0.1}')
    subprocess.run(["git", "-C", str(tmp_path), "add", "."], check=True)
    subprocess.run(
        ["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "t"], check=True
    )
    old_root = check.ROOT
    check.ROOT = tmp_path
    try:
        (folder / "data.json").write_text('{"x": 0.10000000000000002}')  # not compared
        (folder / "t.md").write_text(TABLE.replace("0.8908", "0.8909"))
        assert check.check(["generated"]) == (1, [])
        (folder / "t.md").write_text(TABLE.replace("0.8908", "0.9908"))
        (folder / "new.md").write_text("| a |\n")
        n, failures = check.check(["generated"])
        assert n == 1 and len(failures) == 2
        assert "new.md: regenerated but not committed" in failures[0] and "line 5" in failures[1]
        assert check.main(["generated"]) == 1
    finally:
        check.ROOT = old_root


def test_warn_only_reports_without_failing(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(check, "check", lambda folders: (3, ["t.md: line 2: 'a' -> 'b'"]))
    assert check.main(["--warn-only", "generated"]) == 0
    out = capsys.readouterr().out
    assert "t.md: line 2" in out and "1 difference(s)" in out and "--warn-only: not failing" in out
    assert check.main(["generated"]) == 1
    monkeypatch.setattr(check, "check", lambda folders: (3, []))
    assert check.main([]) == 0 and "3 regenerated tables equal the committed ones" in capsys.readouterr().out


CHAOTIC = """**45dBHz**

| metric | unit | `deep` | `deep-ukf-spread` |
| --- | --- | --- | --- |
| height_error_rmse | m | 0.4259 ± 0.057 | 0.379 ± 0.052 |
| nees | - | 8.629 ± 1 | 5.467 ± 0.79 |
| loss_of_lock_fraction | - | 0 | 0 |

| outcome | case | claim | evidence |
| --- | --- | --- | --- |
| holds | 45dBHz | deep-ukf-spread: nees lower than deep's | difference -3.16 ± 0.76, ratio 0.633 ± 0.070, n=24, p=0.00037 |
| holds | 45dBHz | deep-ukf-spread: nees lower than deep-code-disc's | difference -0.01 ± 0.2, n=24, p=0.9 |
"""


def test_a_chaotic_column_is_held_to_its_standard_errors():
    moved = (
        CHAOTIC.replace("0.4259 ± 0.057", "0.4742 ± 0.061")  # 0.85 SE: another arithmetic's realisation
        .replace("8.629 ± 1", "9.1 ± 1.2")
        .replace("-3.16 ± 0.76, ratio 0.633 ± 0.070, n=24, p=0.00037", "-2.7 ± 0.8, ratio 0.69 ± 0.07, n=24, p=0.002")
    )
    assert check.differences(CHAOTIC, moved) != []  # beyond the last digit
    assert check.differences(CHAOTIC, moved, "deep") == []
    # beyond SE_TOLERANCE standard errors, or an SE changed by more than SE_FACTOR
    far = 0.4259 + (check.SE_TOLERANCE + 0.2) * 0.057
    assert check.differences(CHAOTIC, CHAOTIC.replace("0.4259 ± 0.057", f"{far:.4f} ± 0.057"), "deep") != []
    assert check.differences(CHAOTIC, CHAOTIC.replace("0.4259 ± 0.057", "0.4259 ± 0.13"), "deep") != []
    # the other candidates' cells keep their last digit, in the chaotic candidate's table too
    assert check.differences(CHAOTIC, CHAOTIC.replace("0.379 ± 0.052", "0.381 ± 0.052"), "deep") != []
    # a row naming the chaotic candidate holds its text and counts: an outcome, n, a lock count
    assert (
        check.differences(
            CHAOTIC,
            CHAOTIC.replace(
                "| holds | 45dBHz | deep-ukf-spread: nees lower than deep's",
                "| fails | 45dBHz | deep-ukf-spread: nees lower than deep's",
            ),
            "deep",
        )
        != []
    )
    assert check.differences(CHAOTIC, CHAOTIC.replace("n=24, p=0.00037", "n=23, p=0.00037"), "deep") != []
    assert check.differences(CHAOTIC, CHAOTIC.replace("| - | 0 | 0 |", "| - | 0.04 | 0 |"), "deep") != []
    # a row that does not name it (deep-code-disc is another candidate) keeps its digits
    assert check.differences(CHAOTIC, CHAOTIC.replace("p=0.9", "p=0.7"), "deep") != []


def test_every_chaotic_column_names_a_committed_table_and_its_column():
    for path, (name, where) in check.CHAOTIC_COLUMNS.items():
        text = (ROOT / path).read_text(encoding="utf-8")
        assert f"| `{name}` |" in text, path
        page, _, section = where.partition(", ")
        assert (ROOT / page).is_file(), where
        heading = section.split("'")[1]
        assert heading in (ROOT / page).read_text(encoding="utf-8"), where
