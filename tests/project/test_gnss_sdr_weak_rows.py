"""The rows `validation/gnss_sdr_weak.py` writes for the receiver page: a GNSS-SDR run that
failed is said to have failed, not reported as "no fix"; a run with fixes counts the 1 Hz
epochs from its first fix and the simulated PRNs among those it tracked."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "validation"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from gnss_sdr_weak import row  # noqa: E402

SIMULATED = {5, 10, 12}


def test_a_failed_run_is_not_a_missing_fix() -> None:
    line = row("weak", False, 30.0, {"channels": [5], "exit": 1}, 69, SIMULATED)
    assert "exited with 1" in line and "no fix" not in line


def test_a_run_without_fixes_says_no_fix() -> None:
    line = row("default", True, 30.0, {"channels": [3, 5], "exit": 0}, 69, SIMULATED)
    assert line.startswith("| GNSS-SDR 0.0.17, default settings | moving | 30 | 2, 1 of them simulated | no fix |")


def test_a_run_with_fixes_counts_the_epochs_after_its_first() -> None:
    r = {"channels": [1, 5, 10], "exit": 0, "first_fix_s": 49.0, "fixes": 21, "sats": (5, 5), "errors_m": (3.38, 8.07)}
    line = row("weak", False, 35.0, r, 69, SIMULATED)
    assert (
        line
        == "| GNSS-SDR 0.0.17, weak settings | static | 35 | 3, 2 of them simulated | 49.0 | 21 of 21 | 5-5 | 3.38 | 8.07 |"
    )
