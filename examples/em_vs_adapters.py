"""Learned noise by EM (`learn_noise`) against the online adapters on the same data.

A random walk seen in white noise, x_k = x_{k-1} + w_k (q = 0.09), z_k = x_k + v_k (r = 1),
many independent runs. From the same wrong start (default Q0 = q/4, R0 = 4 r) on the same
measurements: EM (per run, to convergence or 80 iterations) and the final Q, R in force of
the ``innovation`` adapter (R only, window 20) and ``sage-husa`` (improved; R only, then Q
and R), each with its default safeguards. Printed per regime and estimator: the median
estimate over the runs, the RMS of log(estimate / truth), and the paired difference of
|log error| (EM minus the adapter: negative, EM is closer) as mean +- standard error over
the runs.

    python examples/em_vs_adapters.py [--runs 40] [--steps 100 1000] [--start 0.25 4]
"""

from __future__ import annotations

import argparse

import numpy as np

import gnssframework as gf
from gnssframework.estimation import Gaussian, LinearModel, learn_noise

Q_TRUE, R_TRUE = 0.09, 1.0


def simulate(rng, K: int, B: int) -> np.ndarray:
    x = np.cumsum(rng.normal(0.0, np.sqrt(Q_TRUE), (K, B, 1)), axis=0)
    return x + rng.normal(0.0, np.sqrt(R_TRUE), x.shape)


def final_adapter(adapter, model, zs, initial):
    result = gf.filter_sequence(gf.registry.create("estimator", "kf"), model, zs, initial, adapter=adapter)
    return result.Q[-1, :, 0, 0], result.R[-1, :, 0, 0]


def row(label, est, truth, em_est=None):
    err = np.log(est / truth)
    text = f"| {label} | {np.median(est):.3g} | {np.sqrt(np.mean(err ** 2)):.2f} |"
    if em_est is None:
        return text + " |"
    d = np.abs(np.log(em_est / truth)) - np.abs(err)
    return text + f" {d.mean():+.2f} ± {d.std(ddof=1) / np.sqrt(d.size):.2f} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40)
    ap.add_argument("--steps", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--start", type=float, nargs=2, default=[0.25, 4.0], metavar=("QX", "RX"),
                    help="start Q0 = QX q, R0 = RX r (default: q/4, 4r)")
    args = ap.parse_args()
    kf = gf.registry.create("estimator", "kf")
    initial = Gaussian(np.zeros(1), np.eye(1))
    qx, rx = args.start
    start = LinearModel(np.eye(1), np.eye(1), [[qx * Q_TRUE]], [[rx * R_TRUE]])
    known_q = start.with_noise(Q=[[Q_TRUE]])
    innovation = gf.registry.create("noise_adapter", "innovation")
    sh_r = gf.registry.create("noise_adapter", "sage-husa", estimate_q=False)
    sh_qr = gf.registry.create("noise_adapter", "sage-husa")
    for K in args.steps:
        zs = simulate(np.random.default_rng(K), K, args.runs)
        print(f"\n{K} steps, {args.runs} runs; truth q = {Q_TRUE}, r = {R_TRUE}; start {qx:g} q, {rx:g} r")
        print("| regime | estimator | median | RMS log error | EM − it, paired |")
        print("| --- | --- | --- | --- | --- |")
        # R unknown, Q known
        _, r_em, _ = learn_noise(known_q, zs, initial, estimator=kf, iterations=80, tol=1e-8, q_structure="fixed")
        r_em = r_em[:, 0, 0]
        print(row("R (Q known) | EM", r_em, R_TRUE))
        for name, ad in (("innovation", innovation), ("sage-husa", sh_r)):
            print(row(f"R (Q known) | {name}", final_adapter(ad, known_q, zs, initial)[1], R_TRUE, r_em))
        # Q and R unknown
        q_em, r_em2, _ = learn_noise(start, zs, initial, estimator=kf, iterations=80, tol=1e-8)
        q_em, r_em2 = q_em[:, 0, 0], r_em2[:, 0, 0]
        q_sh, r_sh = final_adapter(sh_qr, start, zs, initial)
        print(row("Q and R: q | EM", q_em, Q_TRUE))
        print(row("Q and R: q | sage-husa", q_sh, Q_TRUE, q_em))
        print(row("Q and R: r | EM", r_em2, R_TRUE))
        print(row("Q and R: r | sage-husa", r_sh, R_TRUE, r_em2))


if __name__ == "__main__":
    main()
