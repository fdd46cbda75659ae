"""Learned noise by EM against the online adapters on the same data (docs/estimators/em.md).

A constant-velocity target, x = (position m, velocity m/s), dt = 1 s, its position seen
in white noise: x_k = F x_{k-1} + w_k, w_k ~ N(0, q G), G = [[dt^3/3, dt^2/2], [dt^2/2,
dt]] (white acceleration of density q, Bar-Shalom et al. 2001, sec. 6.2.2), z_k = x_k[0] + v_k,
v_k ~ N(0, r), r = 1 m^2. Two regimes of Q: q = 0.1 m^2/s^3 (well observed: the
acceleration moves the position by more than the noise within a few steps) and q = 1e-4
(weakly observed: the innovations are almost all measurement noise). Records of 100 and 400
steps, ``runs`` independent runs each. Then a regime no constant R fits: r steps to 4 r at
mid-record (400 steps, Q known), every estimator scored against the final 4 r (the fresh
record is at 4 r).

Every estimator sees the same measurements and starts from the same wrong Q0 = q/4 G,
R0 = 4 r (common random numbers; the two regimes share the normal draws too). With Q known
(R only): EM (`learn_noise`, Q fixed), the ``innovation`` adapter (window 20) and
``sage-husa`` R only (improved, the default, and classic); with Q and R unknown: EM (Q's
scale, R) and ``sage-husa`` (improved and classic). The adapters' learned Q and R are
their final ones in force; EM runs to ``TOL`` or ``ITERATIONS`` iterations (the table
gives the M-steps taken and the runs converged). Each learned
pair then filters a fresh record of the same run (300 steps, the same for every
estimator), and its position RMSE after step 50 is divided by that of the filter with
the true Q and R ("RMSE / true").

Per row: the median of q_hat / q and r_hat / r (q_hat = tr(G^-1 Q_hat) / 2, the scale of a
learned Q in the true Q's shape), the RMS over runs of log(q_hat / q) and log(r_hat / r),
the mean RMSE / true, and the paired differences EM minus the row's estimator (per run,
on the same data) of |log(r_hat / r)|, |log(q_hat / q)| and RMSE / true, mean +- standard
error over the runs; negative: EM is closer.

``python docs/em_vs_adapters.py`` prints the page's table (about 40 CPU-seconds);
tests/estimation/test_em_vs_adapters.py checks the page shows it and the orderings it states.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

import gnssframework as gf
from gnssframework.estimation import Gaussian, LinearModel, learn_noise

DT_S = 1.0
F = np.array([[1.0, DT_S], [0.0, 1.0]])
H = np.array([[1.0, 0.0]])
G = np.array([[DT_S**3 / 3, DT_S**2 / 2], [DT_S**2 / 2, DT_S]])
R_TRUE_M2 = 1.0
INITIAL = Gaussian(np.zeros(2), np.diag([10.0, 1.0]))
RUNS = 80
SEED = 43
START = (0.25, 4.0)  # Q0 = 0.25 q G, R0 = 4 r
ITERATIONS, TOL = 100, 1e-7
FRESH_STEPS, FRESH_SKIP = 300, 50


def simulate(
    rng: np.random.Generator,
    q: float,
    K: int,
    runs: int,
    r_step: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """``(K, runs, 2)`` states and ``(K, runs, 1)`` measurements from x_{-1} ~ INITIAL; the
    measurement noise variance is r, times ``r_step`` from step K // 2 on."""
    x = INITIAL.mean + rng.standard_normal((runs, 2)) @ np.linalg.cholesky(INITIAL.cov).T
    w = rng.standard_normal((K, runs, 2)) @ np.linalg.cholesky(q * G).T
    r = np.where(np.arange(K) < K // 2, R_TRUE_M2, r_step * R_TRUE_M2)
    v = rng.standard_normal((K, runs, 1)) * np.sqrt(r)[:, None, None]
    xs = np.empty((K, runs, 2))
    for k in range(K):
        x = x @ F.T + w[k]
        xs[k] = x
    return xs, xs[..., :1] + v


def q_scale(Q: np.ndarray) -> np.ndarray:
    """tr(G^-1 Q) / 2: a learned Q's scale in the true Q's shape (EM's "scaled" M-step)."""
    out: np.ndarray = np.trace(np.linalg.solve(G, Q), axis1=-2, axis2=-1) / 2.0
    return out


class Regime(NamedTuple):
    """A row group: ``q`` (m^2/s^3), record length, R's step at mid-record, what is learned."""

    name: str
    q: float
    steps: int
    r_step: float = 1.0
    unknowns: tuple[str, ...] = ("R only", "Q and R")


#: The stationary regimes (well and weakly observed Q, short and long records), then R
#: stepping to 4 r at mid-record, scored against the final 4 r (where a window tracks).
REGIMES = (
    Regime("well-observed Q", 0.1, 100),
    Regime("well-observed Q", 0.1, 400),
    Regime("weakly observed Q", 1e-4, 100),
    Regime("weakly observed Q", 1e-4, 400),
    Regime("R to 4 r at mid-record", 0.1, 400, r_step=4.0, unknowns=("R only",)),
)


@dataclass
class Learned:
    """One estimator's per-run learned q (m^2/s^3), r (m^2) and RMSE / true on the fresh record."""

    q: np.ndarray
    r: np.ndarray
    rmse_ratio: np.ndarray


@dataclass
class Block:
    """Every estimator of one regime and set of unknowns; ``q_true``, ``r_true`` score them
    (``r_true``: R at the record's end); EM's iterations and its runs converged to ``TOL``."""

    regime: Regime
    unknowns: str
    q_true: float
    r_true: float
    estimators: dict[str, Learned]
    em_iterations: int
    em_converged: int

    def log_errors(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Per-run |log(q_hat / q)| and |log(r_hat / r)| of estimator ``name``."""
        est = self.estimators[name]
        return np.abs(np.log(est.q / self.q_true)), np.abs(np.log(est.r / self.r_true))


def _fresh_rmse(Q: np.ndarray, R: np.ndarray, xs: np.ndarray, zs: np.ndarray) -> np.ndarray:
    """Position RMSE per run (m) after FRESH_SKIP of the filter with per-run ``Q``, ``R``."""
    kf = gf.registry.create("estimator", "kf")
    result = gf.filter_sequence(kf, LinearModel(F, H, Q, R), zs, INITIAL)
    err = result.mean[FRESH_SKIP:, :, 0] - xs[FRESH_SKIP:, :, 0]
    out: np.ndarray = np.sqrt(np.mean(err**2, axis=0))
    return out


def _em_convergence(history: np.ndarray) -> tuple[int, int]:
    """EM's M-steps taken and the runs whose last one moved the log-likelihood by at most TOL."""
    if history.shape[0] < 2:
        return 0, 0
    moved = np.abs(history[-1] - history[-2])
    return history.shape[0] - 1, int(np.sum(moved <= TOL * (1.0 + np.abs(history[-1]))))


def compare(regime: Regime, runs: int = RUNS, seed: int = SEED) -> list[Block]:
    """Every estimator on the same ``runs`` records of the regime, a `Block` per set of unknowns."""
    q = regime.q
    rng = np.random.default_rng(seed)
    xs, zs = simulate(rng, q, regime.steps, runs, regime.r_step)
    r_end = regime.r_step * R_TRUE_M2
    fresh_xs, fresh_zs = simulate(rng, q, FRESH_STEPS, runs)
    fresh_zs = fresh_xs[..., :1] + (fresh_zs - fresh_xs[..., :1]) * np.sqrt(regime.r_step)  # at r_end
    kf = gf.registry.create("estimator", "kf")
    start = LinearModel(F, H, START[0] * q * G, np.array([[START[1] * R_TRUE_M2]]))
    known_q = start.with_noise(Q=q * G)
    true_rmse = _fresh_rmse(np.broadcast_to(q * G, (runs, 2, 2)), np.full((runs, 1, 1), r_end), fresh_xs, fresh_zs)

    def learned(Q: np.ndarray, R: np.ndarray) -> Learned:
        Q = np.broadcast_to(Q, (runs, 2, 2))
        R = np.broadcast_to(R, (runs, 1, 1))
        return Learned(q_scale(Q), R[:, 0, 0].copy(), _fresh_rmse(Q, R, fresh_xs, fresh_zs) / true_rmse)

    def adapter(model: LinearModel, name: str, **params: object) -> Learned:
        ad = gf.registry.create("noise_adapter", name, **params)
        result = gf.filter_sequence(kf, model, zs, INITIAL, adapter=ad)
        return learned(result.Q[-1], result.R[-1])

    blocks = []
    if "R only" in regime.unknowns:
        Q, R, history = learn_noise(
            known_q, zs, INITIAL, estimator=kf, iterations=ITERATIONS, tol=TOL, q_structure="fixed"
        )
        estimators = {
            "EM": learned(Q, R),
            "innovation": adapter(known_q, "innovation"),
            "sage-husa": adapter(known_q, "sage-husa", estimate_q=False),
            "sage-husa classic": adapter(known_q, "sage-husa", estimate_q=False, variant="classic"),
        }
        blocks.append(Block(regime, "R only", q, r_end, estimators, *_em_convergence(history)))
    if "Q and R" in regime.unknowns:
        Q, R, history = learn_noise(
            start, zs, INITIAL, estimator=kf, iterations=ITERATIONS, tol=TOL, q_structure="scaled"
        )
        estimators = {
            "EM": learned(Q, R),
            "sage-husa": adapter(start, "sage-husa"),
            "sage-husa classic": adapter(start, "sage-husa", variant="classic"),
        }
        blocks.append(Block(regime, "Q and R", q, r_end, estimators, *_em_convergence(history)))
    return blocks


def paired(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Mean and standard error over runs of the per-run difference ``a - b``."""
    d = a - b
    return float(d.mean()), float(d.std(ddof=1) / np.sqrt(d.size))


def _pm(mean_se: tuple[float, float], digits: int) -> str:
    return f"{mean_se[0]:+.{digits}f} ± {mean_se[1]:.{digits}f}".replace("-", "−")


def rows(blocks: list[Block]) -> list[str]:
    """The page's table rows, a row per estimator of every block."""
    lines = []
    for b in blocks:
        em_q, em_r = b.log_errors("EM")
        both = b.unknowns == "Q and R"
        for name, est in b.estimators.items():
            lq, lr = b.log_errors(name)
            label = f"EM ({b.em_iterations} it., {b.em_converged}/{lr.size} conv.)" if name == "EM" else f"`{name}`"
            cells = [
                b.regime.name,
                str(b.regime.steps),
                b.unknowns,
                label,
                f"{np.median(est.q / b.q_true):.3g}" if both else "",
                f"{np.median(est.r / b.r_true):.3g}",
                f"{np.sqrt(np.mean(lq**2)):.2f}" if both else "",
                f"{np.sqrt(np.mean(lr**2)):.2f}",
                f"{np.mean(est.rmse_ratio):.3f}",
            ]
            if name == "EM":
                cells += ["", "", ""]
            else:
                cells += [
                    _pm(paired(em_r, lr), 2),
                    _pm(paired(em_q, lq), 2) if both else "",
                    _pm(paired(b.estimators["EM"].rmse_ratio, est.rmse_ratio), 3),
                ]
            lines.append("| " + " | ".join(cells) + " |")
    return lines


HEADER = (
    "| regime | steps | unknown | estimator | median q̂/q | median r̂/r | RMS log q̂/q | RMS log r̂/r "
    "| RMSE / true | EM − it: abs log r | EM − it: abs log q | EM − it: RMSE / true |\n"
    "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
)


def all_blocks(runs: int = RUNS, seed: int = SEED) -> list[Block]:
    """`compare` on every regime of REGIMES."""
    return [block for regime in REGIMES for block in compare(regime, runs, seed)]


def table(blocks: list[Block] | None = None) -> str:
    """The page's table (every regime unless ``blocks`` given)."""
    return "\n".join([HEADER, *rows(all_blocks() if blocks is None else blocks)])


def main() -> None:
    import argparse

    global ITERATIONS
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--runs", type=int, default=RUNS)
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--iterations", type=int, default=ITERATIONS, help="EM's cap (the page's table: 100)")
    args = ap.parse_args()
    ITERATIONS = args.iterations
    print(table(all_blocks(args.runs, args.seed)))


if __name__ == "__main__":
    main()
