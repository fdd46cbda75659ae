"""What the tracker does with the correlator's period sums of one call, before any filter
steps: normalise them, advance the channels' NCO bookkeeping, keep the 1 ms prompts for
the lock detectors and count the bit-sync votes, and sum each channel's coherent interval.

`close_periods` does it for all channels of a call in one compiled pass (the per-interval
cost that matters at low sample rates, where a call correlates little); `close_periods_numpy`
is the reference, on arrays, with the same arithmetic in the same order: the two give
bit-identical results (tested).

- Normalisation: a 1 ms sum of N samples of mean power P against a ±1 replica has I and Q
  noise variance N P / 2 (`gnssframework.receiver.channels.tracker`), so each period's sums
  are divided by :math:`\\sqrt{N P / 2}` (as NumPy divides a complex by a real: times its
  reciprocal). ``power`` is, per channel, the replica's mean square times P: P for a ±1
  replica, P d for one that is 0 outside a share d of the time (`SignalSpec.replica_duty`);
  P is that of the block the channel's interval starts in (`tracker.SampleTracker`).
- Bit synchronisation votes (`lock`): a prompt turned by more than 90 degrees from the
  previous one, :math:`\\mathrm{Re}(P_k P_{k-1}^*) < 0`, votes for its code period modulo the
  code periods of a data symbol (the histograms' length; 20 on L1 C/A).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...backend import HAVE_NUMBA, get_backend

__all__ = ["ChannelArrays", "close_periods", "close_periods_numpy"]


@dataclass
class ChannelArrays:
    """The tracker's per-slot arrays that `close_periods` reads and advances (views, not copies).

    Attributes
    ----------
    acc_t0, acc_phase, acc_cycles
        Start time (s), code phase (chips) and replica Doppler phase (cycles) of the
        interval just closed (what its record row reports).
    start_sample, code_phase, doppler_cycles
        First sample of the next interval, its code phase (chips) and accumulated Doppler phase.
    prompts, n_prompts
        Ring buffers of 1 ms prompts ``(slots, window)`` and how many each has received.
    ms_index
        Milliseconds tracked (the bit-sync histogram's clock).
    previous_prompt, voting, votes
        Last 1 ms prompt, whether the channel votes, the ``(slots, periods per symbol)`` histograms.
    """

    acc_t0: np.ndarray
    acc_phase: np.ndarray
    acc_cycles: np.ndarray
    start_sample: np.ndarray
    code_phase: np.ndarray
    doppler_cycles: np.ndarray
    prompts: np.ndarray
    n_prompts: np.ndarray
    ms_index: np.ndarray
    previous_prompt: np.ndarray
    voting: np.ndarray
    votes: np.ndarray


def close_periods_numpy(
    a: ChannelArrays,
    idx: np.ndarray,
    sums: np.ndarray,
    counts: np.ndarray,
    starts: np.ndarray,
    phases: np.ndarray,
    steps: np.ndarray,
    periods: np.ndarray,
    doppler_hz: np.ndarray,
    power: np.ndarray,
    sample_rate_hz: float,
    code_length: int,
) -> np.ndarray:
    """Reference of `close_periods`. ``sums`` ``(n, max periods, taps)`` (tap 1 the prompt)
    and ``counts`` ``(n, max periods)`` as `correlator.correlate_periods` returns them for
    the channels at slots ``idx`` (ascending), which started at ``starts`` with code phase
    ``phases``, code step ``steps`` (chips per sample), ``periods`` code periods,
    ``doppler_hz`` and the replica's sum of squares per sample ``power``. ``sums`` is
    normalised in place; returns the ``(n, taps)`` interval sums."""
    fs = sample_rate_hz
    valid = counts > 0
    sums[valid] /= np.sqrt((counts * power[:, None])[valid] / 2)[:, None]
    total = counts.sum(axis=1)
    a.acc_t0[idx] = starts / fs
    a.acc_phase[idx] = phases
    a.acc_cycles[idx] = a.doppler_cycles[idx]
    a.start_sample[idx] = starts + total
    a.code_phase[idx] = phases + total * steps - periods * code_length
    a.doppler_cycles[idx] += total * doppler_hz / fs
    # Every millisecond's prompt (ragged over channels: row-major, k ascending).
    rows, ks = np.nonzero(valid)
    ch = idx[rows]
    prompt = sums[rows, ks, 1]
    window = a.prompts.shape[1]
    a.prompts[ch, (a.n_prompts[ch] + ks) % window] = prompt
    a.n_prompts[idx] += periods
    ms = a.ms_index[ch] + ks + 1
    a.ms_index[idx] += periods
    previous = np.where(ks == 0, a.previous_prompt[ch], np.concatenate((prompt[-1:], prompt[:-1])))
    vote = a.voting[ch] & ((prompt * np.conj(previous)).real < 0)
    np.add.at(a.votes, (ch[vote], ms[vote] % a.votes.shape[1]), 1)
    a.previous_prompt[idx] = sums[np.arange(idx.size), periods - 1, 1]
    return sums.sum(axis=1)


def _close(
    idx,
    sums,
    counts,
    starts,
    phases,
    steps,
    periods,
    doppler_hz,
    power,
    fs,
    code_length,
    acc_t0,
    acc_phase,
    acc_cycles,
    start_sample,
    code_phase,
    doppler_cycles,
    prompts,
    n_prompts,
    ms_index,
    previous_prompt,
    voting,
    votes,
    interval,
):  # pragma: no cover - compiled (its Python run is tested against the reference)
    window = prompts.shape[1]
    per_bit = votes.shape[1]
    for j in range(idx.size):
        i = idx[j]
        total = 0
        for k in range(counts.shape[1]):
            n = counts[j, k]
            if n > 0:
                # NumPy's complex / real: the real is a complex with zero imaginary part,
                # divided as (a + b * 0) * (1 / c) (Smith's method, npymath).
                scale = 1.0 / np.sqrt(n * power[j] / 2)
                for t in range(sums.shape[2]):
                    z = sums[j, k, t]
                    sums[j, k, t] = complex((z.real + z.imag * 0.0) * scale, (z.imag - z.real * 0.0) * scale)
                total += n
        acc_t0[i] = starts[j] / fs
        acc_phase[i] = phases[j]
        acc_cycles[i] = doppler_cycles[i]
        start_sample[i] = starts[j] + total
        code_phase[i] = phases[j] + total * steps[j] - periods[j] * code_length
        doppler_cycles[i] += total * doppler_hz[j] / fs
        previous = previous_prompt[i]
        for k in range(counts.shape[1]):
            if counts[j, k] > 0:
                p = sums[j, k, 1]
                prompts[i, (n_prompts[i] + k) % window] = p
                if voting[i] and (p * np.conj(previous)).real < 0:
                    votes[i, (ms_index[i] + k + 1) % per_bit] += 1
                previous = p
        n_prompts[i] += periods[j]
        ms_index[i] += periods[j]
        previous_prompt[i] = sums[j, periods[j] - 1, 1]
        for t in range(sums.shape[2]):  # NumPy's sum over the periods axis: in order
            acc = sums[j, 0, t]
            for k in range(1, sums.shape[1]):
                acc += sums[j, k, t]
            interval[j, t] = acc


if HAVE_NUMBA:
    import numba

    _close_compiled = numba.njit(cache=True, nogil=True)(_close)
else:  # pragma: no cover
    _close_compiled = None


def close_periods(
    a: ChannelArrays,
    idx: np.ndarray,
    sums: np.ndarray,
    counts: np.ndarray,
    starts: np.ndarray,
    phases: np.ndarray,
    steps: np.ndarray,
    periods: np.ndarray,
    doppler_hz: np.ndarray,
    power: np.ndarray,
    sample_rate_hz: float,
    code_length: int,
    backend: str | None = None,
) -> np.ndarray:
    """Close the coherent intervals of the channels at slots ``idx`` (arguments as
    `close_periods_numpy`): compiled where numba is the backend, else the reference."""
    if _close_compiled is None or (backend or get_backend()) != "numba":
        return close_periods_numpy(
            a, idx, sums, counts, starts, phases, steps, periods, doppler_hz, power, sample_rate_hz, code_length
        )
    interval = np.empty((idx.size, sums.shape[2]), complex)
    _close_compiled(
        idx,
        sums,
        counts,
        starts,
        phases,
        steps,
        periods,
        doppler_hz,
        np.ascontiguousarray(power, float),
        float(sample_rate_hz),
        int(code_length),
        a.acc_t0,
        a.acc_phase,
        a.acc_cycles,
        a.start_sample,
        a.code_phase,
        a.doppler_cycles,
        a.prompts,
        a.n_prompts,
        a.ms_index,
        a.previous_prompt,
        a.voting,
        a.votes,
        interval,
    )
    return interval
