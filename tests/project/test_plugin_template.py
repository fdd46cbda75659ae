"""The example third-party plugin installs into a fresh environment and is registered."""

from __future__ import annotations

import pytest
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
TEMPLATE = ROOT / "examples" / "plugin-template"


@pytest.mark.slow
def test_template_installs_and_registers(tmp_path):
    target = tmp_path / "site"
    source = tmp_path / "plugin-template"  # build from a copy: never write into the repository
    shutil.copytree(TEMPLATE, source, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    probe = (
        "import gnssframework as gf, numpy as np\n"
        "info = {(i.kind, i.name): i for i in gf.registry.describe()}['estimator', 'fading-kf']\n"
        "print(info.distribution, info.version)\n"
        "kf = gf.registry.create('estimator', 'fading-kf', alpha=1.0)\n"
        "m = gf.LinearModel([[1.0]], [[1.0]], [[0.1]], [[1.0]])\n"
        "s = kf.update(kf.predict(gf.Gaussian([0.0], [[2.0]]), m), [1.0], m).state\n"
        "print(float(s.mean[0]), float(s.cov[0, 0]))\n"
        "try:\n"
        "    gf.registry.create('estimator', 'fading-kf', alpha=0.5)\n"
        "except gf.ConfigError as e:\n"
        "    print('rejected', 'alpha' in str(e))\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(target), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run(
        [sys.executable, "-c", probe], check=True, capture_output=True, text=True, env=env, cwd=tmp_path
    ).stdout.split("\n")
    assert out[0] == "gnssframework-fading 0.1.0"
    mean, var = map(float, out[1].split())
    # alpha = 1 is the Kalman filter: prior 2.1, gain 2.1/3.1.
    np.testing.assert_allclose([mean, var], [2.1 / 3.1, 2.1 / 3.1], rtol=1e-12)
    assert out[2] == "rejected True"
