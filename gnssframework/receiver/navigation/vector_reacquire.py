"""Loss of lock and re-acquisition of vector channels, aided by the navigation solution.

Loss of lock (`drop`): a vector channel whose C/N0 estimate over a full ``cn0_window_ms``
stays below ``loss_cn0_dbhz`` (18 dB-Hz) for ``loss_ms`` (500 ms) leaves the loop and the
tracker's active channels (a signal gone, not one faded to 24 dB-Hz, whose estimates stay
above 21 dB-Hz on the project's generator).

Once the loop runs, a satellite outside it that the solution can predict (a dropped
channel's ephemeris, or the RINEX file's) is searched every ``reacquire_every_ms`` in the
window of code phase and Doppler the state predicts
(`receiver.acquisition.assisted.window_search`) and joins the loop when found
(`reacquire`, `join`); a lost scalar channel it cannot predict gets the scalar receiver's
full search.

The functions take the `vector_tracking.VectorSampleCloser` ``v`` (annotated, not imported: it
imports them) whose navigator they read and change.
"""

from __future__ import annotations

import numpy as np
import pymap3d

from ...navigation.ephemeris import Ephemerides, satellite_state
from ...navigation.geometry import line_of_sight
from ..acquisition.assisted import SearchWindow, window_search
from ..channels.channel import SampleChannel
from .observables import SPEED_OF_LIGHT_MPS
from .vector_navigator import rotate, stack

__all__ = ["drop", "reacquire", "join"]

_C = SPEED_OF_LIGHT_MPS


def drop(v: VectorSampleCloser, c: SampleChannel, t0: float) -> None:
    """Loss of lock of vector channel ``c`` (`VectorConfig.loss_cn0_dbhz` for ``loss_ms``):
    it leaves the navigation filter's updates and the tracker's active channels; its
    ephemeris is kept for the aided search (`reacquire`), which may try it from the next
    re-acquisition round on."""
    t, nav, vc = v.tracker, v.nav, v.vector
    i = c.slot
    keep = nav.slots != i
    v.held[i] = nav.eph.subset(np.flatnonzero(~keep))
    nav.eph = nav.eph.subset(np.flatnonzero(keep))
    nav.iono_m = nav.iono_m[keep]
    nav.slots = nav.slots[keep]
    nav.pending.pop(i, None)
    why = f"C/N0 estimate below {vc.loss_cn0_dbhz:g} dB-Hz for {vc.loss_ms} ms"
    t.deactivate(
        c,
        int(t.start_sample[i]),
        (t0, f"lost: {why}; out of the navigation filter, re-acquisition aided by the navigation solution"),
    )
    v.solution.events.append((t0, f"PRN {c.prn} dropped from the vector loop ({why})"))


def reacquire(v: VectorSampleCloser, at: int, stop: int) -> None:
    """Every satellite the solution can predict (a RINEX record, or the kept record of a
    dropped vector channel) that is not in the loop is searched in its predicted window
    (`window_search`) and joins the loop when found; lost channels it cannot predict get
    the full search (`SampleTracker.search`)."""
    t, p = v.tracker, v.vector
    sp = t.signal
    need = int(round(p.reacquire_coherent_ms * 1e-3 * t.fs)) * p.reacquire_noncoherent
    if at + need > stop:
        return
    t_s = at / t.fs
    unpredicted = []
    in_loop = set(v.nav.slots.tolist())
    for prn in sp.prns:
        c = t.channels.get(prn)
        if (c is not None and (c.stage != "lost" or c.retry_at > at)) or t.slot(prn) in in_loop:
            continue
        predicted = _predict_signal(v, prn, t_s)
        if predicted is None:
            if c is not None:
                unpredicted.append(prn)
            continue
        record, window, tx_s, elevation = predicted
        if elevation < p.reacquire_elevation_deg:
            continue
        acq = window_search(
            t.rec.read(at, need),
            t.fs,
            t.if_hz,
            prn,
            window,
            coherent_ms=p.reacquire_coherent_ms,
            noncoherent=p.reacquire_noncoherent,
            alternate=p.reacquire_coherent_ms == 10,
            pfa=p.reacquire_pfa,
            signal=sp,
        )
        if not acq.detected:
            continue
        per_code = t.fs * sp.code_length_chips / sp.chip_rate_hz
        code_off = (acq.code_phase_samples - window.code_start_samples + per_code / 2) % per_code - per_code / 2
        t.add(prn, acq, at)
        v.held.pop(t.slot(prn), None)
        c = t.channels[prn]
        c.record.events.append(
            (
                t_s,
                f"re-acquired in the window predicted by the navigation solution "
                f"({code_off:+.1f} samples, {acq.doppler_hz - window.doppler_hz:+.1f} Hz "
                f"from the prediction; window +-{window.code_halfwidth_samples:.1f} samples, "
                f"+-{window.doppler_halfwidth_hz:.1f} Hz)",
            )
        )
        v.solution.events.append((t_s, f"PRN {prn} re-acquired by the aided search"))
        join(v, c, record, tx_s + acq.code_phase_samples / t.fs * (1 + window.doppler_hz / sp.carrier_freq_hz))
    t.search(tuple(unpredicted), at, stop)


def _predict_signal(v: VectorSampleCloser, prn: int, t_s: float):
    """The solution's prediction for ``prn`` at recording time ``t_s``: its RINEX
    record, the `SearchWindow` (the first code epoch after ``t_s``; half widths
    ``reacquire_sigmas`` standard deviations of the predicted range and rate, from the
    state covariance on the line of sight), the transmit time at ``t_s`` and the
    elevation (deg); None without a healthy record (the kept one of a dropped vector
    channel, else the RINEX file's)."""
    t, nav = v.tracker, v.nav
    sp = t.signal
    record = v.held.get(t.slot(prn))
    if record is None:
        if v.rinex is None:
            return None
        try:
            record = v.rinex.select([sp.rinex_satellite(prn)], t_s + nav.rx_offset)
        except KeyError:
            return None
    dt = t_s - nav.t_nav
    x = nav.x
    r, b = x[:3] + x[3:6] * dt, x[6] + x[7] * dt
    t_rx = t_s + nav.rx_offset
    tx = t_rx - 0.075
    for _ in range(3):  # the flight time, iterated
        st = satellite_state(record, np.array([tx]))
        pos, vel = rotate(st.position_m, np.array([t_rx - tx])), rotate(st.velocity_mps, np.array([t_rx - tx]))
        dist, e = line_of_sight(pos, r)
        tx = t_rx - (float(dist[0]) + b - _C * float(st.clock_l1_s[0])) / _C
    e = e[0]
    rate = float((vel[0] - x[3:6]) @ e + x[7] - _C * st.clock_drift_s_s[0])
    doppler = t.nco.doppler_hz(rate)
    h = np.r_[-e, 1.0]
    cov = v.solution.cov[-1]
    pc, vd = np.r_[0:3, 6], np.r_[3:6, 7]
    sigma_range = float(np.sqrt(h @ cov[np.ix_(pc, pc)] @ h))
    sigma_rate = float(np.sqrt(h @ cov[np.ix_(vd, vd)] @ h))
    k = v.vector.reacquire_sigmas
    n = sp.code_length_chips
    chips = (tx * (1.0 / sp.code_period_s) % 1.0) * n  # sent of the current period at t_s
    code_rate = sp.code_freq_hz(doppler)
    window = SearchWindow(
        (n - chips) / code_rate * t.fs,
        doppler,
        k * sigma_range / sp.chip_length_m * t.fs / sp.chip_rate_hz,
        k * sigma_rate / sp.wavelength_m,
    )
    lat, lon, hgt = pymap3d.ecef2geodetic(*r)
    _, elevation, _ = pymap3d.ecef2aer(*pos[0], lat, lon, hgt)
    return record, window, tx, float(elevation)


def join(v: VectorSampleCloser, c: SampleChannel, record: Ephemerides, tx_start_s: float) -> None:
    """Channel ``c`` (just added at a code epoch) joins the vector loop: its transmit
    time there is a whole code period (the predicted one rounded), its bit edge follows,
    and it goes over at its next aligned boundary (`VectorSampleCloser.advance`)."""
    t, nav = v.tracker, v.nav
    sp = t.signal
    i = c.slot
    whole = int(np.round(tx_start_s * (1.0 / sp.code_period_s)))
    nav.tx_anchor[i] = whole * sp.code_period_s + t.code_phase[i] / sp.chip_rate_hz
    nav.chip_anchor[i] = t.ms_index[i] * sp.code_length_chips + t.code_phase[i]
    c.bit_edge = (int(t.ms_index[i]) + 1 - whole) % c.periods_per_symbol
    records = {int(s): nav.eph.subset(np.array([k])) for k, s in enumerate(nav.slots)}
    records[i] = record
    nav.slots = np.array(sorted(records))
    nav.eph = stack([records[int(s)] for s in nav.slots])
    nav.iono_m = nav.delays(nav.slots, nav.x[:3], float(t.start_sample[i]) / t.fs)
    v.solution.prns = tuple(sorted(set(v.solution.prns) | {sp.prns[int(s)] for s in nav.slots}))
    c.vector_pending = True
    t.leave_batch(c)
    c.join_tries = 3
    nav.command(np.array([i]), nav.x)
