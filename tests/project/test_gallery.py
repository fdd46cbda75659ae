"""The gallery's example scripts run and reach their own checks (each asserts its result)."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

GALLERY = pathlib.Path(__file__).resolve().parents[2] / "examples" / "gallery"
SCRIPTS = sorted(GALLERY.glob("*.py"))


def test_the_gallery_holds_the_six_examples():
    assert [p.stem for p in SCRIPTS] == [
        "comparison_sweep",
        "custom_channel_filter",
        "custom_discriminator",
        "first_filter",
        "plugin_to_comparison",
        "reading_rinex",
    ]


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_gallery_script_runs(script, tmp_path):
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip(), "each script prints its result"
