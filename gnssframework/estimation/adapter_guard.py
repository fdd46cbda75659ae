"""Run a noise adapter's step so that an overflow is reported by name, never as a raw
NumPy warning or ``LinAlgError``.

A noise adapter forms outer products of innovations and state corrections (Sage-Husa,
innovation-based, ML-Q adapters): an innovation of magnitude above about 1e154 (a
measurement of 1e300, a corrupted sample) squares to ``inf``, and the adapter's PSD
projection (``eigh``) then fails with "Eigenvalues did not converge". `FilterStep` calls
`adapt_checked` instead of the adapter's ``step``: the arithmetic runs with NumPy's
floating-point warnings off, and a Q or R estimate that is not finite, or a failing
decomposition, raises :class:`~gnssframework.errors.NonFiniteError` naming the filter,
the adapter, the batch elements and the step. No recovery policy applies: the adapter
cannot tell a usable estimate from one built on an overflow, so the step is refused.
"""

from __future__ import annotations

import numpy as np

from ..errors import NonFiniteError
from .compiled import loop as compiled_loop
from .adaptation import AdapterRun, AdaptationStep
from .linalg import failing_indices

__all__ = ["adapt_checked"]


def _finite_per_element(a: np.ndarray | None, batch_shape: tuple[int, ...]) -> np.ndarray:
    if a is None:
        return np.ones(batch_shape, bool)
    return np.broadcast_to(np.isfinite(np.asarray(a, float)).all(axis=(-2, -1)), batch_shape)


def adapt_checked(
    run: AdapterRun, ctx: AdaptationStep, filter_name: str, adapter_name: str, step: int
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``run.step(ctx)``, refused by name where the adapter's arithmetic overflows.

    Raises
    ------
    NonFiniteError
        Where the returned Q or R is not finite, or the adapter's decomposition failed
        (then naming the elements whose innovation outer product overflows, or every
        element when none does).
    """
    batch_shape = ctx.update.state.batch_shape
    failed = None
    Q: np.ndarray | None
    R: np.ndarray | None
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        try:
            Q, R = run.step(ctx)
        except np.linalg.LinAlgError as exc:
            Q = R = None
            failed = str(exc)
        if failed is None and (Q is None or compiled_loop.all_finite(Q)) and (R is None or compiled_loop.all_finite(R)):
            return Q, R  # the common step: no per-element masks
        ok = _finite_per_element(Q, batch_shape) & _finite_per_element(R, batch_shape)
        if failed is None and ok.all():
            return Q, R
        nu = np.asarray(ctx.update.innovation, float)
        size = float(np.max(np.abs(nu[np.isfinite(nu)]), initial=0.0))
        if failed is not None:  # which elements: those whose innovation squared overflows
            ok = np.broadcast_to(np.isfinite(nu * nu).all(axis=-1) | np.asarray(ctx.update.skipped), batch_shape)
            if ok.all():
                ok = np.zeros(batch_shape, bool)
    what = f"its decomposition failed ({failed})" if failed else "its Q or R estimate is not finite"
    raise NonFiniteError(
        filter_name,
        failing_indices(ok),
        step,
        detail=f"noise adapter {adapter_name!r}: {what}, from innovations of magnitude up to "
        f"{size:.3g} (an overflow: a measurement far outside the model)",
    )
