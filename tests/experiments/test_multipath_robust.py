"""The multipath scenario's gross errors, and examples/multipath_robust.toml's claims."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gnssframework import random_streams
from gnssframework.experiments import get_scenario

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "multipath_robust.toml"


def _noise(**params):
    scenario = get_scenario({"kind": "multipath", "epochs": 400, **params})
    return scenario.simulate(6, random_streams.run_streams(5, (), range(6)))


def test_gross_errors_leave_the_noise_draws_alone():
    clean = _noise()
    dirty = _noise(outlier_probability=0.1, outlier_std_m=30.0, outlier_from_epoch=3)
    hit = clean != dirty
    assert not hit[:3].any()  # no gross error before outlier_from_epoch
    # where there is none, the noise is the same draw
    assert 0.07 < hit.mean() < 0.13
    assert np.std((dirty - clean)[hit]) == pytest.approx(30.0, rel=0.1)


@pytest.mark.slow
def test_the_robust_example_claims_hold(tmp_path):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gnssframework",
            "compare",
            str(EXAMPLE),
            "--out",
            str(tmp_path / "o"),
            "--quiet",
            "--check",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
