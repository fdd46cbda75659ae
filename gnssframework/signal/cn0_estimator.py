r"""The ``cn0_estimator`` plugin kind: prompt correlators over K coherent intervals -> C/N0.

Contract (batch-first)
----------------------
An estimator reads the complex prompt correlators of a window of ``K`` coherent intervals
of ``T`` seconds on the **last** axis, shape ``(..., K)``, and returns one C/N0 per
leading index, shape ``(...)``:

- `CN0Estimator.estimate_hz` gives the linear estimate :math:`\hat c` in Hz, which may be
  zero or negative for an estimator that is unbiased in linear terms (on pure noise it
  then reads below zero about half the time);
- `CN0Estimator.estimate_dbhz` (and calling the estimator) gives
  :math:`10 \log_{10} \hat c` in dB-Hz, with :math:`\hat c T` clipped at
  :math:`10^{-12}` as `gnssframework.signal.cn0` clips (a reading of no signal).

An estimator that measures the noise on its own correlator declares ``needs = ("prompt",
"noise")`` and takes ``noise`` of the prompt's shape: a correlator against a replica that
holds no signal (an unused PRN, or a tap far off the correlation peak), whose noise has the
prompt's variance and is independent of it (Groves 2013, 2nd ed., ch. 9: measuring the noise
power on a correlator that holds no signal).

Normalisation is the correlator model's (`gnssframework.signal.correlator_model`): unit
variance in I and in Q, amplitude :math:`A = \sqrt{2 c T}`, so :math:`c T = A^2 / 2` and
:math:`E|P|^2 = A^2 + 2`. Data bits must be wiped off for estimators that sum prompts
coherently across intervals (the narrow-wide power ratio); the others read magnitudes
only and are insensitive to bits.

The built-in estimators (``gnssframework plugins``) are in ``gnssframework_plugins``;
docs/receiver/cn0-estimators.md tables their bias, spread and noise-only floor.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np

from ..errors import ConfigError
from ..plugin import Plugin, PluginParams
from .cn0 import MIN_CN0_T
from .correlator_model import simulate_correlators

__all__ = [
    "CN0Estimator",
    "CN0EstimatorParams",
    "linear_to_dbhz",
    "MIN_CN0_T",
    "noise_readings_hz",
    "noise_floor_dbhz",
    "FLOOR_PERCENTILE",
]

#: The percentile of an estimator's readings on pure noise that is its floor.
FLOOR_PERCENTILE = 95.0
#: Offset (chips) of the noise-only tap the floor's draws give estimators that need one:
#: far off the correlation peak, so it holds no signal and its noise is independent of the
#: prompt's in the correlator model.
NOISE_TAP_CHIPS = -10.0


def linear_to_dbhz(cn0_hz: np.ndarray, coherent_time_s: float) -> np.ndarray:
    r""":math:`10 \log_{10} \hat c` with :math:`\hat c T` clipped at `MIN_CN0_T`."""
    ct = np.clip(np.asarray(cn0_hz, dtype=float) * coherent_time_s, MIN_CN0_T, None)
    return 10.0 * np.log10(ct / coherent_time_s)


class CN0EstimatorParams(PluginParams):
    """Parameters of an estimator without any."""

    no_parameters: ClassVar[str] = "the window (K intervals of T s) is its input"


class CN0Estimator(Plugin, abc.ABC):
    """Plugin kind ``cn0_estimator``: prompts ``(..., K)`` of coherent time T -> C/N0.

    Attributes
    ----------
    needs
        The correlators read: ``("prompt",)`` or ``("prompt", "noise")``.
    min_intervals
        The fewest intervals K a window must hold (an instance may ask more, e.g. the
        narrow-wide ratio's block length).
    bit_blind
        True when data bits (sign flips of whole intervals) leave its reading unchanged;
        False for one that sums prompts coherently across intervals (bits must be wiped).
    """

    kind = "cn0_estimator"
    Params = CN0EstimatorParams
    params: CN0EstimatorParams  # self.params, as validated
    needs: ClassVar[tuple[str, ...]] = ("prompt",)
    min_intervals: ClassVar[int] = 2
    bit_blind: ClassVar[bool] = True

    def required_intervals(self) -> int:
        """The fewest intervals K this instance accepts."""
        return self.min_intervals

    @abc.abstractmethod
    def _estimate_hz(self, prompt: np.ndarray, coherent_time_s: float, noise: np.ndarray | None) -> np.ndarray:
        """The linear estimate (Hz) of checked input."""

    def estimate_hz(self, prompt: np.ndarray, coherent_time_s: float, noise: np.ndarray | None = None) -> np.ndarray:
        """Linear C/N0 estimate (Hz), shape ``prompt.shape[:-1]``.

        Raises
        ------
        ConfigError
            For a window shorter than `required_intervals`, a coherent time that is not
            positive, or a missing or misshapen ``noise`` where the estimator needs one.
        """
        p = np.asarray(prompt)
        if p.ndim < 1 or p.shape[-1] < self.required_intervals():
            raise ConfigError(
                "prompt",
                f"{self.name} needs at least {self.required_intervals()} intervals on the "
                f"last axis, got shape {p.shape}",
            )
        if not np.isfinite(coherent_time_s) or coherent_time_s <= 0:
            raise ConfigError("coherent_time_s", f"must be a positive number of seconds, got {coherent_time_s!r}")
        n = None
        if "noise" in self.needs:
            if noise is None:
                raise ConfigError(
                    "noise", f"{self.name} measures N0 on a noise-only correlator: pass `noise` (shape of the prompt)"
                )
            n = np.asarray(noise)
            if n.shape != p.shape:
                raise ConfigError("noise", f"shape {n.shape} differs from the prompt's {p.shape}")
        return self._estimate_hz(p.astype(complex, copy=False), float(coherent_time_s), n)

    def estimate_dbhz(self, prompt: np.ndarray, coherent_time_s: float, noise: np.ndarray | None = None) -> np.ndarray:
        """C/N0 estimate (dB-Hz), shape ``prompt.shape[:-1]`` (`linear_to_dbhz` of `estimate_hz`)."""
        return linear_to_dbhz(self.estimate_hz(prompt, coherent_time_s, noise), coherent_time_s)

    __call__ = estimate_dbhz


def noise_readings_hz(
    estimator: CN0Estimator, coherent_time_s: float, intervals: int, runs: int, rng: np.random.Generator
) -> np.ndarray:
    """The linear readings (Hz) of ``estimator`` on ``runs`` windows of pure noise, K =
    ``intervals`` prompts of T = ``coherent_time_s`` each, drawn by the correlator model
    (`simulate_correlators` with zero amplitude; the noise-only correlator a tap
    `NOISE_TAP_CHIPS` off the peak)."""
    shape = (int(runs), int(intervals))
    c = simulate_correlators(
        np.zeros(shape),
        0.0,
        0.0,
        0.0,
        coherent_time_s,
        rng,
        extra_taps={"noise": NOISE_TAP_CHIPS},
        amplitude=np.zeros(shape),
    )
    return estimator.estimate_hz(c.prompt, coherent_time_s, noise=c.extra["noise"])


def noise_floor_dbhz(
    estimator: CN0Estimator,
    coherent_time_s: float,
    intervals: int,
    percentile: float = FLOOR_PERCENTILE,
    runs: int = 2000,
    seed: int = 0,
) -> float:
    r"""The noise-only floor (dB-Hz) of ``estimator`` on a window of K = ``intervals``
    intervals of T = ``coherent_time_s``: the ``percentile`` of its readings on pure noise
    (`noise_readings_hz`, ``runs`` windows from ``seed``); ``-inf`` when that reading is
    zero or below.

    A threshold claim below this floor is void: noise alone reads it in more than
    ``100 - percentile`` % of windows (docs/receiver/cn0-estimators.md).

    Raises
    ------
    ConfigError
        For ``percentile`` outside (0, 100) or fewer than 100 ``runs``.
    """
    if not 0 < percentile < 100:
        raise ConfigError("percentile", f"must be in (0, 100), got {percentile!r}")
    if runs < 100:
        raise ConfigError("runs", f"at least 100 windows give a percentile, got {runs!r}")
    hz = noise_readings_hz(estimator, coherent_time_s, intervals, runs, np.random.default_rng(seed))
    value = float(np.percentile(hz, percentile))
    return 10 * np.log10(value) if value > 0 else float("-inf")
