"""Two checkouts' compiled kernels and estimator benchmarks, alternated, with ratios.

Times, in processes of each checkout's own code, (1) every compiled Gaussian-rule kernel
alone (the serial driver called on a 5-state / 6-measurement batch of 200 elements, ns
of CPU per element, best of several blocks), (2) ``benchmarks/estimators.py --no-numpy
--no-peers`` and (3) ``benchmarks/vector_loop.py`` (the scripts beside this one, so both
checkouts run the same script on their own library), alternating
BEFORE and AFTER ``--repeats`` times so that both see the same load. Prints the median
of each number over the repeats and the ratio AFTER / BEFORE for times (above 1: AFTER
slower) and BEFORE / AFTER for rates, and the load average before and after.

Each checkout runs with its own ``.venv/bin/python`` if it has one, otherwise with this
interpreter and ``PYTHONPATH`` set to the checkout (its ``gnssframework`` is imported
from there). Both compile into a fresh numba cache first (untimed), so no kernel left
in a checkout's cache by an older build is timed.

    git worktree add /tmp/before c8f2f89     # the commit to compare against
    python benchmarks/compare_commits.py /tmp/before . [--repeats 3] [--only kernels]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent

#: Kernel timing: elements per call, calls per block, blocks (the best block is kept).
_B, _CALLS, _BLOCKS = 200, 100, 7


def _kernel_cases():
    """(name, serial driver, args) of every Gaussian-rule kernel at 5 states, 6 measurements."""
    import numpy as np

    from gnssframework.estimation.compiled import drivers
    from gnssframework.estimation.compiled_model import CompiledFunctions, linear_h, linear_h_jacobian
    from gnssframework.signal.channel_model import channel_model

    rng = np.random.default_rng(0)
    B, n, m = _B, 5, 6
    A = rng.standard_normal((B, n, n))
    cov = np.einsum("bij,bkj->bik", A, A) + n * np.eye(n)
    mean = rng.standard_normal((B, n))
    model = channel_model(0.01, 0.5, np.diag([1e-4, 1e-6, 1e-3, 1e-2, 1e-1]), np.eye(m))
    compiled = model.compiled
    Q, R = model.Q[None].copy(), model.R[None].copy()
    N = 2 * n
    w = np.full(N, 1.0 / N)
    X = np.empty((N, B, n))
    status = np.empty(B, dtype=np.int8)
    drivers._sigma_points_kernels[0](mean, cov, 0, float(np.sqrt(n)), False, X, status)
    Z = rng.standard_normal((N, B, m))
    z_hat, S, C = np.empty((B, m)), np.empty((B, m, m)), np.empty((B, n, m))
    drivers._measurement_moments_kernels[0](X, Z, mean, w, w, R, z_hat, S, C)
    z = z_hat + rng.standard_normal((B, m))
    H = rng.standard_normal((1, m, n))
    bad = np.zeros(B, dtype=np.bool_)
    upd_out = (np.empty((B, n)), np.empty((B, n, n)), np.empty((B, n, m)), np.empty((B, m)), np.empty(B, np.bool_))
    cases = [
        (
            "sigma points (Cholesky)",
            drivers._sigma_points_kernels[0],
            (mean, cov, 0, float(np.sqrt(n)), False, X, status),
        ),
        ("sigma points (eigh)", drivers._sigma_points_kernels[0], (mean, cov, 1, float(np.sqrt(n)), False, X, status)),
        ("predict moments", drivers._predict_moments_kernels[0], (X, w, w, Q, np.empty((B, n)), np.empty((B, n, n)))),
        (
            "measurement moments",
            drivers._measurement_moments_kernels[0],
            (X, Z, mean, w, w, R, np.empty((B, m)), np.empty((B, m, m)), np.empty((B, n, m))),
        ),
        ("update (P - K S K^T)", drivers._update_kernels[0], (mean, cov, z, z_hat, S, C, bad, False, H, R, *upd_out)),
        ("update (Joseph)", drivers._update_kernels[0], (mean, cov, z, z_hat, S, C, bad, True, H, R, *upd_out)),
        (
            "linear predict",
            drivers._linear_predict_kernels[0],
            (mean, cov, compiled.f_params, Q, np.empty((B, n)), np.empty((B, n, n))),
        ),
    ]
    linear = CompiledFunctions(compiled.f, compiled.f_params, linear_h, H[0].copy(), linear_h_jacobian)
    cases.append(
        (
            "ekf moments (linear h)",
            drivers._ekf_pair(linear)[0],
            (mean, cov, linear.h_params, R, np.empty((B, m)), np.empty((B, m, m)), np.empty((B, n, m))),
        )
    )
    rules = {
        "ukf": (0, float(np.sqrt(3.0)), True),
        "ckf": (0, float(np.sqrt(n)), False),
        "svd-ckf": (1, float(np.sqrt(n)), False),
    }
    for label, (kind, scale, center) in rules.items():
        Nr = 2 * n + (1 if center else 0)
        wr = np.full(Nr, 1.0 / Nr)
        cases.append(
            (
                f"fused predict 5x6 ({label})",
                drivers._predict_pair(compiled, n)[0],
                (
                    mean,
                    cov,
                    kind,
                    scale,
                    center,
                    wr,
                    wr,
                    compiled.f_params,
                    Q,
                    np.empty((B, n)),
                    np.empty((B, n, n)),
                    np.empty(B, np.int8),
                    np.empty(1, np.int64),
                ),
            )
        )
        outs = (
            np.empty((B, n)),
            np.empty((B, n, n)),
            np.empty((B, n, m)),
            np.empty((B, m)),
            np.empty((B, m)),
            np.empty((B, m, m)),
            np.empty((B, n, m)),
        )
        cases.append(
            (
                f"fused update 5x6 ({label})",
                drivers._update_pair(compiled, n, m)[0],
                (
                    mean,
                    cov,
                    z,
                    bad,
                    kind,
                    scale,
                    center,
                    wr,
                    wr,
                    compiled.h_params,
                    R,
                    *outs,
                    np.empty(B, np.int8),
                    np.empty(B, np.bool_),
                    np.empty(B, np.bool_),
                    np.empty(3, np.int64),
                ),
            )
        )
    return cases


def _time_kernels() -> dict[str, float]:
    """ns of CPU per element of each kernel (best block of ``_CALLS`` calls)."""
    out = {}
    for name, kernel, args in _kernel_cases():
        kernel(*args)  # load or compile
        best = float("inf")
        for _ in range(_BLOCKS):
            c0 = time.process_time()
            for _ in range(_CALLS):
                kernel(*args)
            best = min(best, (time.process_time() - c0) / (_CALLS * _B) * 1e9)
        out[name] = best
    return out


#: numba's disk cache of this comparison, fresh (set in `main`): a cache left by an
#: earlier build of a checkout can hold kernels compiled before a change to a module
#: other than the driver file (numba checks only that file's time stamp).
_CACHE_DIR = ""


def _python(tree: Path) -> tuple[str, dict]:
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=_CACHE_DIR)
    venv = tree / ".venv" / "bin" / "python"
    return (str(venv) if venv.exists() else sys.executable), env


def _run(tree: Path, args: list[str]) -> str:
    exe, env = _python(tree)
    done = subprocess.run([exe, *args], cwd=tree, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {' '.join(args)} failed:\n{done.stderr[-2000:]}")
    return done.stdout


_NUM = r"(-?\d+(?:\.\d+)?)"


def _estimator_rows(text: str) -> dict[str, float]:
    """CPU us per filter-step of each (filter, path, batch) row of estimators.py."""
    rows = {}
    for line in text.splitlines():
        hit = re.match(rf"^(ukf|ckf|svd-ckf)\s+(\S+)\s+(\d+)\s+{_NUM}\s+.*?\s{_NUM}\s+\S+\s*$", line)
        if hit:
            rows[f"{hit[1]} {hit[2]} batch {hit[3]} (CPU us)"] = float(hit[5])
    return rows


def _vector_rows(text: str) -> dict[str, float]:
    """x real time (from CPU time) of each (channel filter, runs) row of vector_loop.py."""
    rows = {}
    for line in text.splitlines():
        hit = re.match(rf"^(.+?)\s+(\d+)\s+{_NUM}\s+{_NUM}\s+{_NUM}\s*$", line)
        if hit:
            rows[f"{hit[1].strip()}, {hit[2]} runs (x real time, CPU)"] = float(hit[5])
    return rows


def _measure(tree: Path, what: str) -> dict[str, float]:
    if what == "kernels":
        return json.loads(_run(tree, [__file__, "--worker"]).splitlines()[-1])
    if what == "estimators":
        return _estimator_rows(_run(tree, [str(_HERE / "estimators.py"), "--no-numpy", "--no-peers"]))
    return _vector_rows(_run(tree, [str(_HERE / "vector_loop.py")]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path, nargs="?")
    parser.add_argument("after", type=Path, nargs="?")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--only",
        choices=("kernels", "estimators", "vector-loop"),
        nargs="+",
        default=["kernels", "estimators", "vector-loop"],
    )
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:  # inside a checkout's process: time its kernels, print one JSON line
        print(json.dumps(_time_kernels()))
        return
    if args.before is None or args.after is None:
        parser.error("BEFORE and AFTER checkouts are required")
    trees = (args.before.resolve(), args.after.resolve())
    for tree in trees:
        if not (tree / "gnssframework" / "__init__.py").exists():
            parser.error(f"{tree} is not a gnssframework checkout")
    global _CACHE_DIR
    _CACHE_DIR = tempfile.mkdtemp(prefix="compare-commits-numba-")
    print(
        f"BEFORE {trees[0]}\nAFTER  {trees[1]}\nload average {os.getloadavg()[0]:.1f} at start, "
        f"{os.cpu_count()} cores; numba cache {_CACHE_DIR}",
        flush=True,
    )
    for tree in trees:  # compile every kernel once, untimed
        _measure(tree, "kernels")
    for what in args.only:
        results: tuple[dict, dict] = ({}, {})
        for r in range(args.repeats):
            for side, tree in enumerate(trees):
                for key, value in _measure(tree, what).items():
                    results[side].setdefault(key, []).append(value)
            print(
                f"  {what}: repeat {r + 1} of {args.repeats} done, load {os.getloadavg()[0]:.1f}",
                file=sys.stderr,
                flush=True,
            )
        rate = what == "vector-loop"  # a rate (higher is faster); the others are times
        unit = ("BEFORE / AFTER" if rate else "AFTER / BEFORE") + " (above 1: AFTER slower)"
        print(f"\n{what}: medians of {args.repeats} alternated repeats; ratio {unit}")
        print(f"{'':48s} {'BEFORE':>10s} {'AFTER':>10s} {'ratio':>7s}")
        for key in results[0]:
            if key not in results[1]:
                continue
            a, b = statistics.median(results[0][key]), statistics.median(results[1][key])
            ratio = a / b if rate else b / a
            print(f"{key:48s} {a:10.2f} {b:10.2f} {ratio:7.3f}", flush=True)
    print(f"\nload average {os.getloadavg()[0]:.1f} at the end")
    shutil.rmtree(_CACHE_DIR, ignore_errors=True)


if __name__ == "__main__":
    main()
