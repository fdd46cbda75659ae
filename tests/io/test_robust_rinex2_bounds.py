"""Issue 38: the pseudorange plausibility bounds are validated for every RINEX version and
applied to RINEX 2 files as to RINEX 3 ones (on main a RINEX 2 file skipped nothing and
accepted NaN or inverted bounds)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError, DataFileError
from gnssframework.io.observations import read_observations

RINEX2 = Path(__file__).parents[1] / "data" / "07590920.05o"


def test_rinex2_pseudoranges_below_the_minimum_are_skipped_and_listed(tmp_path, capsys):
    plain = read_observations(RINEX2, "G")
    low = plain.valid & (plain.pseudorange_m < 2.2e7)
    assert low.sum() > 0  # the file has satellites closer than 22,000 km
    bounded = read_observations(RINEX2, "G", pseudorange_min_m=2.2e7)
    assert len(bounded.skipped) == int((np.isfinite(plain.pseudorange_m) & (plain.pseudorange_m < 2.2e7)).sum())
    assert not np.any(bounded.pseudorange_m < 2.2e7)
    assert all("outside [2.2e+07, 5e+07] m" in why and line > 0 for line, why in bounded.skipped)
    out = tmp_path / "s.csv"
    assert main(["smooth", str(RINEX2), "--prn", "G", "--out", str(out), "--pseudorange-min", "2.2e7"]) == 3
    rows = list(csv.DictReader(out.open()))
    assert rows and min(float(r["pseudorange_m"]) for r in rows) >= 2.2e7
    with pytest.raises(DataFileError, match="without --strict"):
        read_observations(RINEX2, "G", pseudorange_min_m=2.2e7, strict=True)


@pytest.mark.parametrize("lo, hi", [(float("nan"), 5e7), (3e7, 2e7), (1e7, float("nan")), (-1.0, 5e7)])
def test_bounds_that_cannot_hold_are_refused_for_rinex2(lo, hi, tmp_path, capsys):
    with pytest.raises(ConfigError, match="need 0 <= min < max"):
        read_observations(RINEX2, "G", pseudorange_min_m=lo, pseudorange_max_m=hi)
    code = main(
        [
            "smooth",
            str(RINEX2),
            "--prn",
            "G",
            "--out",
            str(tmp_path / "s.csv"),
            "--pseudorange-min",
            str(lo),
            "--pseudorange-max",
            str(hi),
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and "--pseudorange-m" in err and err.count("\n") == 1
