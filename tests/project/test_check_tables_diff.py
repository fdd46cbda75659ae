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
    # numbers without a standard error: one unit in the last digit
    assert (
        check.differences(TABLE, TABLE.replace("0.8908 ± 0.0088", "0.8907 ± 0.0088").replace("4.6e-05", "4.7e-05"))
        == []
    )
    assert check.differences(TABLE, TABLE.replace("-0.00341 ± 0.00030", "-0.00341 ± 0.00032")) == []
    bare = "| ratio | - | 0.8908 | 30.75 |"
    assert check.differences(bare, "| ratio | - | 0.8906 | 30.75 |") != []  # two units
    assert check.differences(bare, "| ratio | - | 0.8908 | 30.85 |") != []
    # the exponent after a parenthesised mantissa is text: a decade is never "one unit"
    assert check.differences(TABLE, TABLE.replace(")e-07", ")e-06")) != []
    # words, outcomes and structure must match exactly
    assert check.differences(TABLE, TABLE.replace("holds", "fails")) != []
    assert check.differences(TABLE, TABLE.replace("n=12", "n=11")) != []  # counts are exact
    assert check.differences(TABLE, TABLE + "| extra | row |\n") != []


def test_a_mean_is_held_to_its_standard_error():
    s = 0.1  # 2.262 ± 0.1
    within = 2.262 + (check.SE_TOLERANCE - 0.2) * s
    beyond = 2.262 + (check.SE_TOLERANCE + 0.2) * s
    assert check.differences(TABLE, TABLE.replace("2.262 ± 0.1", f"{within:.3f} ± 0.1")) == []
    assert check.differences(TABLE, TABLE.replace("2.262 ± 0.1", f"{beyond:.3f} ± 0.1")) != []
    # the larger of the two standard errors sets the width
    assert check.differences(TABLE, TABLE.replace("2.262 ± 0.1", f"{beyond:.3f} ± 0.2")) == []
    # a paired difference and a ratio of means in a claim's evidence: the same rule
    moved = TABLE.replace("-0.00341 ± 0.00030, ratio 0.8908 ± 0.0088", "-0.00330 ± 0.00031, ratio 0.8950 ± 0.0090")
    assert check.differences(TABLE, moved) == []
    far = TABLE.replace("-0.00341 ± 0.00030", "-0.00241 ± 0.00030")
    assert check.differences(TABLE, far) != []
    # a standard error within SE_FACTOR either way, not beyond
    assert (
        check.differences(TABLE, TABLE.replace("30.75 ± 0.28", f"30.75 ± {0.28 * (check.SE_FACTOR - 0.5):.2f}")) == []
    )
    assert (
        check.differences(TABLE, TABLE.replace("30.75 ± 0.28", f"30.75 ± {0.28 * (check.SE_FACTOR + 0.5):.2f}")) != []
    )
    # a mean in parentheses with a shared exponent
    assert check.differences(TABLE, TABLE.replace("(6.56 ± 0.39)e-07", "(6.90 ± 0.39)e-07")) == []
    assert check.differences(TABLE, TABLE.replace("(6.56 ± 0.39)e-07", "(8.56 ± 0.39)e-07")) != []


def test_p_values_follow_the_compared_difference_and_counts_stay_exact():
    row = "| holds | 35dBHz | a: x lower than b's | difference -3.16 ± 0.76, n=24, p=0.00037, Holm-adjusted p=0.0015 of 5 |"
    assert check.differences(row, row.replace("p=0.00037", "p=0.0021").replace("p=0.0015", "p=0.0044")) == []
    assert check.differences(row, row.replace("holds", "fails")) != []
    assert check.differences(row, row.replace("n=24", "n=23")) != []
    assert check.differences(row, row.replace("of 5", "of 6")) != []
    lock = "| loss_of_lock_fraction | - | 0 | 0 |"
    assert check.differences(lock, "| loss_of_lock_fraction | - | 0.04 | 0 |") != []


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
        (folder / "t.md").write_text(TABLE.replace("0.8908", "0.9908"))  # 11 SE
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


def test_a_heavy_tailed_mean_keeps_its_sign_only():
    # one diverged run of a loop that lost lock moved these under another arithmetic
    row = "| horizontal_velocity_error_rmse | m/s | 0.05912 ± 0.0026 | 21.9 ± 3.9 |"
    assert check.differences(row, row.replace("21.9 ± 3.9", "49.71 ± 27")) == []
    assert check.differences(row, row.replace("21.9 ± 3.9", "49.71 ± 3.9")) != []  # not heavy: 7 SE
    claim = "| holds | 35dBHz | deep: x lower than b's | difference -21.8 ± 3.9, ratio 0.00270 ± 0.00049, n=24 |"
    heavy = claim.replace("-21.8 ± 3.9, ratio 0.00270 ± 0.00049", "-50 ± 19, ratio 0.00119 ± 0.00065")
    assert check.differences(claim, heavy) == []
    assert check.differences(claim, heavy.replace("-50 ± 19", "50 ± 19")) != []  # the sign flipped
    # a difference within noise of 0 may change sign
    noise = "| phase | rad | -0.000002 ± 0.000011 |"
    assert check.differences(noise, noise.replace("-0.000002", "0.000004")) == []
    # a detectable difference is a multiple of a standard error
    mdd = "| holds | n=4 (n < 12: detects differences >= 0.47 at power 0.8, >= 0.69 after adjustment) |"
    assert check.differences(mdd, mdd.replace("0.47", "0.5").replace("0.69", "0.73")) == []
    assert check.differences(mdd, mdd.replace("0.47", "2.5")) != []


def test_the_adjustments_reported_only_verdicts_follow_the_p_values():
    """Holm's verdicts follow from the p-values alone (not compared): a p-value that crosses
    0.05 under another arithmetic changes them, the family's size does not."""
    row = (
        "| holds | misalignment-35dBHz | deep: x higher than in nominal-35dBHz | difference +0.0130 ± 0.0020, "
        "n=12, p=0.029, Holm-adjusted p=0.052 of 13 (not significant after adjustment) |"
    )
    crossed = row.replace("p=0.052", "p=0.046").replace(" (not significant after adjustment)", "")
    assert check.differences(row, crossed) == []
    assert check.differences(row, crossed.replace("+0.0130 ± 0.0020", "+0.0330 ± 0.0020")) != []
    assert check.differences(row, row.replace("holds", "fails")) != []
    summary = (
        "**Claims**: 21 of 21 hold (95 % intervals). 11 of the 13 tests hold after Holm's adjustment over the example."
    )
    assert check.differences(summary, summary.replace("11 of the 13", "13 of the 13")) == []
    assert check.differences(summary, summary.replace("11 of the 13", "11 of the 14")) != []
    assert check.differences(summary, summary.replace("21 of 21 hold", "20 of 21 hold")) != []
