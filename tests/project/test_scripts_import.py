"""The benchmark and validation scripts are not imported by the suite, so a helper moved
or renamed in the library (or in a sibling script) would break them silently until CI
or a user ran them. Each must at least start: ``--help`` (or a plain import, for the
shared helper modules) exits 0."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted([*ROOT.glob("benchmarks/*.py"), *ROOT.glob("validation/*.py")])


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_script_starts(script: Path) -> None:
    run = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert run.returncode == 0, f"{script.relative_to(ROOT)} --help exited {run.returncode}:\n{run.stderr[-2000:]}"
