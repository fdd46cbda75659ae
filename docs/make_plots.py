"""Regenerate the documentation's figures into docs/img/.

    python docs/make_plots.py

Every figure is computed from the library (no hand-drawn curves), with a fixed seed.
"""

from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import gnssframework as gf  # noqa: E402
from gnssframework.receiver.tracking.jitter import loop_variance, pll_thermal_variance_rad2  # noqa: E402
from gnssframework.receiver.tracking.scalar import SignalTruth, run_closed_loop  # noqa: E402
from gnssframework.signal.correlator_model import (  # noqa: E402
    amplitude_from_cn0,
    code_autocorrelation,
    correlator_mean,
    simulate_correlators,
    tap_offsets,
)
from gnssframework.signal.galileo_e1 import GALILEO_E1C_BOC11  # noqa: E402
from gnssframework.signal.gps_l1ca import GPS_L1CA  # noqa: E402
from gnssframework.simulation import clock, impairments, scintillation  # noqa: E402

OUT = pathlib.Path(__file__).resolve().parent / "img"
T = 0.01


def _save(fig, name: str) -> None:
    fig.tight_layout()
    fig.savefig(OUT / name, dpi=90)
    plt.close(fig)


#: A signal of each modulation a discriminator may declare (`Discriminator.modulation`).
SIGNAL_OF_MODULATION = {"bpsk": GPS_L1CA, "boc11": GALILEO_E1C_BOC11}


def _signal_of(d):
    """The signal a discriminator's figures use: one of the modulation it is designed for
    (GPS L1 C/A for BPSK, Galileo E1-C's BOC(1,1) replica for the BOC discriminators)."""
    return SIGNAL_OF_MODULATION[d.modulation]


def _taps_of(d) -> dict[str, float]:
    """Tap offsets (chips) the discriminator reads: early, prompt, late at its own spacing
    (1 chip if it has none), and the extra taps it declares (`Discriminator.extra_taps`)."""
    return tap_offsets(getattr(d.params, "early_late_spacing_chips", 1.0), d.extra_taps())


def _noise_free(d, code=0.0, phase=0.0, freq=0.0, T=T):
    """Noise-free correlators at 45 dB-Hz for the taps and signal ``d`` reads."""
    taps = _taps_of(d)
    y = correlator_mean(
        amplitude_from_cn0(45.0, T), code, phase, freq, T, np.array(list(taps.values())), signal=_signal_of(d)
    )
    names = list(taps)
    extra = {n: y[..., i] for i, n in enumerate(names) if n not in ("early", "prompt", "late")}
    return gf.Correlators(
        y[..., names.index("early")], y[..., names.index("prompt")], y[..., names.index("late")], extra=extra
    )


def s_curve(name: str) -> None:
    """The S-curve of discriminator ``name`` (noise-free, 45 dB-Hz, T = 10 ms) into scurve-NAME.png."""
    d = gf.registry.create("discriminator", name, coherent_time_s=T)
    fig, ax = plt.subplots(figsize=(5, 3.2))
    if d.unit == "chips":
        e = np.linspace(-1.5, 1.5, 601)
        out = d(_noise_free(d, code=e))
    elif d.unit == "Hz":
        e = np.linspace(-1 / T, 1 / T, 601)
        out = d(_noise_free(d, phase=2 * np.pi * e * T, freq=e), previous=_noise_free(d, phase=0.0, freq=e))
    else:
        e = np.linspace(-np.pi, np.pi, 601)
        out = d(_noise_free(d, phase=e))
    ax.plot(e, out, label=name)
    ax.plot(e, e, "k:", lw=0.8, label="unit slope")
    ax.set_xlabel(f"true error ({d.unit})")
    ax.set_ylabel(f"output ({d.unit})")
    ax.set_ylim(np.min(out) * 1.3 - 1e-9, np.max(out) * 1.3 + 1e-9)
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(f"{name} ({_signal_of(d).name}): S-curve (T = {T * 1e3:.0f} ms)", fontsize=9)
    _save(fig, f"scurve-{name}.png")


def noise_curve(name: str, rng: np.random.Generator, draws: int = 20000) -> None:
    """The output noise of discriminator ``name`` against its formula (``noise_variance``),
    at T = 1 and 10 ms, on ``draws`` simulated intervals per C/N0, into noise-NAME.png."""
    cn0 = np.arange(25, 51, 2.5)
    fig, ax = plt.subplots(figsize=(5, 3.2))
    for Tc, style in ((0.001, "o"), (0.01, "s")):
        d = gf.registry.create("discriminator", name, coherent_time_s=Tc)
        taps = _taps_of(d)
        spacing = taps["late"] - taps["early"]
        extra = {n: o for n, o in taps.items() if n not in ("early", "prompt", "late")}
        mc = []
        for c in cn0:
            cur, prev = (
                simulate_correlators(
                    np.zeros(draws),
                    0.0,
                    0.0,
                    c,
                    Tc,
                    rng,
                    early_late_spacing_chips=spacing,
                    extra_taps=extra,
                    signal=_signal_of(d),
                )
                for _ in range(2)
            )
            mc.append(np.std(d(cur, previous=prev)))
        ax.semilogy(cn0, np.sqrt(d.noise_variance(cn0)), "-", label=f"formula, T = {Tc * 1e3:.0f} ms")
        ax.semilogy(cn0, mc, style, label=f"Monte Carlo, T = {Tc * 1e3:.0f} ms")
    ax.set_xlabel("C/N0 (dB-Hz)")
    ax.set_ylabel(f"output std ({d.unit})")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    ax.set_title(f"{name}: thermal noise")
    _save(fig, f"noise-{name}.png")


def autocorrelation() -> None:
    tau = np.linspace(-1.5, 1.5, 601)
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.plot(tau, code_autocorrelation(tau), label="infinite bandwidth")
    for bw in (4.092e6, 2.046e6):
        ax.plot(tau, code_autocorrelation(tau, bandwidth_hz=bw), label=f"{bw / 1e6:.3f} MHz front end")
    ax.set_xlabel("lag (chips)")
    ax.set_ylabel("R")
    ax.grid(alpha=0.3)
    ax.legend()
    _save(fig, "autocorrelation.png")


def loops(rng: np.random.Generator) -> None:
    cn0 = np.array([35.0, 40.0, 45.0, 50.0])
    mc_pll, mc_dll = [], []
    for c in cn0:
        truth = SignalTruth.from_dynamics(3.0, 0.001, c, doppler_hz=np.full(32, 500.0))
        loop = gf.registry.create("channel_filter", "scalar", pll_bandwidth_hz=10.0, pll_order=2, fll_bandwidth_hz=0.0)
        rec = run_closed_loop(loop, truth, rng, initial_doppler_hz=500.0)
        mc_pll.append(np.std((rec.phase_error_rad[1000:] + np.pi / 2) % np.pi - np.pi / 2))
        mc_dll.append(np.std(rec.code_error_chips[1000:]))
    disc = gf.registry.create("discriminator", "eml-envelope", coherent_time_s=0.001)
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
    axes[0].semilogy(cn0, np.degrees(np.sqrt(pll_thermal_variance_rad2(cn0, 10.0, 0.001))), "-", label="formula")
    axes[0].semilogy(cn0, np.degrees(mc_pll), "o", label="closed loop")
    axes[0].set_title("PLL, B = 10 Hz, T = 1 ms")
    axes[0].set_ylabel("phase jitter (deg)")
    axes[1].semilogy(cn0, np.sqrt(loop_variance(disc.noise_variance(cn0), 1.0, 0.001)), "-", label="formula")
    axes[1].semilogy(cn0, mc_dll, "o", label="closed loop")
    axes[1].set_title("DLL (eml-envelope), B = 1 Hz")
    axes[1].set_ylabel("code jitter (chips)")
    for ax in axes:
        ax.set_xlabel("C/N0 (dB-Hz)")
        ax.grid(alpha=0.3, which="both")
        ax.legend()
    _save(fig, "loop-jitter.png")


def scintillation_plots(rng: np.random.Generator) -> None:
    fs = 50.0
    t = np.arange(int(60 * fs)) / fs
    fig, axes = plt.subplots(2, 1, figsize=(7, 4.2), sharex=True)
    for s4 in (0.5, 0.9):
        z = scintillation.cornell(s4, 0.8, 60.0, fs, rng)
        axes[0].plot(t, 10 * np.log10(np.abs(z) ** 2), lw=0.7, label=f"Cornell S4 = {s4}")
        z = scintillation.aj_stanford(s4, 0.1, 60.0, fs, rng)
        axes[1].plot(t, 10 * np.log10(np.abs(z) ** 2), lw=0.7, label=f"AJ-Stanford S4 = {s4}")
    for ax in axes:
        ax.set_ylabel("intensity (dB)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[1].set_xlabel("time (s)")
    _save(fig, "scintillation.png")


def multipath_envelope() -> None:
    disc = gf.registry.create("discriminator", "eml-envelope", early_late_spacing_chips=1.0)
    A = amplitude_from_cn0(45.0, 0.001)
    delays = np.linspace(0.0, 1.6, 81)
    fig, ax = plt.subplots(figsize=(5, 3.2))
    from scipy import optimize

    for phase, label in ((0.0, "in phase"), (np.pi, "anti-phase")):
        err = []
        for dl in delays:

            def out(e, dl=dl, phase=phase):
                y = impairments.multipath_correlator_mean(
                    A, e, 0.0, 0.0, 0.001, np.array([-0.5, 0, 0.5]), 0.5, dl, phase
                )
                return float(disc(gf.Correlators(y[0], y[1], y[2])))

            err.append(optimize.brentq(out, -0.45, 0.45))
        ax.plot(delays, err, label=label)
    ax.set_xlabel("reflection delay (chips)")
    ax.set_ylabel("DLL bias (chips)")
    ax.set_title("eml-envelope, D = 1 chip, alpha = 0.5")
    ax.grid(alpha=0.3)
    ax.legend()
    _save(fig, "multipath-envelope.png")


def clock_adev(rng: np.random.Generator) -> None:
    import allantools

    taus = np.logspace(-1, 2, 13)
    fig, ax = plt.subplots(figsize=(5, 3.2))
    for name, model in clock.PRESETS.items():
        bias, _ = model.simulate(200_000, 0.01, rng)
        t2, ad, _, _ = allantools.oadev(bias, rate=100.0, data_type="phase", taus=taus)
        ax.loglog(t2, ad, "o", label=f"{name} simulated")
        ax.loglog(taus, np.sqrt(model.allan_variance(taus)), "-", label=f"{name} h-parameters")
    ax.set_xlabel("tau (s)")
    ax.set_ylabel("Allan deviation")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    _save(fig, "clock-adev.png")


def main() -> None:
    OUT.mkdir(exist_ok=True)
    rng = np.random.default_rng(2026)
    for name in gf.registry.names("discriminator"):
        s_curve(name)
        noise_curve(name, rng)
    autocorrelation()
    loops(rng)
    scintillation_plots(rng)
    multipath_envelope()
    clock_adev(rng)
    print(f"figures written to {OUT}")


if __name__ == "__main__":
    main()
