"""docs/spacing_tables.py: the thermal formula it prints, the spacing it fits to the
paper's values, and the committed table against the example it is generated from."""

from __future__ import annotations

import math
import re
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs"))

import spacing_tables  # noqa: E402


def test_thermal_std_is_the_eml_envelope_form():
    # D/(4cT) (1 + 1/((2 - D) cT)) by hand at 45 dB-Hz, 10 ms: cT = 316.23.
    cT = 10**4.5 * 0.01
    for d in (1.0, 0.1):
        expected = math.sqrt(d / (4 * cT) * (1 + 1 / ((2 - d) * cT)))
        assert spacing_tables.thermal_std_chips(d, 45.0, 0.01) == pytest.approx(expected, rel=1e-12)


def test_spacing_for_inverts_the_formula_and_refuses_what_no_spacing_gives():
    d = spacing_tables.spacing_for(0.010, 45.0, 0.01)
    assert spacing_tables.thermal_std_chips(d, 45.0, 0.01) == pytest.approx(0.010, rel=1e-9)
    assert 0.1 < d < 0.15  # 0.010 / 0.0282 chips squared, about 0.126
    assert spacing_tables.spacing_for(0.05, 45.0, 0.01) is None  # above the 1-chip value, 0.0282


def test_the_committed_table_follows_the_example():
    config = tomllib.loads((ROOT / "examples" / "vector_tracking_spacing.toml").read_text())
    values = config["sweeps"][0]["values"]
    text = (ROOT / "docs" / "experiments" / "generated" / "vector_tracking_spacing_theory.md").read_text()
    rows = re.findall(r"^\| ([\d.]+) \| ([\d.e-]+) \|", text, re.M)
    assert [float(v) for v, _ in rows] == values
    T = config["scenario"]["coherent_time_s"]
    cn0 = config["cases"][0]["cn0_dbhz"]
    for value, formula in rows:
        assert float(formula) == pytest.approx(spacing_tables.thermal_std_chips(float(value), cn0, T), rel=5e-3)
