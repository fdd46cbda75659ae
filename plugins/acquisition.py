"""Built-in acquisition (plugin kind ``acquisition``): FFT parallel code-phase search."""

from __future__ import annotations

from dataclasses import replace
from typing import Literal

import numpy as np
from pydantic import Field

from gnssframework.errors import ConfigError
from gnssframework.receiver.acquisition import (
    Acquisition,
    AcquisitionResult,
    fine_doppler,
    noise_floor,
    first_period_lag,
    overlay_doppler,
    overlay_refine_periods,
    search_grid,
    sideband_overlap,
    sideband_power_fraction,
    threshold_from_pfa,
)
from gnssframework.receiver.acquisition.search import searched_prns
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.spec import SignalSpec
from gnssframework.plugin import PluginParams

__all__ = ["ParallelCodePhaseSearch"]

#: Largest raw search grid held at once (float32 elements, 64 MB): PRNs are searched in
#: groups whose grids fit (each PRN's grid is the same whatever its group; a 1 ms code's
#: 32 PRNs are one group; a 10 ms weak-signal search's about 3 PRNs a group).
_GRID_ELEMENTS = 1 << 24


class PcpsParams(PluginParams):
    coherent_ms: int = Field(1, ge=1, le=10, description="coherent integration time (code periods)")
    noncoherent: int = Field(8, ge=1, le=100, description="non-coherent sums K of coherent blocks")
    doppler_max_hz: float = Field(5000.0, gt=0, le=50_000, description="search Doppler range +-")
    doppler_step_hz: float | None = Field(
        None, gt=0, description="coarse Doppler bin spacing; null: 1/(2T), at most half a sinc lobe"
    )
    fine_step_hz: float | None = Field(None, gt=0, description="fine-search step around the coarse peak; null: 1/(20T)")
    pfa: float = Field(1e-3, gt=0, lt=1, description="false-alarm probability of one PRN's whole search")
    alternate_blocks: bool = Field(
        False,
        description="sum the even and the odd coherent blocks apart and keep the larger: with 10 ms blocks "
        "one of the two is free of data-bit transitions (needs an even noncoherent)",
    )
    xcorr_margin_db: float | None = Field(
        17.0,
        gt=0,
        description="drop a detection whose C/N0 estimate is more than this below the strongest one's: "
        "a C/A cross-correlation sidelobe of a strong signal; null keeps every detection",
    )
    code_doppler: bool = Field(
        False,
        description="follow the code Doppler across the non-coherent blocks (each block's correlation shifted "
        "back by its drift, 3.2 chips/s at 5 kHz on L1): a long search (hundreds of ms) keeps its peak",
    )
    boc_search: Literal["full", "bpsk-like"] = Field(
        "full",
        description="a BOC signal's search: full (its spreading waveform, narrow peak with side peaks) or "
        "bpsk-like (the code on the upper and lower sub-carrier side bands, powers summed: one peak a chip "
        "wide either side, 0.9 dB less on the peak; Martin et al. 2003)",
    )


class ParallelCodePhaseSearch(Acquisition):
    """FFT parallel code-phase search over Doppler bins, non-coherent sums, then a fine
    Doppler search at the peak's code phase.

    The test statistic is the peak of :math:`S = \\sum_k |z_k|^2 / \\sigma^2`, with the
    noise floor :math:`\\sigma^2` measured on the PRN's own grid
    (`gnssframework.receiver.acquisition.threshold.noise_floor`); the threshold is the
    chi-square(2K) quantile for the per-cell false-alarm probability that gives ``pfa``
    over the grid's cells. C/N0 from the fine peak: with the correlator normalisation of
    `gnssframework.signal.correlator_model`, :math:`E[S] = K(2 + 2cT)`, so
    :math:`\\hat c = (S/K - 2)/(2T)`; for a component sent in one of two time slots (GPS L2
    CM) a block holds its energy over :math:`T/2` only, so :math:`2T` becomes :math:`T` (the
    replica's duty, `SignalSpec.replica_duty`), and :math:`\\hat c` is the signal's C/N0
    (CM and CL together, which share the slots and the power; the tracker reports the same,
    `gnssframework.receiver.channels.lock.signal_cn0_dbhz`).

    ``boc_search = "bpsk-like"`` (a BOC signal) sums the two side bands' correlations
    (`gnssframework.receiver.acquisition.fft_search`): the noise-only statistic is then
    chi-square with :math:`4K` degrees of freedom, the threshold and the noise floor are
    those of :math:`2K` blocks, and :math:`E[S] = K(4 + 2cTg)` with :math:`g` the side
    bands' share of the signal's power (`sideband_power_fraction`, 0.81 for BOC(1,1)),
    which the C/N0 divides out.
    """

    name = "pcps"
    description = "FFT parallel code-phase search, threshold from a false-alarm probability"
    Params = PcpsParams
    params: PcpsParams  # self.params, as validated

    def _coherent_s(self, signal: SignalSpec = GPS_L1CA) -> float:
        """The coherent time: ``coherent_ms`` code periods of ``signal`` (ms for L1 C/A)."""
        return self.params.coherent_ms * signal.code_period_s

    def samples_needed(self, sample_rate_hz: float, signal: SignalSpec = GPS_L1CA) -> int:
        """The search's blocks, or the overlay refinement's periods where that is longer
        (`fft_search.overlay_refine_periods`: 41 ms for B1I's NH20; fewer samples skip the
        refinement, they are not refused)."""
        # The refinement's periods start up to one period in (at the found code epoch).
        refine = int(round((overlay_refine_periods(signal) + 1) * signal.code_period_s * sample_rate_hz))
        return max(self._search_samples(sample_rate_hz, signal), refine)

    def _search_samples(self, sample_rate_hz: float, signal: SignalSpec) -> int:
        """The search's own blocks: ``coherent_ms`` code periods times ``noncoherent``."""
        return int(round(self._coherent_s(signal) * sample_rate_hz)) * self.params.noncoherent

    def dopplers_hz(self, signal: SignalSpec = GPS_L1CA) -> np.ndarray:
        p = self.params
        step = p.doppler_step_hz or 1.0 / (2 * self._coherent_s(signal))
        half = int(np.floor(p.doppler_max_hz / step + 1e-9))
        return np.arange(-half, half + 1) * step

    def acquire(
        self,
        samples: np.ndarray,
        sample_rate_hz: float,
        if_hz: float,
        prns: tuple[int, ...] | None = None,
        signal: SignalSpec = GPS_L1CA,
    ) -> list[AcquisitionResult]:
        p = self.params
        prns = searched_prns(prns, signal)
        T = self._coherent_s(signal)
        need = self._search_samples(sample_rate_hz, signal)
        if samples.shape[0] < need:
            raise ConfigError(
                "recording",
                f"acquisition needs {need} samples ({need / sample_rate_hz * 1e3:.0f} ms: "
                f"{p.coherent_ms} ms coherent x {p.noncoherent} non-coherent), the recording holds "
                f"{samples.shape[0]}",
            )
        alt = p.alternate_blocks
        if alt and p.noncoherent % 2:
            raise ConfigError(
                "acquisition.noncoherent", f"alternate_blocks needs an even number of blocks, got {p.noncoherent}"
            )
        blocks = p.noncoherent // 2 if alt else p.noncoherent  # summed into the statistic
        dopplers = self.dopplers_hz(signal)
        n = int(round(T * sample_rate_hz))
        sidebands = self._sidebands(signal, n, sample_rate_hz)
        threshold = threshold_from_pfa(p.pfa, dopplers.size * n, blocks * sidebands, alt)
        fine_step = p.fine_step_hz or 1.0 / (20 * T)
        coarse_step = dopplers[1] - dopplers[0] if dopplers.size > 1 else fine_step
        results = []
        # PRNs in groups whose grids fit _GRID_ELEMENTS (one group for a 1 ms code; a 20 ms
        # code such as L2 CM has 20 times the lags and 20 times the Doppler bins a PRN).
        group = max(1, _GRID_ELEMENTS // (dopplers.size * n))
        for lo in range(0, len(prns), group):
            grid = search_grid(
                samples,
                sample_rate_hz,
                if_hz,
                prns[lo : lo + group],
                T,
                p.noncoherent,
                dopplers,
                alt,
                signal,
                code_doppler=p.code_doppler,
                bpsk_like=sidebands == 2,
            )
            results += self._peaks(
                grid,
                prns[lo : lo + group],
                samples,
                sample_rate_hz,
                if_hz,
                T,
                dopplers,
                threshold,
                blocks,
                fine_step,
                coarse_step,
                signal,
            )
            del grid  # freed before the next group's is made: one grid at a time
        found = [r.cn0_dbhz for r in results if r.detected]
        if p.xcorr_margin_db is not None and found:
            floor = max(found) - p.xcorr_margin_db
            results = [replace(r, detected=False) if r.detected and r.cn0_dbhz < floor else r for r in results]
        return results

    def _symbol_blocks(self, signal: SignalSpec, alternate: bool) -> bool:
        """Whether the fine search takes its blocks from the code epoch on: where a coherent
        block is exactly the span over which the tracked component's sign holds, one data
        symbol (`SignalSpec.code_periods_per_symbol` equal to ``coherent_ms``: L2 CM, E1-B)
        or, under an overlay code, one code period (E1-C, L5, E5a: the overlay may flip the
        sign at every code epoch), with two blocks or more and not summed by parity."""
        p = self.params
        sign_periods = 1 if signal.overlay_length(0) else signal.code_periods_per_symbol
        return sign_periods == p.coherent_ms and p.noncoherent >= 2 and not alternate and not p.code_doppler

    def _sidebands(self, signal: SignalSpec, n: int, sample_rate_hz: float) -> int:
        """Correlations summed per block: 1, or 2 for a BPSK-like search, refused in one line
        for a signal without a sub-carrier or a sample rate that folds the side bands together."""
        if self.params.boc_search == "full":
            return 1
        if signal.subcarrier.kind == "bpsk":
            raise ConfigError(
                "acquisition.boc_search",
                f"'bpsk-like' searches a BOC signal's side bands; {signal.name!r} has no sub-carrier: use 'full'",
            )
        overlap = sideband_overlap(n, sample_rate_hz, signal)
        if overlap > 0.1:
            raise ConfigError(
                "acquisition.boc_search",
                f"'bpsk-like' at {sample_rate_hz / 1e6:g} MHz: the rate folds the two side bands "
                f"{2 * signal.subcarrier.frequency_hz / 1e6:g} MHz apart onto one frequency (their "
                f"replicas overlap {overlap:.2f}); use another sample rate or 'full'",
            )
        return 2

    def _peaks(
        self, grid, prns, samples, sample_rate_hz, if_hz, T, dopplers, threshold, blocks, fine_step, coarse_step, signal
    ) -> list[AcquisitionResult]:
        """Each PRN's peak of its raw ``grid``, its fine Doppler and C/N0."""
        p = self.params
        alt = p.alternate_blocks
        # The signal's energy in a coherent block is C T duty, not C T (`SignalSpec.replica_duty`);
        # a BPSK-like search's two side bands hold g of it and add two noise terms a block.
        duty = signal.replica_duty
        n = int(round(T * sample_rate_hz))
        sidebands = self._sidebands(signal, n, sample_rate_hz)
        if sidebands == 2:
            duty *= sideband_power_fraction(prns[0], n, sample_rate_hz, signal)
        results = []
        for i, prn in enumerate(prns):
            sigma2 = noise_floor(grid[i], blocks * sidebands, alt)
            d, lag = np.unravel_index(int(np.argmax(grid[i])), grid[i].shape)
            s = first_period_lag(int(lag), sample_rate_hz, signal)
            stat = float(grid[i, d, lag] / sigma2)
            fine = dopplers[d] + np.arange(-coarse_step, coarse_step + fine_step / 2, fine_step)
            # A block that is one data symbol (L2 CM: 20 ms; E1-B: 4 ms) but starts at sample 0
            # holds the symbol edge at the code epoch s: where the symbols differ its two parts
            # cancel, and the frequency that maximises the sum is pulled off the true one (21.5 Hz
            # on an L2C satellite, which then pulled in to a false lock 25 Hz off). The fine
            # search then takes the whole symbols from s on: one block fewer, none straddling.
            aligned = self._symbol_blocks(signal, alt)
            start, fine_blocks = (int(s), p.noncoherent - 1) if aligned else (0, p.noncoherent)
            raw = fine_doppler(
                samples[start:],
                sample_rate_hz,
                if_hz,
                prn,
                0 if aligned else int(s),
                T,
                fine_blocks,
                fine,
                alt,
                signal,
                bpsk_like=sidebands == 2,
                code_doppler=p.code_doppler,
            )
            power = raw / sigma2
            j = int(np.argmax(power))
            doppler = float(fine[j])
            if stat > threshold and overlay_refine_periods(signal):  # a 1 ms overlay: its own detector
                refined = overlay_doppler(samples, sample_rate_hz, if_hz, prn, int(s), doppler, signal)
                doppler = doppler if refined is None else refined
            summed = blocks - 1 if aligned else blocks
            c = max((power[j] / summed - 2.0 * sidebands) / (2 * T * duty), 1e-3)
            # Chip 0 at sample s: the phase at sample 0 is -s samples' worth of chips.
            chips = float((-s * signal.chip_rate_hz / sample_rate_hz) % signal.code_length_chips)
            results.append(
                AcquisitionResult(
                    int(prn),
                    stat > threshold,
                    doppler,
                    s,
                    chips,
                    float(10 * np.log10(c)),
                    stat,
                    threshold,
                )
            )
        return results
