r"""Where a secondary (overlay) code stands in a run of prompts.

A pilot's prompts over consecutive primary periods carry one overlay chip each,
:math:`P_k = A\,o_{(k+s) \bmod N}\,e^{j(\phi + 2\pi\,\delta f\,k T)}`. The products of
neighbours, :math:`D_k = P_{k+1} P_k^*`, lose the unknown phase; correlating them with the
overlay's neighbour products at every shift,

.. math:: Z(s) = \sum_k D_k\, o_{(k+s+1) \bmod N}\, o_{(k+s) \bmod N},

peaks in magnitude at the true shift :math:`s`, and the peak's angle over :math:`2\pi T` is
the residual frequency :math:`\delta f` (a differential detector). The overlay's
sign flips would read as frequency to an FLL that does not wipe them: synchronise first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["OverlaySync", "overlay_sync"]


@dataclass(frozen=True)
class OverlaySync:
    """The overlay chip on the first prompt (``shift``), the residual frequency (Hz) and the
    peak's magnitude over the runner-up's (``margin``; near 1 when nothing stands out)."""

    shift: int
    freq_error_hz: float
    margin: float


def overlay_sync(prompts: np.ndarray, overlay: tuple[int, ...] | np.ndarray, period_s: float) -> OverlaySync:
    """Synchronise ``prompts`` (complex, one per primary period ``period_s``) to ``overlay``
    (±1 chips, one per primary period): the differential correlation in the module text."""
    p = np.asarray(prompts, complex).ravel()
    o = np.asarray(overlay, float)
    if p.size < 3 or o.size < 2:
        raise ConfigError(
            "prompts", f"overlay sync needs at least 3 prompts and a 2-chip overlay, got {p.size} and {o.size}"
        )
    diff = p[1:] * np.conj(p[:-1])
    k = np.arange(diff.size)
    shifts = np.arange(o.size)[:, None]
    pairs = o[(k + shifts + 1) % o.size] * o[(k + shifts) % o.size]  # (N, K-1)
    z = pairs @ diff
    mags = np.abs(z)
    best = int(np.argmax(mags))
    runner_up = np.sort(mags)[-2]
    return OverlaySync(
        best,
        float(np.angle(z[best]) / (2 * np.pi * period_s)),
        float(mags[best] / runner_up) if runner_up > 0 else float("inf"),
    )
