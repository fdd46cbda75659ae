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

import numpy as np

from gnssframework.estimation import kernels
from gnssframework.experiments import get_scenario
from gnssframework_plugins import estimators as builtin_estimators

SERIES = ("code_error_chips", "freq_error_hz", "position_error_m", "velocity_error_m_s", "nav_nees",
          "code_output_error_chips", "freq_output_error_hz")


def run(estimator: str, backend: str, duration_s: float, nudge: bool = False, reverse: bool = False) -> dict:
    scen = get_scenario({"kind": "vector-tracking", "duration_s": duration_s, "channels": 8, "settle_s": 1.0})
    classes = (builtin_estimators.UnscentedKalmanFilter, builtin_estimators.CubatureKalmanFilter)
    saved = {c: c.__dict__["sigma_points"] for c in classes}
    truth = type(scen).truth
    kernels.set_backend(backend)
    try:
        if reverse:
            for c, f in saved.items():
                c.sigma_points = lambda self, state, f=f: tuple(a[::-1] for a in f(self, state))
        if nudge:
            def nudged(self, *args, **kwargs):
                t, x0, P0 = truth(self, *args, **kwargs)
                return t, np.nextafter(x0, np.inf), P0
            type(scen).truth = nudged
        plugins = scen.build({"channel_filter": {"name": "iq-filter", "params": {"estimator": estimator}},
                              "nav_filter": {"name": "ekf-pv", "params": {"clock": "ocxo"}}})
        return scen.run_batch({"cn0_dbhz": 30.0}, plugins, 2, np.random.default_rng(5)).series
    finally:
        kernels.set_backend(None)
        type(scen).truth = truth
        for c, f in saved.items():
            c.sigma_points = f


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds per run")
    args = parser.parse_args()
    for estimator in ("svd-ckf", "ckf", "ukf"):
        ref = run(estimator, "numpy", args.duration)
        others = {"numba": run(estimator, "numba", args.duration),
                  "1 ulp": run(estimator, "numpy", args.duration, nudge=True),
                  "reversed": run(estimator, "numpy", args.duration, reverse=True)}
        print(f"\n{estimator}, 30 dB-Hz, 2 runs x {args.duration:g} s: max |difference| / max |value|")
        print(f"{'series':26s}" + "".join(f"{k:>11s}" for k in others))
        for name in SERIES:
            scale = np.max(np.abs(ref[name]))
            print(f"{name:26s}" + "".join(f"{np.max(np.abs(o[name] - ref[name])) / scale:11.1e}"
                                          for o in others.values()))


if __name__ == "__main__":
    main()
