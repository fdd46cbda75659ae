r"""Loop closers of the engine: what turns correlators into the next NCO command.

- `ScalarCloser`: a channel filter per channel (``channel_filter`` plugin) reads its
  correlators and commands its own NCOs by frequency (``carrier_freq_hz``,
  ``code_freq_hz``, optional ``carrier_phase_step_rad``; `Channel.steer_frequency`).
- `VectorCloser`: channel filters turn each channel's correlators into code and frequency
  errors with their variances; a navigation filter over all channels of a run takes them
  as pseudorange and rate errors of the replicas at mid-interval (Zou et al. 2018, eqs.
  35-36) and commands every channel's NCOs by range and rate (``nco_range_m``,
  ``nco_range_rate_m_s``; `Channel.steer_range`).

A closer sees only correlators and its `Channel`: it runs unchanged on the analytic
source and on samples (`gnssframework.receiver.engine.sources`).

Signs (`gnssframework.receiver.engine.channel`): a channel filter reports errors in the
engine's convention, truth minus replica code phase (chips) and Doppler (Hz). The
navigation filters' ``code_error_chips`` input is a range error in chips,
:math:`(\rho - \hat\rho)/\lambda_{chip} = -\delta\tau`, so `VectorCloser` hands them the
channel filter's code error negated (`range_error_chips`, the one place the sign changes); their
``freq_error_hz`` is the Doppler error, :math:`\dot\rho - \dot{\hat\rho} = -\lambda\,\delta f`.
"""

from __future__ import annotations

import numpy as np

from ... import names
from ...errors import ConfigError
from ...interfaces import ChannelFilter, NavFilter, RunContext
from ...signal.correlators import Correlators
from .channel import Channel
from .channel_monitor import IGNORE_VAR, ChannelMonitor

__all__ = [
    "ScalarCloser",
    "EstimateCloser",
    "VectorCloser",
    "check_closed_loop",
    "check_estimate_loop",
    "check_composition",
    "range_error_chips",
    "NCO_COMMANDS",
    "ESTIMATE_OUTPUTS",
    "CHANNEL_OUTPUTS",
    "NAV_OUTPUTS",
    "HARNESS_INPUTS",
]

#: Outputs a channel filter needs to steer the NCOs of a closed loop.
NCO_COMMANDS = (names.CARRIER_FREQ_HZ, names.CODE_FREQ_HZ)
#: What a channel filter must provide to close its own loop by its estimates (`EstimateCloser`).
ESTIMATE_OUTPUTS = (names.CODE_ERROR_CHIPS, names.FREQ_ERROR_HZ, names.PHASE_ERROR_RAD)
#: What a channel filter must provide to feed a vector loop's nav filter.
CHANNEL_OUTPUTS = (names.CODE_ERROR_CHIPS, names.CODE_ERROR_VAR_CHIPS2, names.FREQ_ERROR_HZ, names.FREQ_ERROR_VAR_HZ2)
#: What a nav filter must provide to close a vector loop.
NAV_OUTPUTS = (
    names.POSITION_M,
    names.VELOCITY_M_S,
    names.CLOCK_M,
    names.COV,
    names.NCO_RANGE_M,
    names.NCO_RANGE_RATE_M_S,
)
#: Inputs the vector loop itself gives the nav filter (besides the channel outputs).
HARNESS_INPUTS = (
    names.SAT_POS_M,
    names.SAT_VEL_M_S,
    names.NEXT_SAT_POS_M,
    names.NEXT_SAT_VEL_M_S,
    names.REPLICA_RANGE_M,
    names.REPLICA_RATE_M_S,
)


def range_error_chips(code_error_chips: np.ndarray | float) -> np.ndarray | float:
    r"""A channel filter's code error (truth minus replica code phase, chips) as the
    navigation filters' ``code_error_chips`` input, a range error in chips
    :math:`(\rho - \hat\rho)/\lambda_{chip} = -\delta\tau` (see the module text)."""
    return -code_error_chips


def check_closed_loop(channel: ChannelFilter, record: tuple[str, ...] = ()) -> None:
    """Refuse a channel filter that cannot close a tracking loop (or lacks an output to record).

    Raises
    ------
    ConfigError
        With field ``"channel_filter"``.
    """
    needed = NCO_COMMANDS + tuple(record)
    missing = [n for n in needed if n not in channel.provides]
    if names.CORRELATORS not in channel.requires or missing:
        raise ConfigError(
            "channel_filter",
            f"{channel.name!r} cannot close a tracking loop: it must require "
            f"'correlators' and provide {', '.join(needed)}",
        )


def check_estimate_loop(channel: ChannelFilter) -> None:
    """Refuse a channel filter that `EstimateCloser` cannot close.

    Raises
    ------
    ConfigError
        With field ``"channel_filter"``.
    """
    missing = [n for n in ESTIMATE_OUTPUTS if n not in channel.provides]
    if names.CORRELATORS not in channel.requires or missing:
        raise ConfigError(
            "channel_filter",
            f"{channel.name!r} cannot close a tracking loop by its estimates: it "
            f"must require 'correlators' and provide {', '.join(ESTIMATE_OUTPUTS)}",
        )


def check_composition(channel: ChannelFilter, nav: NavFilter) -> None:
    """Refuse a channel/nav filter pair that cannot close a vector loop.

    Raises
    ------
    ConfigError
        With field ``"channel_filter"`` or ``"nav_filter"`` (the part at fault).
    """
    missing = [n for n in CHANNEL_OUTPUTS if n not in channel.provides]
    if missing:
        raise ConfigError(
            "channel_filter", f"{channel.name!r} cannot feed a vector loop: it does not provide {', '.join(missing)}"
        )
    unmet = [n for n in nav.requires if n not in channel.provides and n not in HARNESS_INPUTS]
    if unmet:
        raise ConfigError(
            "nav_filter",
            f"{nav.name!r} needs {', '.join(unmet)}, which {channel.name!r} does "
            f"not provide (it provides {', '.join(channel.provides)})",
        )
    missing = [n for n in NAV_OUTPUTS if n not in nav.provides]
    if missing:
        raise ConfigError(
            "nav_filter", f"{nav.name!r} cannot close a vector loop: it does not provide {', '.join(missing)}"
        )


class _ChannelFilterCloser:
    """What the closers with one channel filter per channel share: its start on a channel."""

    filter: ChannelFilter

    def reset(
        self,
        channel: Channel,
        coherent_time_s: float,
        *,
        early_late_spacing_chips: float = 1.0,
        cn0_dbhz: np.ndarray | float = 45.0,
    ) -> None:
        """Start the filter on ``channel``'s batch; its Doppler prior is the carrier NCO's,
        its signal the channel's (the chip rate and carrier a carrier-aided DLL scales by)."""
        T = coherent_time_s
        context = RunContext(
            coherent_time_s=T,
            early_late_spacing_chips=early_late_spacing_chips,
            epoch_interval_s=T,
            cn0_dbhz=cn0_dbhz,
            doppler_hz=channel.carrier_freq_hz,
            signal=channel.signal,
        )
        self.filter.reset(channel.batch, context)


class ScalarCloser(_ChannelFilterCloser):
    """One channel filter per channel, steering its own NCOs by frequency.

    Parameters
    ----------
    channel_filter
        Requires ``correlators``, provides ``carrier_freq_hz`` and ``code_freq_hz`` (and
        every name in ``record``).
    record
        Further outputs the caller will keep (checked here).
    """

    def __init__(self, channel_filter: ChannelFilter, record: tuple[str, ...] = ()) -> None:
        check_closed_loop(channel_filter, record)
        self.filter = channel_filter

    def step(self, channel: Channel, correlators: Correlators) -> dict[str, np.ndarray]:
        """Filter one interval's correlators and steer ``channel`` (after its `Channel.errors`
        or `Channel.run_interval` of the interval); returns the filter's outputs."""
        out = self.filter.checked_step({names.CORRELATORS: correlators})
        channel.steer_frequency(
            out[names.CARRIER_FREQ_HZ], out[names.CODE_FREQ_HZ], out.get("carrier_phase_step_rad", 0.0)
        )
        return out


class EstimateCloser(_ChannelFilterCloser):
    r"""One channel filter per channel that estimates the replica's errors, its NCOs moved to
    the estimate every interval.

    For a filter of the errors themselves (``iq-filter`` with ``output = "filtered"``: code
    error :math:`\widehat{\delta\tau}`, frequency error :math:`\widehat{\delta f}` and
    phase error :math:`\widehat{\delta\theta}` at the interval's start, truth minus
    replica) on one channel, without a navigation filter: after each interval the code NCO
    jumps by :math:`\widehat{\delta\tau}` and the carrier frequency by
    :math:`\widehat{\delta f}` (`Channel.steer_by_errors`; the code rate carrier-aided),
    and the filter is told the moves (``nco_shift_chips``, ``nco_shift_hz``), so its states
    stay relative to the replica in use. Full feedback: the replica of the next interval is
    the filter's own prediction, with no loop bandwidth of its own (the filter's Q and R set
    it). The carrier phase is not stepped (the filter's phase state keeps it): the loop's
    carrier phase estimate is the replica's plus :math:`\widehat{\delta\theta}`
    (`phase_estimate_error`).
    """

    def __init__(self, channel_filter: ChannelFilter) -> None:
        check_estimate_loop(channel_filter)
        self.filter = channel_filter

    def step(self, channel: Channel, correlators: Correlators) -> dict[str, np.ndarray]:
        """Filter one interval's correlators and move ``channel`` to the estimate (after its
        `Channel.errors` or `Channel.run_interval` of the interval); returns the outputs."""
        out = self.filter.checked_step(
            {
                names.CORRELATORS: correlators,
                names.NCO_SHIFT_CHIPS: channel.shift_chips,
                names.NCO_SHIFT_HZ: channel.shift_hz,
            }
        )
        channel.steer_by_errors(out[names.CODE_ERROR_CHIPS], out[names.FREQ_ERROR_HZ])
        return out

    @staticmethod
    def phase_estimate_error(
        true_mid_phase_error_rad: np.ndarray, out: dict[str, np.ndarray], coherent_time_s: float
    ) -> np.ndarray:
        r"""The true error of the loop's carrier phase estimate at mid-interval: the replica's
        true error :math:`\delta\theta + \pi\,\delta f\,T` minus the filter's estimate of
        it, :math:`\widehat{\delta\theta} + \pi\widehat{\delta f}T`."""
        est = out[names.PHASE_ERROR_RAD] + np.pi * out[names.FREQ_ERROR_HZ] * coherent_time_s
        return true_mid_phase_error_rad - est


class VectorCloser:
    """Channel filters feeding one navigation filter per run, which steers every channel by range.

    Parameters
    ----------
    channel_filter, nav_filter
        A channel filter providing `CHANNEL_OUTPUTS` and a nav filter providing
        `NAV_OUTPUTS` (`check_composition`).
    monitor
        A `ChannelMonitor` that tests each channel's innovation before the nav filter's
        update and leaves excluded channels out of it (None: every channel used). It works
        for any nav filter: from the channel outputs, the filter's published position and
        covariance and its ``transition(T)`` if it has one. Its ``observe`` sees each
        interval's correlators first (a lock test on them: `CN0LockDetector`), and the
        channels it marks ``returned`` have their filters restarted (`ChannelFilter.restart`).
    """

    def __init__(
        self, channel_filter: ChannelFilter, nav_filter: NavFilter, monitor: ChannelMonitor | None = None
    ) -> None:
        check_composition(channel_filter, nav_filter)
        self.filter, self.nav, self.monitor = channel_filter, nav_filter, monitor

    def reset(self, channel: Channel, context: RunContext) -> None:
        """Start the channel filters on ``channel``'s batch ``(runs, channels)`` and the nav filter on the runs."""
        self.filter.reset(channel.batch, context)
        self.nav.reset(channel.batch[:1], context)
        if self.monitor is not None:
            self.monitor.reset(channel.batch)
            self._position = np.asarray(context.initial_state, float)[..., 0:3]
            self._cov = np.asarray(context.initial_cov, float)[..., :8, :8]
            self._predict = False  # the initial estimate is at the first mid-interval

    def _screen(self, nav_in: dict[str, np.ndarray], chip_length_m: float, coherent_time_s: float) -> None:
        """The monitor's test on this interval's innovations; excluded channels' variances
        raised to `IGNORE_VAR` in ``nav_in``."""
        P = self._cov
        if self._predict and hasattr(self.nav, "transition"):
            F, Q = (np.asarray(a, float)[:8, :8] for a in self.nav.transition(coherent_time_s))
            P = F @ P @ F.T + Q
        los = np.asarray(nav_in[names.SAT_POS_M], float) - self._position[..., None, :]
        los = los / np.linalg.norm(los, axis=-1, keepdims=True)
        innovation = chip_length_m * np.asarray(nav_in[names.CODE_ERROR_CHIPS], float)
        variance = chip_length_m**2 * np.asarray(nav_in[names.CODE_ERROR_VAR_CHIPS2], float)
        out = self.monitor.screen(innovation, variance, los, P)
        for name in (names.CODE_ERROR_VAR_CHIPS2, names.FREQ_ERROR_VAR_HZ2):
            nav_in[name] = np.where(out, IGNORE_VAR, nav_in[name])

    def channel_step(
        self, channel: Channel, correlators: Correlators, data_bit: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """The channel filters on one interval (told how far the last command moved the NCOs)."""
        inputs = {
            names.CORRELATORS: correlators,
            names.NCO_SHIFT_CHIPS: channel.shift_chips,
            names.NCO_SHIFT_HZ: channel.shift_hz,
        }
        if data_bit is not None:
            inputs[names.DATA_BIT] = data_bit
        if self.monitor is not None:  # a lock test on the correlators reads them here
            self.monitor.observe(correlators)
            if self.monitor.returned.any():  # a lost signal back: its filter starts again
                self.filter.restart(self.monitor.returned)
        return self.filter.checked_step(inputs)

    def nav_step(
        self,
        channel: Channel,
        ch_out: dict[str, np.ndarray],
        geometry: dict[str, np.ndarray],
        coherent_time_s: float,
        next_start_s: float,
    ) -> dict[str, np.ndarray]:
        """The nav filter on the channel outputs (code error as range error: negated) and
        ``geometry`` (satellite states, `HARNESS_INPUTS` but the replica's), then the range
        command of the interval starting at ``next_start_s`` into ``channel``."""
        nav_in = dict(ch_out)
        nav_in[names.CODE_ERROR_CHIPS] = range_error_chips(ch_out[names.CODE_ERROR_CHIPS])
        nav_in.update(geometry)
        rate = channel.nco_range_rate_m_s
        batch = channel.batch
        nav_in[names.REPLICA_RANGE_M] = channel.nco_range_m + rate * coherent_time_s / 2
        nav_in[names.REPLICA_RATE_M_S] = rate if np.shape(rate) == batch else np.broadcast_to(rate, batch)
        if self.monitor is not None:
            self._screen(nav_in, channel.signal.chip_length_m, coherent_time_s)
        nav_out = self.nav.checked_step(nav_in)
        if self.monitor is not None:
            self._position = np.asarray(nav_out[names.POSITION_M], float).reshape(batch[0], 3)
            self._cov = np.array(np.asarray(nav_out[names.COV], float)[..., :8, :8])
            self._predict = True
        channel.steer_range(nav_out[names.NCO_RANGE_M], nav_out[names.NCO_RANGE_RATE_M_S], next_start_s)
        return nav_out
