"""How far rounding alone moves a closed vector loop, beside the compiled path's change.

The accuracy companion of the speed benchmarks (docs/benchmarks.md, "Closed-loop
results and rounding"). For each sigma-point engine of ``iq-filter`` (with ``ekf-pv``,
the vector-tracking scenario at 30 dB-Hz, 2 runs) it prints, per time series, the
largest difference from the NumPy reference relative to the series' largest value:

- ``numba``: the compiled path (the default backend);
- ``1 ulp``: the NumPy reference with the initial navigation state one ulp up;
- ``reversed``: the NumPy reference with its sigma points summed in reverse order.

    python benchmarks/closed_loop_rounding.py [--duration 5]
"""

from __future__ import annotations

import argparse
import contextlib

import numpy as np

from gnssframework import testing
from gnssframework_plugins import estimators as builtin_estimators

SERIES = (
    "code_error_chips",
    "freq_error_hz",
    "position_error_m",
    "velocity_error_m_s",
    "nav_nees",
    "code_output_error_chips",
    "freq_output_error_hz",
)


@contextlib.contextmanager
def reversed_points():
    """Sigma points summed from the other end (the same point set, another rounding)."""
    classes = (builtin_estimators.UnscentedKalmanFilter, builtin_estimators.CubatureKalmanFilter)
    saved = {c: c.__dict__["sigma_points"] for c in classes}
    for c, f in saved.items():
        c.sigma_points = lambda self, state, f=f: tuple(a[::-1] for a in f(self, state))
    try:
        yield
    finally:
        for c, f in saved.items():
            c.sigma_points = f


def run(estimator: str, backend: str, duration_s: float, nudge: bool = False, reverse: bool = False) -> dict:
    channel = {"name": "iq-filter", "params": {"estimator": estimator}}
    with reversed_points() if reverse else contextlib.nullcontext():
        return testing.vector_loop_series(channel, backend=backend, nudge_initial_ulp=nudge, duration_s=duration_s)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds per run")
    args = parser.parse_args()
    for estimator in ("svd-ckf", "ckf", "ukf"):
        ref = run(estimator, "numpy", args.duration)
        others = {
            "numba": run(estimator, "numba", args.duration),
            "1 ulp": run(estimator, "numpy", args.duration, nudge=True),
            "reversed": run(estimator, "numpy", args.duration, reverse=True),
        }
        print(f"\n{estimator}, 30 dB-Hz, 2 runs x {args.duration:g} s: max |difference| / max |value|")
        print(f"{'series':26s}" + "".join(f"{k:>11s}" for k in others))
        for name in SERIES:
            scale = np.max(np.abs(ref[name]))
            print(
                f"{name:26s}" + "".join(f"{np.max(np.abs(o[name] - ref[name])) / scale:11.1e}" for o in others.values())
            )


if __name__ == "__main__":
    main()
