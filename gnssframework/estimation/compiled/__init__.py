"""Compiled (numba) kernels behind the Gaussian filter engines.

The NumPy code in `gnssframework.estimation.estimator` is the reference implementation; these kernels do
the same arithmetic in one pass per batch element, without the temporaries and the
Python wrappers of NumPy's batched calls on tiny matrices. They cover

* the square root of P (lower Cholesky, or for ``svd-ckf`` the symmetric
  eigen-decomposition: Householder tridiagonalisation + implicit QR with Wilkinson
  shifts, as LAPACK does it, see `_eigh_into`) and the sigma/cubature points built from it;
* the weighted moments of transformed points (predicted mean and covariance + Q, or
  predicted measurement, innovation covariance + R and cross covariance);
* the measurement update: Cholesky of S, gain ``K = C S^{-1}``, posterior mean and
  covariance (``P - K S K^T`` or Joseph's form), with the skip/failure mask;
* a positive-definiteness test without the factor (`pd_mask`), which the filter step's
  posterior check and the noise adapters' bound tests use every step.

A model's NumPy ``f`` and ``h`` are evaluated between these kernels. A model that also
carries compiled twins (`gnssframework.estimation.CompiledFunctions`: jitted functions
defined next to the model, e.g. linear ``F x`` and ``H x`` here, the correlator channel
model in `gnssframework.signal.channel_model`, a plugin's own) runs a whole sigma-point
predict or update in one compiled pass per element (``fused_predict``,
``fused_update``), and the KF/EKF predict and measurement moments in compiled code
(``linear_predict``, ``ekf_moments``). The drivers of those passes are built per model
function (`_model_pair`): the function is a compile-time constant, so numba inlines it,
and this module knows no model. Results equal the NumPy path to rounding (a Hypothesis
test holds them to 1e-12 relative on random models).

Every input array reaches a kernel writable (read-only ones are copied), so each kernel
has one numba specialisation: the one `warm_up` compiles (a test checks that runs add none).

Backend choice: `gnssframework.backend` (``GNSSFRAMEWORK_BACKEND``, ``set_backend``; an
estimator's ``backend`` attribute overrides it for that instance).

Every kernel is compiled twice: a serial version for small batches (no thread launch)
and a ``parallel=True`` version whose ``prange`` splits the batch across cores from
`PARALLEL_MIN_BATCH` elements on. Both are cached on disk (``cache=True``), so
only the first import on a machine pays the compile time. The fused predict and update
(the hot path of a batched channel filter) split a large batch differently by default
(`split.SPLIT`): the calling thread and one helper thread take chunks of it as each
becomes free (`gnssframework.estimation.compiled.pool`), because numba's workers, asleep
between the calls of a filter loop, wake too late for the static split to gain
(docs/benchmarks.md, "Why the compiled path is built as it is"). A model that declares
its sizes (``CompiledFunctions.sizes``, the channel filter's 5 states and 6
measurements) gets fused drivers with those sizes as constants, bitwise the generic ones.

The package, from the bottom up: `specialise` (serial/parallel and size-specialised
twins), `dense` (per-element linear algebra), `drivers` (the Gaussian rules written
once as per-element steps, and the plain, fused and size-specialised batch drivers that
compose them), `pool` and `split` (how a batch is split
across threads), `arrays` (the array-level calls the engines make), `warm` (compile
before a run), `loop` (the filter step's compiled checks and the adapters' guard).
"""

from __future__ import annotations

from . import loop
from .arrays import (
    ekf_moments,
    fused_predict,
    fused_update,
    linear_predict,
    measurement_moments,
    pd_mask,
    predict_moments,
    sigma_points,
    update,
    vector_operand,
)
from .split import PARALLEL_MIN_BATCH, PD_MASK_PARALLEL_MIN_BATCH
from .warm import warm_up as warm_up_kernels

__all__ = [
    "PARALLEL_MIN_BATCH",
    "PD_MASK_PARALLEL_MIN_BATCH",
    "sigma_points",
    "predict_moments",
    "measurement_moments",
    "update",
    "pd_mask",
    "linear_predict",
    "ekf_moments",
    "fused_predict",
    "fused_update",
    "vector_operand",
    "warm_up",
    "warm_up_kernels",
]


def warm_up() -> float:
    """Compile (or load from the disk cache) every kernel of the package: the Gaussian
    rules (`warm_up_kernels`) and the loop checks (`loop.warm_up`); seconds taken."""
    import time

    t0 = time.perf_counter()
    warm_up_kernels()
    loop.warm_up()
    return time.perf_counter() - t0
