"""Intermediate-frequency (IF) samples: generation and correlation into ``Correlators``.

The same tracking loops then run on generated or recorded samples. Correlator
outputs are scaled to the normalisation of `gnssframework.signal.correlator_model`
(unit-variance I and Q noise), so the analytic model and this path agree.

Signal model, real samples (complex: ``exp`` instead of ``cos``, no factor 1/2):

$$
s(t_n) = a\\, D(t_n)\\, c\\big(\\tau(t_n)\\big) \\cos\\big(2\\pi (f_{IF} + f_D) t_n + \\theta_0\\big) + w_n,
\\qquad w_n \\sim N(0, \\sigma^2)
$$

with $a = \\sqrt{4 \\sigma^2 c / f_s}$ for real and $a = \\sqrt{2 \\sigma^2 c / f_s}$ for complex
samples ($c$ = C/N0 in Hz, $f_s$ the sample rate). The code phase advances at
$f_{chip} (1 + f_D / f_{L})$ (code Doppler).

The signal is any `SignalSpec` (GPS L1 C/A by default): $c$ is its spreading waveform
(`SignalSpec.spreading_table`, code times sub-carrier) times the tracked component's
overlay code (`SignalSpec.overlay`: the PRN's own where it differs by PRN) (one chip per primary code period, if it has one), $D$ its data symbols.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import backend
from ..errors import ConfigError
from .correlator_model import tap_offsets
from .correlators import Correlators
from .gps_l1ca import GPS_L1CA
from .navdata import bit_at
from .spec import SignalSpec

__all__ = ["IfSignal", "generate_if_samples", "signal_samples", "correlate_if", "carrier_phasor", "SAMPLE_TYPES"]

#: Allowed sample types and the noise standard deviation (in LSB) they are scaled to.
SAMPLE_TYPES = {"float64": 1.0, "float32": 1.0, "int16": 1000.0, "int8": 16.0}


@dataclass(frozen=True)
class IfSignal:
    """Generated IF samples and what is needed to correlate them."""

    samples: np.ndarray
    sample_rate_hz: float
    if_hz: float
    noise_std: float
    is_complex: bool
    #: The signal the samples hold (the replica `correlate_if` makes).
    spec: SignalSpec = GPS_L1CA


def _check(sample_rate_hz: float, if_hz: float, is_complex: bool, signal: SignalSpec = GPS_L1CA) -> None:
    rate = signal.chip_rate_hz * signal.subchips_per_chip
    if sample_rate_hz <= rate:
        what = "chip rate" if signal.is_bpsk else "sub-chip rate"
        raise ConfigError("sample_rate_hz", f"must exceed the {what} {rate} Hz of {signal.name}, got {sample_rate_hz}")
    if not is_complex and not 0 < if_hz < sample_rate_hz / 2:
        raise ConfigError("if_hz", f"real sampling needs 0 < IF < fs/2 = {sample_rate_hz / 2}, got {if_hz}")


def generate_if_samples(
    prn: int,
    duration_s: float,
    sample_rate_hz: float,
    if_hz: float,
    cn0_dbhz: float,
    rng: np.random.Generator,
    *,
    doppler_hz: float = 0.0,
    code_phase_chips: float = 0.0,
    carrier_phase_rad: float = 0.0,
    complex_samples: bool = False,
    sample_type: str = "float64",
    data_bits: np.ndarray | None = None,
    first_bit_edge_s: float = 0.0,
    noise: bool = True,
    signal: SignalSpec = GPS_L1CA,
) -> IfSignal:
    """Generate IF samples of one satellite's signal (GPS L1 C/A by default) in white noise.

    Parameters
    ----------
    prn
        Satellite PRN (one of ``signal.prns``: 1-32 for GPS L1 C/A).
    duration_s, sample_rate_hz, if_hz
        Length, sample rate and intermediate frequency (0 allowed for complex).
    cn0_dbhz
        Carrier-to-noise density ratio of the whole signal. A component sent in one of
        several time slots (GPS L2 CM) is sent at the whole signal's amplitude in its slots
        only (the other components' are not generated), so it holds its share of the power
        (half on L2C: CM's own C/N0 is 3 dB below).
    rng
        The only source of randomness.
    doppler_hz, code_phase_chips, carrier_phase_rad
        Signal parameters at t = 0.
    complex_samples
        I/Q samples instead of real ones.
    sample_type
        One of ``SAMPLE_TYPES``; integers are rounded and clipped after scaling the
        noise to the listed standard deviation.
    data_bits
        Optional ±1 navigation bits (one per ``signal.symbol_period_s`` from
        ``first_bit_edge_s``: 50 bit/s for L1 C/A).
    noise
        False generates the noise-free signal (for checks against the analytic model).
    signal
        The signal's description (`SignalSpec`): code, chip rate, sub-carrier, carrier.
    """
    if sample_type not in SAMPLE_TYPES:
        raise ConfigError("sample_type", f"got {sample_type!r}; allowed: {', '.join(SAMPLE_TYPES)}")
    _check(sample_rate_hz, if_hz, complex_samples, signal)
    if data_bits is not None and signal.symbol_period_s is None:
        raise ConfigError("data_bits", f"{signal.name} carries no data symbols")
    n = int(round(duration_s * sample_rate_hz))
    sigma = SAMPLE_TYPES[sample_type]
    c = 10.0 ** (cn0_dbhz / 10.0)
    a = np.sqrt((2.0 if complex_samples else 4.0) * sigma**2 * c / sample_rate_hz)
    x = signal_samples(
        signal,
        prn,
        n,
        sample_rate_hz,
        float(a),
        code_phase_chips,
        signal.chip_rate_hz * (1.0 + doppler_hz / signal.carrier_freq_hz),
        carrier_phase_rad,
        2 * np.pi * (if_hz + doppler_hz) / sample_rate_hz,
        data_bits,
        first_bit_edge_s,
        complex_samples,
    )
    if noise:
        if complex_samples:
            x = x + sigma * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        else:
            x = x + sigma * rng.standard_normal(n)
    if sample_type.startswith("int"):
        info = np.iinfo(sample_type)
        if complex_samples:
            x = np.stack([x.real, x.imag], axis=-1)
        x = np.clip(np.rint(x), info.min, info.max).astype(sample_type)
    else:
        x = x.astype(
            np.complex128
            if complex_samples and sample_type == "float64"
            else (np.complex64 if complex_samples else sample_type),
            copy=False,  # float64 samples are already of their type: no copy
        )
    return IfSignal(x, float(sample_rate_hz), float(if_hz), sigma, complex_samples, signal)


def signal_samples(
    signal: SignalSpec,
    prn: int,
    n: int,
    sample_rate_hz: float,
    amplitude: float,
    code_phase_chips: float,
    chips_per_s: float,
    carrier_phase_rad: float,
    rad_per_sample: float,
    data_bits: np.ndarray | None,
    first_bit_edge_s: float,
    complex_samples: bool,
    backend_override: str | None = None,
) -> np.ndarray:
    """The noise-free samples ``(n,)`` of `generate_if_samples` (complex, or real with the
    carrier's cosine): amplitude times the spreading waveform at the code phase
    ``code_phase_chips + chips_per_s t``, the overlay's chip of each primary period, the
    data symbol in force, and the carrier `carrier_phasor`, at ``t = k / sample_rate_hz``.

    The NumPy lines are the reference; under the numba backend (`gnssframework.backend`)
    one compiled pass makes each sample from the same operations in the same order (a
    fifth to a seventh of the time: the reference makes a dozen arrays of ``n``), equal to the reference
    within a few units of roundoff (`tests/signal/test_if_samples.py`).
    """
    bits = None if data_bits is None else np.asarray(data_bits, float)
    overlay = signal.overlay(prn)
    table = signal.spreading_table(prn)
    if backend.compiled(backend_override):
        out = np.empty(n, complex if complex_samples else float)
        inner, outer = _phasor_tables(carrier_phase_rad, rad_per_sample, n)
        period = signal.symbol_period_s if signal.symbol_period_s is not None else 1.0
        _signal_kernel(
            out.view(np.float64),
            2 if complex_samples else 1,
            float(sample_rate_hz),
            float(amplitude),
            np.ascontiguousarray(table, dtype=float),
            int(signal.subchips_per_chip),
            float(code_phase_chips),
            float(chips_per_s),
            float(signal.code_length_chips),
            np.asarray(overlay if overlay else [], float),
            np.zeros(0) if bits is None else bits,
            float(first_bit_edge_s),
            float(period),
            inner,
            outer,
        )
        return out
    t = np.arange(n) / sample_rate_hz
    chips = code_phase_chips + chips_per_s * t
    sig = amplitude * signal.spreading_at(table, chips)
    if overlay:  # chip k of the overlay over primary period k (modulo its length)
        periods = np.floor(chips / signal.code_length_chips).astype(np.int64)
        sig = sig * np.asarray(overlay, float)[periods % len(overlay)]
    if bits is not None:
        sig = sig * bit_at(t, bits, first_bit_edge_s, signal.symbol_period_s, signal=signal)
    carrier = carrier_phasor(carrier_phase_rad, rad_per_sample, n)
    return sig * carrier if complex_samples else sig * carrier.real


@backend.jit
def _carried(remainder, step, size):
    """``(remainder + step) % size`` for a remainder in ``[0, size)`` and a small step,
    by additions."""
    remainder += step
    while remainder >= size:
        remainder -= size
    while remainder < 0:
        remainder += size
    return remainder


@backend.jit
def _signal_kernel(
    out,
    stride,
    fs,
    amplitude,
    table,
    subchips,
    chip0,
    chips_per_s,
    code_length,
    overlay,
    bits,
    first_edge,
    period,
    inner,
    outer,
):
    """`signal_samples`' compiled pass: sample k from the reference's operations, in its
    order, into ``out`` (real samples, ``stride`` 1) or its interleaved real and imaginary
    parts (complex samples viewed as float64, ``stride`` 2). The reference's floors are
    computed as there; their remainders (code table, overlay) are carried from sample to
    sample by additions, which equal the reference's ``%`` while the index steps by less
    than the table (any sample rate above the chip rate), without a division per sample."""
    n = out.shape[0] // stride
    block = inner.shape[0]
    size = table.shape[0]
    n_overlay = overlay.shape[0]
    n_bits = bits.shape[0]
    last = np.int64(np.floor(chip0 * subchips))
    r = last % size
    last_p = np.int64(np.floor(chip0 / code_length))
    rp = last_p % n_overlay if n_overlay > 0 else 0
    k = 0
    for m in range(outer.shape[0]):
        om = outer[m]
        for i in range(block):
            if k >= n:
                break
            t = k / fs
            chips = chip0 + chips_per_s * t
            idx = np.int64(np.floor(chips * subchips))
            r = _carried(r, idx - last, size)
            last = idx
            v = amplitude * table[r]
            if n_overlay > 0:
                p = np.int64(np.floor(chips / code_length))
                rp = _carried(rp, p - last_p, n_overlay)
                last_p = p
                v = v * overlay[rp]
            if n_bits > 0:
                j = np.int64(np.floor((t - first_edge) / period))
                v = v * bits[min(max(j, 0), n_bits - 1)]
            c = om * inner[i]
            out[stride * k] = v * c.real
            if stride == 2:
                out[stride * k + 1] = v * c.imag
            k += 1


#: Samples per block of `carrier_phasor`'s factorisation.
_PHASOR_BLOCK = 4096


def carrier_phasor(phase0_rad: float, rad_per_sample: float, n: int) -> np.ndarray:
    """$e^{j(\\theta_0 + \\omega k)}$ for samples $k = 0 \\ldots n-1$, as the product of two
    short tables: $e^{j(\\theta_0 + \\omega B m)}\\, e^{j\\omega i}$ with $k = Bm + i$
    ($B$ = 4096): exponentials of $B$ and $n/B$ values and one complex product per sample
    instead of $n$ exponentials (a third of a generated signal's time). Both forms round the
    phase to about $\\epsilon\\,|\\theta_0 + \\omega n|$; the product adds a few units of
    roundoff (`tests/signal/test_if_samples.py` holds the two together)."""
    if n <= 0:
        return np.zeros(0, complex)
    inner, outer = _phasor_tables(phase0_rad, rad_per_sample, n)
    return (outer[:, None] * inner[None, :]).reshape(-1)[:n]


def _phasor_tables(phase0_rad: float, rad_per_sample: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """`carrier_phasor`'s two tables: $e^{j\\omega i}$ for $i < B$ and $e^{j(\\theta_0 + \\omega B m)}$
    for the blocks that cover ``n`` samples (none for ``n`` = 0)."""
    b = min(_PHASOR_BLOCK, max(n, 1))
    inner = np.exp(1j * rad_per_sample * np.arange(b))
    outer = np.exp(1j * (phase0_rad + rad_per_sample * b * np.arange(-(-n // b))))
    return inner, outer


def correlate_if(
    signal: IfSignal,
    prn: int,
    code_phase_chips: np.ndarray,
    code_rate_hz: np.ndarray,
    carrier_freq_hz: np.ndarray,
    carrier_phase_rad: np.ndarray,
    coherent_time_s: float,
    start_sample: int = 0,
    early_late_spacing_chips: float = 1.0,
    extra_taps: dict[str, float] | None = None,
) -> Correlators:
    """Correlate ``coherent_time_s`` of samples with code and carrier NCO replicas.

    Parameters
    ----------
    signal
        From `generate_if_samples` or a recording wrapped in ``IfSignal`` (integer
        I/Q recordings as ``(n, 2)`` arrays); its ``spec`` makes the replica.
    prn
        Replica code.
    code_phase_chips, code_rate_hz, carrier_freq_hz, carrier_phase_rad
        Replica NCO states at ``start_sample`` (any batch shape, e.g. one per channel or
        per hypothesis). ``carrier_freq_hz`` is the full replica frequency (IF + Doppler).
    coherent_time_s
        Integration length.

    Returns
    -------
    Correlators
        Scaled to unit-variance I/Q noise, batch shape of the replica parameters.
    """
    x = signal.samples
    if np.issubdtype(x.dtype, np.integer):
        x = x[..., 0] + 1j * x[..., 1] if signal.is_complex else x.astype(float)
    n = int(round(coherent_time_s * signal.sample_rate_hz))
    if start_sample + n > x.shape[0]:
        raise ConfigError("start_sample", f"{start_sample} + {n} samples exceeds the {x.shape[0]} available")
    seg = x[start_sample : start_sample + n]
    t = np.arange(n) / signal.sample_rate_hz
    cp = np.asarray(code_phase_chips, float)[..., None]
    cr = np.asarray(code_rate_hz, float)[..., None]
    carrier = np.exp(
        -1j
        * (
            2 * np.pi * np.asarray(carrier_freq_hz, float)[..., None] * t
            + np.asarray(carrier_phase_rad, float)[..., None]
        )
    )
    baseband = seg * carrier  # (..., n)
    spec = signal.spec
    table = spec.spreading_table(prn)
    # Real samples carry half the amplitude in each of the two mixing products.
    norm = np.sqrt(n * signal.noise_std**2 * (1.0 if signal.is_complex else 0.5))
    taps = {}
    for name, offset in tap_offsets(early_late_spacing_chips, extra_taps).items():
        taps[name] = np.sum(baseband * spec.spreading_at(table, cp + offset + cr * t), axis=-1) / norm
    return Correlators(taps.pop("early"), taps.pop("prompt"), taps.pop("late"), extra=taps)
