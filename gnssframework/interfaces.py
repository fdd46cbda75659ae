"""Abstract interfaces of the GNSS plugin kinds.

The estimation kinds (``Estimator``, ``NoiseAdapter``, ``Augmentation``) live in
``gnssframework.estimation``, which knows nothing of GNSS. These three compose them
into a receiver:

- a ``Discriminator`` turns correlators into a code, frequency or phase error;
- a ``ChannelFilter`` processes one channel's correlators or observables per
  epoch (batched over channels and runs);
- a ``NavFilter`` fuses every channel and returns the navigation state and the
  NCO commands of the next epoch.

Capabilities a harness asks of a nav filter are interfaces too, so the core never picks
a plugin by its name: an ``ErrorStateNavFilter`` (INS integration) and a
``BatchPositionFilter`` (filtering a recorded position sequence).

Channel and navigation filters declare the named quantities they ``provides`` and
``requires``, so a configuration that feeds a nav filter from a channel filter whose
outputs it cannot use is refused before anything runs.
"""

from __future__ import annotations

import abc
import dataclasses
import functools
import inspect
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, TypeVar
from collections.abc import Callable, Mapping

import numpy as np
from pydantic import Field

from .errors import ConfigError, InvalidArgumentError, InvalidInputError, PluginError
from .estimation import FilterResult, Gaussian, LinearModel, filter_sequence
from .plugin import Plugin, PluginParams
from .signal.correlators import Correlators
from .signal.gps_l1ca import GPS_L1CA
from .signal.spec import SignalSpec

__all__ = [
    "Discriminator",
    "DiscriminatorParams",
    "RunContext",
    "SequentialFilter",
    "ChannelFilter",
    "NavFilter",
    "ASSUMPTION_LABELS",
    "ErrorStateNavFilter",
    "IntegrationAiding",
    "BatchPositionFilter",
]


class DiscriminatorParams(PluginParams):
    """Parameters every discriminator takes."""

    coherent_time_s: float = Field(0.001, gt=0, le=0.1, description="coherent integration time T")


class Discriminator(Plugin, abc.ABC):
    """Plugin kind ``discriminator``: correlators -> an error in physical units.

    Discriminators have unit slope in their linear region: for a small true error e,
    the output is e plus noise. ``unit`` is ``"chips"``, ``"Hz"`` or ``"rad"``.
    """

    kind = "discriminator"
    unit: ClassVar[str] = ""
    Params = DiscriminatorParams
    params: DiscriminatorParams  # self.params, as validated
    #: True for frequency discriminators, which need the previous prompt.
    needs_previous: ClassVar[bool] = False
    #: The ranging modulation whose correlation function the linear region and
    #: ``noise_variance`` assume: ``"bpsk"`` (a rectangular chip: GPS C/A, L2C, the
    #: classic code discriminators) or ``"boc11"`` (BOC(1,1), the main peak of Galileo E1 and
    #: BeiDou B1C: the BOC code discriminators). A harness that draws or simulates a
    #: discriminator on its own (docs/make_plots.py's S-curves) picks the signal from it.
    modulation: ClassVar[Literal["bpsk", "boc11"]] = "bpsk"

    @abc.abstractmethod
    def __call__(self, current: Correlators, previous: Correlators | None = None) -> np.ndarray:
        """The error estimate, shape ``current.shape``."""

    @abc.abstractmethod
    def noise_variance(self, cn0_dbhz: float | np.ndarray) -> np.ndarray:
        """Thermal-noise variance of one output (``unit``^2) at the given C/N0."""

    def extra_taps(self) -> dict[str, float]:
        """Correlator taps beyond early, prompt and late that ``__call__`` reads from
        ``Correlators.extra``, by name and offset from the prompt (chips, negative = early).

        A harness that builds the correlators (the analytic source's `CorrelatorSimulator`
        ``extra_taps``) asks the code discriminator for them. Default: none.
        """
        return {}

    def code_jump_chips(self) -> np.ndarray | float:
        """The jump of the replica's code phase commanded by the last call (chips, the
        sign of the output: positive moves the replica forward), 0 for none (default).

        A discriminator that detects a false lock (a BOC side peak: ``bump-jumping``,
        ``boc-vemlp``) commands a whole jump here instead of feeding it through the loop
        filter. A DLL that honours it (the ``scalar`` and ``kf-carrier-loop`` channel
        filters) adds ``jump / T`` to the code NCO's rate over the next interval, outside
        its loop filter, so the filter's state is untouched. A discriminator keeping state
        across calls (counters, windows) is created afresh at every loop reset.
        """
        return 0.0


def _unset(value: Any) -> bool:
    return value is None or (isinstance(value, tuple) and not value)


def _frozen_array(value: Any) -> np.ndarray | None:
    if value is None:
        return None
    arr = np.array(value, dtype=float)  # a copy: the harness's later edits cannot leak in
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class RunContext:
    """What the harness owns and tells a sequential filter when a run starts.

    The harness (closed-loop tracking, the vector loop, a scenario, the CLI) builds one
    frozen context per run and passes it to ``reset(batch_shape, context)``. A value the
    harness owns comes *only* from here: a filter must not keep its own copy of the
    coherent time or the correlator spacing, so the harness and the filter cannot
    disagree. A field the harness does not know is ``None``; a plugin that needs it calls
    `require`, which fails at ``reset`` (before the first epoch) naming the plugin and
    the field. Arrays are read-only copies.

    Attributes
    ----------
    coherent_time_s
        Coherent integration time T of one correlator interval (tracking harnesses).
    early_late_spacing_chips
        Early-to-late correlator spacing d of the simulated correlators.
    epoch_interval_s
        Interval between two epochs of observables or positions (smoothing, position
        filters) or between an INS filter's updates (``ins-ekf``); equals
        ``coherent_time_s`` in tracking harnesses.
    cn0_dbhz
        C/N0 of each channel, broadcastable to the batch shape (a receiver would use
        its C/N0 estimate).
    doppler_hz
        The acquisition's Doppler estimate per channel: the carrier NCO at the start.
    satellites
        PRNs of the channels on the last batch axis (vector loop), ``()`` if unknown.
    initial_state, initial_cov
        A navigation filter's initial estimate ``(..., n)`` and covariance ``(..., n, n)``
        (vector loop: at the middle of the first interval).
    signal
        The tracked signal's description (`SignalSpec`); ``None``: GPS L1 C/A (`spec`).

    Examples
    --------
    >>> ctx = RunContext(coherent_time_s=0.01, cn0_dbhz=45.0)
    >>> ctx.require("coherent_time_s", "channel_filter 'iq-filter'")
    0.01
    >>> ctx.require("doppler_hz", "channel_filter 'scalar'")
    Traceback (most recent call last):
    ...
    gnssframework.errors.ConfigError: run context.doppler_hz: channel_filter 'scalar' needs it, but this harness does not provide it (it provides: coherent_time_s, cn0_dbhz)
    """

    coherent_time_s: float | None = None
    early_late_spacing_chips: float | None = None
    epoch_interval_s: float | None = None
    cn0_dbhz: np.ndarray | None = None
    doppler_hz: np.ndarray | None = None
    satellites: tuple[int, ...] = ()
    initial_state: np.ndarray | None = None
    initial_cov: np.ndarray | None = None
    signal: SignalSpec | None = None

    def __post_init__(self) -> None:
        for name in ("cn0_dbhz", "doppler_hz", "initial_state", "initial_cov"):
            object.__setattr__(self, name, _frozen_array(getattr(self, name)))
        for name in ("coherent_time_s", "early_late_spacing_chips", "epoch_interval_s"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise ConfigError(f"run context.{name}", f"must be a finite number > 0, got {value!r}")
        object.__setattr__(self, "satellites", tuple(int(s) for s in self.satellites))

    def spec(self, default: SignalSpec = GPS_L1CA) -> SignalSpec:
        """The tracked signal: the harness's ``signal``, or ``default`` (GPS L1 C/A) where it set none."""
        return default if self.signal is None else self.signal

    def provided(self) -> tuple[str, ...]:
        """Names of the fields this harness set."""
        return tuple(f.name for f in dataclasses.fields(self) if not _unset(getattr(self, f.name)))

    def require(self, name: str, who: str) -> Any:
        """The value of field ``name``; a `ConfigError` naming ``who`` if the harness did not set it."""
        if name not in {f.name for f in dataclasses.fields(self)}:
            raise ConfigError(
                "run context", f"has no field {name!r}; fields: {', '.join(f.name for f in dataclasses.fields(self))}"
            )
        value = getattr(self, name)
        if _unset(value):
            raise ConfigError(
                f"run context.{name}",
                f"{who} needs it, but this harness does not provide it "
                f"(it provides: {', '.join(self.provided()) or 'nothing'})",
            )
        return value

    def resolve(self, name: str, own_value: Any, who: str) -> Any:
        """The harness's value of ``name``, checked against a plugin parameter that repeats it.

        For a plugin that also runs without a harness (``position-ca``'s ``dt_s`` in
        ``filter()``): ``own_value`` is used where the harness sets none; where both are
        set they must be equal, else a `ConfigError` names the parameter. ``None`` takes
        the harness's value (a `ConfigError` if it has none).
        """
        if own_value is None:
            return self.require(name, who)
        value = self.get(name)
        if value is None:
            return own_value
        if not np.allclose(value, own_value, rtol=1e-12, atol=0):
            raise ConfigError(
                f"{who}.{name}",
                f"is {own_value} but the harness runs with {value}; leave the "
                "parameter out (the harness's value is used)",
            )
        return value

    def get(self, name: str, default: Any = None) -> Any:
        """The value of field ``name``, or ``default`` where the harness did not set it."""
        value = getattr(self, name)
        return default if _unset(value) else value


_R = TypeVar("_R")


def _marks_reset(reset: Callable[..., _R]) -> Callable[..., _R]:
    """Wrap a plugin's ``reset`` so that `SequentialFilter.checked_step` knows it ran."""

    @functools.wraps(reset)
    def wrapper(self: Any, *args: Any, **kwargs: Any) -> _R:
        out = reset(self, *args, **kwargs)
        self._reset_done = True
        return out

    return wrapper


#: Labels of ``SequentialFilter.assumptions`` that several plugins share (their units fixed).
ASSUMPTION_LABELS = {
    "line-of-sight acceleration PSD": "m²/s³",
    "line-of-sight jerk PSD": "m²/s⁵",
    "frequency R / thermal variance": "-",
    "code R / thermal variance": "-",
    # Reference 003 (scintillation): the carrier loops' bandwidth and phase R.
    "carrier loop noise bandwidth": "Hz",
    "phase R / thermal variance": "-",
    # Reference 001 (carrier-smoothed code, plugins/smoothers.py; context from the
    # carrier-smoothing scenario): the smoothers' averaging and noise assumptions.
    "smoothing time constant": "s",
    "noise-equivalent window": "s",
    "assumed code-minus-carrier drift PSD": "m²/s",
    "true code-minus-carrier drift PSD": "m²/s",
    "pseudorange R / code noise variance": "-",
    "Q adapter": "",
    "slip reset threshold": "m",
}


class SequentialFilter(Plugin, abc.ABC):
    """A plugin that processes a sequence epoch by epoch, batch-first.

    ``reset(batch_shape, context)`` starts it for a batch with the harness's frozen
    `RunContext`; ``step`` takes one epoch's inputs (named arrays) and returns named
    outputs. ``requires`` and ``provides`` name them, so a composition that cannot work
    is refused before a run.

    A subclass whose ``reset`` has the pre-0.2 signature ``reset(self, batch_shape,
    **context)`` is refused when it is defined, with a `TypeError` that says how to change it.
    """

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        reset = cls.__dict__.get("reset")
        if reset is None or getattr(reset, "__isabstractmethod__", False):
            return
        params = list(inspect.signature(reset).parameters.values())
        positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
        if any(p.kind == p.VAR_KEYWORD for p in params) and len(positional) < 3:
            raise TypeError(
                f"{cls.__module__}.{cls.__qualname__}.reset(self, batch_shape, **context) is the signature "
                "before 0.2; write reset(self, batch_shape, context) and read the harness's values from the "
                "frozen gnssframework.RunContext (context.coherent_time_s, context.require('cn0_dbhz', ...))"
            )
        # Wraps the subclass's own reset once, when the class is made (the marker checked_step reads).
        cls.reset = _marks_reset(cls.reset)  # type: ignore[method-assign]

    #: Names of the inputs ``step`` needs.
    requires: ClassVar[tuple[str, ...]] = ()
    #: Names of the outputs ``step`` returns.
    provides: ClassVar[tuple[str, ...]] = ()

    @abc.abstractmethod
    def reset(self, batch_shape: tuple[int, ...], context: RunContext) -> None:
        """Start a new sequence for ``batch_shape`` (runs, channels, ...) with the
        harness's `RunContext`."""

    @abc.abstractmethod
    def step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Process one epoch."""

    def check_context(self, context: RunContext) -> None:  # noqa: B027 - optional hook
        """Refuse a harness context this filter cannot run in (a loop bandwidth too large
        for the context's coherent time...), raising `ConfigError` with the field written
        ``"<kind> '<name>'.<parameter>"``. Scenarios call it when the config loads, so a
        bad value is named before any batch runs. The default accepts every context."""

    def assumptions(self, context: Mapping[str, Any]) -> dict[str, tuple[Any, str]]:
        """What this filter assumes about dynamics and noise, in units common to every
        filter of its kind, for a comparison's assumptions table: ``{label: (value,
        unit)}``. ``context`` holds what the scenario knows (``coherent_time_s``,
        ``cn0_dbhz``, ``wavelength_m``...). Labels shared across plugins (see
        :data:`ASSUMPTION_LABELS`) let a reader put a mismatch side by side before reading
        a ranking. The default declares nothing."""
        return {}

    def checked_step(self, inputs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``step``, then check it returned every name the plugin ``provides`` (harnesses
        call this, so a plugin that breaks its declaration fails at its first epoch, by name).

        Raises
        ------
        InvalidArgumentError
            Before the first ``reset``.
        PluginError
            If ``step`` did not return every name in ``provides``.
        """
        if not getattr(self, "_reset_done", False):
            raise InvalidArgumentError(
                f"{self.kind} {self.name!r}",
                "checked_step",
                "called before reset(batch_shape, context); call reset first",
            )
        inputs = _checked_inputs(self, inputs)
        out = self.step(inputs)
        missing = [n for n in self.provides if n not in out]
        if missing:
            raise PluginError(
                f"{self.kind} {self.name!r}: step() did not return {', '.join(missing)} that it declares in `provides`"
            )
        return out


def _checked_inputs(filt: SequentialFilter, inputs: Mapping[str, Any]) -> Mapping[str, Any]:
    """``inputs`` with every name ``filt.requires`` present and numeric: a missing name or
    text where numbers go is an `InvalidInputError` naming the filter and the input; a
    NumPy masked array's masked entries become NaN (missing measurements, as the readers
    give them) instead of their hidden values."""
    who = f"{filt.kind} {filt.name!r}"
    if not isinstance(inputs, Mapping):
        raise InvalidArgumentError(
            who,
            "checked_step",
            f"inputs must be a mapping of named arrays "
            f"({', '.join(filt.requires) or 'none required'}), got {type(inputs).__name__}",
        )
    masked = {}
    for name in filt.requires:
        if name not in inputs:
            raise InvalidInputError(who, f"inputs[{name!r}]", f"missing; step needs {', '.join(filt.requires)}")
        value = inputs[name]
        if isinstance(value, np.ma.MaskedArray):
            masked[name] = np.ma.filled(value.astype(float), np.nan)
            continue
        kind: str | None
        if isinstance(value, (str, bytes)) or value is None:
            kind = "text" if value is not None else "None"
        elif isinstance(value, (np.ndarray, list, tuple)):
            arr = np.asarray(value) if not isinstance(value, np.ndarray) else value
            kind = "text" if arr.dtype.kind in "USV" else None
        else:
            kind = None
        if kind is not None:
            raise InvalidInputError(who, f"inputs[{name!r}]", f"must be numbers, got {kind} {value!r:.40}")
    return {**inputs, **masked} if masked else inputs


class ChannelFilter(SequentialFilter):
    """Plugin kind ``channel_filter``: per-channel processing of correlators (``"correlators"``)
    or observables (``"pseudorange_m"``, ``"carrier_m"``) into named outputs
    (``"code_error_chips"``, ``"smoothed_m"``, NCO commands...)."""

    kind = "channel_filter"

    def restart(self, elements: np.ndarray) -> bool:
        """Forget what the filter learned for the batch ``elements`` (bool, the batch shape):
        from its next step each of them starts again from its correlators, as at its first
        step. A lock detector asks it when a lost signal comes back (the replica held by
        vector or deep aiding, the filter's state spent on noise). Returns whether the
        filter did: the default keeps the state and returns False."""
        return False


class NavFilter(SequentialFilter):
    """Plugin kind ``nav_filter``: fuses channel outputs into a navigation state.

    ``step`` takes the channel filters' outputs (stacked over channels on the last
    batch axis) and returns the navigation state and, in a vector loop, the
    per-channel NCO commands of the next epoch.
    """

    kind = "nav_filter"

    def fixed_channel_set(self) -> bool:
        """Whether the filter appends states for the channels of its first step (range
        biases), so it must be given the same channels at every step and read through its
        outputs only: a harness whose satellites come and go, or that carries the filter's
        8 states itself (the sample receiver's gate, smoother and hand-over), refuses such a
        filter. Default False."""
        return False


def refuse_fixed_channel_set(nav: NavFilter, field: str) -> None:
    """Refuse ``nav`` where satellites come and go between steps (`NavFilter.fixed_channel_set`),
    naming ``field``."""
    if nav.fixed_channel_set():
        raise ConfigError(
            field,
            f"nav_filter {nav.name!r} appends range-bias states for the channels of its first step, which the "
            "scenarios' fixed channel sets allow; here satellites come and go and the receiver carries the 8 "
            "states itself: leave sisre_std_m, iono_vertical_std_m and tropo_zenith_std_m at 0",
        )


# -- capabilities: what a harness asks of a nav filter, by contract rather than by name -------------


@dataclass(frozen=True)
class IntegrationAiding:
    """What an INS integration filter asks of the deep-integration harness around it.

    Attributes
    ----------
    accel_aiding
        Predict the NCOs with the line-of-sight acceleration from the corrected INS.
    carrier_filter
        A carrier-phase prefilter per channel (a ``channel_filter`` reference,
        :class:`~gnssframework.plugin_ref.PluginSpec`), or ``None``: the carrier phase is
        not tracked.
    clock_psd
        White-noise PSDs of the NCO clock filter's bias (m^2/s) and drift (m^2/s^3).
    coupling
        With scalar tracking loops (no NCO aiding): ``"loose"`` (position/velocity fixes
        update the filter) or ``"tight"`` (each channel's pseudorange and rate do).
    """

    accel_aiding: bool = True
    carrier_filter: Any = None
    clock_psd: tuple[float, float] = (0.1, 0.1)
    coupling: Literal["loose", "tight"] = "loose"

    def __post_init__(self) -> None:
        if self.coupling not in ("loose", "tight"):
            raise ConfigError("coupling", f"must be 'loose' or 'tight', got {self.coupling!r}")


class ErrorStateNavFilter(NavFilter):
    """A closed-loop error-state filter of a strapdown INS: the nav filter of deep and loose
    integration (``ins-ekf``).

    The contract the integration harnesses (`gnssframework.receiver.deep.ins_navigator.InsNavigator`,
    the loose baseline) rely on:

    - ``reset(batch_shape, context)`` takes the initial error covariance
      ``context.initial_cov`` ``(..., n, n)``; the error estimate starts at zero;
    - ``step(inputs)`` takes the error model's ``transition`` and ``process_noise`` since
      the previous step and a measurement, and returns ``error_state`` ``(runs, n)`` (the
      caller removes it from the INS; the filter's estimate restarts at zero) and ``cov``;
    - ``propagate(transition, process_noise)`` carries the covariance over an interval
      without a measurement (pull-in, outages);
    - ``cov`` is the covariance of the INS error now;
    - ``aiding()`` says how the harness aids the NCOs around it (`IntegrationAiding`).
    """

    @property
    def error_states(self) -> int:
        """Size of the INS error state the harness's strapdown propagates and corrects: 15 (the
        layout of `gnssframework.inertial.error_model`), or 33 with the IMU's scale factors and
        misalignments after them (`gnssframework.inertial.calibration`). ``step``'s
        ``error_state`` has this size; states the filter keeps beyond it (range biases) are
        its own."""
        return 15

    @property
    @abc.abstractmethod
    def cov(self) -> np.ndarray:
        """Covariance ``(runs, n, n)`` of the INS error now (after the last correction)."""

    @abc.abstractmethod
    def propagate(self, transition: np.ndarray, process_noise: np.ndarray) -> None:
        """Propagate the covariance over an interval without a measurement."""

    def aiding(self) -> IntegrationAiding:
        """How the deep-integration harness aids the NCOs around this filter (default: the
        `IntegrationAiding` defaults)."""
        return IntegrationAiding()

    def innovation(self, inputs: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray] | None:
        """The innovation ``(runs, m)`` of the measurement ``inputs`` (as `step` takes them)
        against the prediction over their interval, and its covariance $H P^- H^T + R$
        ``(runs, m, m)``, without updating: what the loose and tight innovation gates test.
        The default, None: the harness builds them from `cov` and the 15-state measurement
        (`receiver.deep.ins_navigator`), which holds for a filter whose state is the 15
        INS errors with a zero mean between updates."""
        return None


class BatchPositionFilter(NavFilter):
    """A position-domain filter that filters a whole recorded sequence with a linear model
    (``position-ca``): what the ``multipath`` scenario and ``filter-positions`` need.

    The contract: ``model()`` is the linear model of one coordinate, whose state holds the
    position at index ``position_index``; ``initial(first)`` the prior from the first
    measurement; ``filter(zs, estimator, ...)`` filters ``zs (K, ..., n_coord)`` with
    that model and prior through :func:`gnssframework.estimation.filter_sequence`, so a
    scenario may run the same filter with a scaled Q and R (an oracle's grid) or batched.
    """

    #: Index of the position in the state.
    position_index: ClassVar[int] = 0

    @abc.abstractmethod
    def model(self, dt_s: float | None = None) -> LinearModel:
        """The linear model (`gnssframework.estimation.LinearModel`) of one coordinate."""

    @abc.abstractmethod
    def initial(self, first: np.ndarray) -> Gaussian:
        """The prior (`gnssframework.estimation.Gaussian`) given the first measurements
        ``(..., n_coord)``: batch shape ``(..., n_coord)``."""

    def filter(
        self,
        zs: np.ndarray,
        estimator: Any,
        adapter: Any = None,
        augmentation: Any = None,
        model: LinearModel | None = None,
        **policies: Any,
    ) -> FilterResult:
        """Filter positions ``zs (K, ..., n_coord)`` in metres with ``estimator`` (and an
        optional noise adapter and augmentation); ``model`` replaces `model()` (a scaled
        Q and R). Returns the `gnssframework.estimation.FilterResult`, batch shape
        ``(..., n_coord)``."""
        zs = np.asarray(zs, dtype=float)
        return filter_sequence(
            estimator,
            self.model() if model is None else model,
            zs[..., None],
            self.initial(zs[0]),
            adapter=adapter,
            augmentation=augmentation,
            **policies,
        )
