"""examples/vector_tracking_fault_ci.toml's claims (docs/estimators/integrity.md, "Vector
tracking: a faulty channel"), from a fresh run: the channel monitor excludes nothing
without a fault, excludes the faulty channel from 1.5 or 2.5 intervals after a 60 m step to
the end, and removes most of the step's and the ramp's position error.

The claims are judged by the library's claim checker on the paired runs (the same as
``gnssframework compare ... --check``); the test also holds every claim's evidence to the
runs the example asks for, so a claim cannot pass on fewer runs or an empty case. About 11 CPU-seconds with the numba
cache warm (75 cold, compiling the loop kernels).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gnssframework.experiments import load_config, run_comparison
from gnssframework.io.files import loads_strict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "vector_tracking_fault_ci.toml"


@pytest.mark.slow
def test_the_fault_example_claims_hold(tmp_path):
    config = load_config(EXAMPLE)
    summary = loads_strict(run_comparison(config, tmp_path / "out", progress=False).read_text())
    claims = summary["claims"]
    assert len(claims) == len(config.claims) == 4
    failed = [f"{c['case']}: {c['statement']} -> {c['outcome']}" for c in claims if c["outcome"] != "holds"]
    assert not failed, "\n".join(failed)
    assert all(c["n"] == config.runs == 12 for c in claims)
