"""The helpers of validation/rtklib_loss_of_lock.py (the script itself needs rnx2rtkp and
runs in CI where RTKLIB is installed): reading rnx2rtkp's solution file and its trace's
slip lines, matching its epochs to ours, and the exit code when rnx2rtkp is absent. Their
doctests run here too."""

from __future__ import annotations

import doctest
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("rtklib_loss_of_lock", ROOT / "validation" / "rtklib_loss_of_lock.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


def test_the_doctests_pass(script):
    result = doctest.testmod(script)
    assert result.attempted >= 3 and result.failed == 0


def test_a_solution_file_is_read_row_by_row(script):
    # The head of a file rnx2rtkp (RTKLIB 2.4.3, Debian) wrote in the script's run.
    text = (
        "% program   : RTKLIB ver.2.4.3\n"
        "% (x/y/z-ecef=WGS84,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)\n"
        "%  GPST              x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   sdy(m)   sdz(m)  "
        "sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio\n"
        "1316 518712.997  -3976219.6472   3382372.4619   3652512.6922   5   5  15.7544  12.6307  11.6706 "
        "-13.1992   9.9733 -11.5012   0.00    0.0\n"
        "1316 518715.997  -3976218.2946   3382370.4578   3652512.4891   5   4  30.0478  21.6669  11.6765 "
        "-24.9934  10.2304 -11.8289   0.00    0.0\n"
    )
    tow, xyz, ns = script.parse_pos(text)
    assert tow.tolist() == [518712.997, 518715.997]
    np.testing.assert_array_equal(xyz[1], [-3976218.2946, 3382370.4578, 3652512.4891])
    assert ns.tolist() == [5, 4]


def test_epochs_match_only_within_the_tolerance(script):
    theirs = np.array([10.0, 11.0, 12.0, 13.0])
    k, ok = script.match_epochs(theirs, np.array([9.0, 10.0, 11.0004, 12.6, 13.0, 20.0]))
    assert k.tolist() == [0, 0, 1, 3, 3, 3]
    assert ok.tolist() == [False, True, True, False, True, False]
    k, ok = script.match_epochs(np.zeros(0), np.array([1.0]))
    assert not ok.any()


def test_slips_are_counted_per_satellite(script):
    trace = "\n".join(
        [
            "3 detslp_ll: n=5",
            "3 detslp_ll: slip detected sat=20 f=1",
            "3 detslp_gf: n=5",
            "3 detslp_ll: slip detected sat=20 f=1",
            "3 detslp_ll: slip detected sat= 3 f=1",
        ]
    )
    assert script.count_slips(trace) == {3: 1, 20: 2}
    assert script.count_slips("3 detslp_ll: n=5\n") == {}


def test_without_rnx2rtkp_it_exits_2_saying_why(script, monkeypatch, capsys):
    monkeypatch.setattr(script.shutil, "which", lambda name: None)
    assert script.main([]) == 2
    assert "rnx2rtkp is not on PATH (Debian package rtklib)" in capsys.readouterr().err
