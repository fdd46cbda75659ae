"""Correlator outputs of a batch of channels."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError

__all__ = ["Correlators"]


@dataclass(frozen=True)
class Correlators:
    """Complex early / prompt / late correlator outputs ``I + jQ``, batch-first.

    Parameters
    ----------
    early, prompt, late
        Complex arrays of one shape ``(...)`` (channels, runs, ...).
    extra
        Optional further taps by name (``"very_early"``, ``"very_late"``).
    """

    early: np.ndarray
    prompt: np.ndarray
    late: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        taps = [np.asarray(self.early), np.asarray(self.prompt), np.asarray(self.late)]
        try:
            shape = np.broadcast_shapes(*(t.shape for t in taps))
        except ValueError:
            raise ConfigError(
                "Correlators", f"early/prompt/late shapes do not match: {[t.shape for t in taps]}"
            ) from None
        for name, tap in zip(("early", "prompt", "late"), taps):
            object.__setattr__(self, name, np.broadcast_to(tap.astype(complex, copy=False), shape))

    @classmethod
    def trusted(cls, early: np.ndarray, prompt: np.ndarray, late: np.ndarray) -> Correlators:
        """Taps already of one shape and complex dtype (the library's own simulators and
        wipe-off): built without the checks of the constructor, which a harness would
        otherwise pay every interval. No extra taps."""
        obj = object.__new__(cls)
        object.__setattr__(obj, "early", early)
        object.__setattr__(obj, "prompt", prompt)
        object.__setattr__(obj, "late", late)
        object.__setattr__(obj, "extra", {})
        return obj

    @property
    def shape(self) -> tuple[int, ...]:
        return self.prompt.shape

    def as_iq(self) -> np.ndarray:
        """The six real outputs ``[I_E, I_P, I_L, Q_E, Q_P, Q_L]`` on the last axis."""
        taps = np.stack([self.early, self.prompt, self.late], axis=-1)
        return np.concatenate([taps.real, taps.imag], axis=-1)

    @classmethod
    def from_iq(cls, iq: np.ndarray) -> Correlators:
        """Inverse of ``as_iq``."""
        iq = np.asarray(iq, dtype=float)
        c = iq[..., :3] + 1j * iq[..., 3:6]
        return cls(c[..., 0], c[..., 1], c[..., 2])
