"""What the gps-sdr-sim validation scripts share: building and running gps-sdr-sim, its
log, the added noise, and the report's check lines.

gps-sdr-sim (an independent GPS L1 C/A generator) is built from
``../shared/tools/gps-sdr-sim`` (beside the repository) into a temporary folder and run
with every satellite at one fixed power (``-p 128``: no path loss, so each has the same
C/N0), 16-bit complex samples, for a static receiver at `LOCATION` or one on a circle
about it (`circle_truth`, a user motion file). Complex white noise is then added for the
chosen C/N0 (`add_noise`). `noisy_recording` does all of it; `Checks` prints each check
as a report line and gives the exit code.
"""

from __future__ import annotations

import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gnssframework.receiver.frontend.sigmf_meta import write_sigmf_meta

__all__ = [
    "SIM_DIR",
    "NAV",
    "LOCATION",
    "AMPLITUDE_LSB",
    "CIRCLE_RADIUS_M",
    "CIRCLE_SPEED_MPS",
    "SimRecording",
    "SimulatorError",
    "Checks",
    "circle_truth",
    "simulate",
    "parse_log",
    "add_noise",
    "noisy_recording",
    "exit_unavailable",
]

HERE = Path(__file__).resolve().parent
SIM_DIR = HERE.parent.parent / "shared" / "tools" / "gps-sdr-sim"
#: The RINEX navigation file gps-sdr-sim encodes.
NAV = SIM_DIR / "brdc0010.22n"
#: gps-sdr-sim's per-satellite amplitude with -b 16 and -p 128: its 250-level carrier
#: table times the gain 128, shifted right by 7 (gpssim.c, the sample loop).
AMPLITUDE_LSB = 250.0
#: Largest noise standard deviation (LSB) written as int16 (`add_noise`): 32767 / 6.4, about
#: 35 dB-Hz at 2.6 MHz (the lowest C/N0 that fitted unscaled); weaker files are scaled to it.
NOISE_SIGMA_MAX_LSB = 5120.0
#: The static receiver (latitude, longitude in degrees, height in metres).
LOCATION = (35.681298, 139.766247, 10.0)
#: The moving receiver: a horizontal circle about LOCATION (radius m, speed m/s).
CIRCLE_RADIUS_M, CIRCLE_SPEED_MPS = 100.0, 15.0


class SimulatorError(RuntimeError):
    """gps-sdr-sim could not be built or run (the scripts exit 2)."""


@dataclass(frozen=True)
class SimRecording:
    """A noisy gps-sdr-sim recording (SigMF, ci16_le) and what its log says: the GPS week
    and time of week of the first sample, and per PRN (azimuth, elevation, range, iono delay)."""

    path: Path
    week: int
    tow0_s: float
    satellites: dict[int, tuple[float, float, float, float]]


class Checks:
    """The report's check lines: ``checks(ok, text)`` prints ``ok`` or ``FAIL`` and the text."""

    def __init__(self) -> None:
        self.failures: list[str] = []

    def __call__(self, ok: bool, text: str) -> None:
        print(("  ok    " if ok else "  FAIL  ") + text)
        if not ok:
            self.failures.append(text)

    def summary(self) -> int:
        """Print PASS or the number of failed checks; the exit code (0 or 1)."""
        print("PASS" if not self.failures else f"FAIL: {len(self.failures)} check(s)")
        return 0 if not self.failures else 1


def circle_truth(t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ECEF positions ``(n, 3)`` and east-north-up velocities ``(n, 3)`` of the moving receiver."""
    import pymap3d

    w = CIRCLE_SPEED_MPS / CIRCLE_RADIUS_M
    t = np.asarray(t_s, float)
    e, n = CIRCLE_RADIUS_M * np.cos(w * t), CIRCLE_RADIUS_M * np.sin(w * t)
    xyz = np.stack(pymap3d.enu2ecef(e, n, np.zeros_like(t), *LOCATION), axis=-1)
    vel = np.stack([-CIRCLE_SPEED_MPS * np.sin(w * t), CIRCLE_SPEED_MPS * np.cos(w * t), np.zeros_like(t)], axis=-1)
    return xyz, vel


def simulate(work: Path, duration_s: float, fs: float, moving: bool = False) -> tuple[Path, str]:
    """Build gps-sdr-sim and simulate the static receiver at LOCATION or, ``moving``, the
    circle (a user motion file of ECEF positions at 10 Hz, gps-sdr-sim's ``-u``); the raw
    file and gps-sdr-sim's log."""
    binary = (
        subprocess.run([str(SIM_DIR / "build.sh"), str(work / "bin")], check=True, capture_output=True, text=True)
        .stdout.strip()
        .splitlines()[-1]
    )
    out = work / "sim.bin"
    if moving:
        t = np.arange(int(np.ceil(duration_s * 10)) + 2) / 10.0
        xyz, _ = circle_truth(t)
        motion = work / "circle.csv"
        motion.write_text("".join(f"{ti:.1f},{x:.4f},{y:.4f},{z:.4f}\n" for ti, (x, y, z) in zip(t, xyz)))
        where = ["-u", str(motion)]
    else:
        lat, lon, h = LOCATION
        where = ["-l", f"{lat},{lon},{h}"]
    run = subprocess.run(
        [
            binary,
            "-e",
            str(NAV),
            *where,
            "-d",
            f"{duration_s}",
            "-b",
            "16",
            "-s",
            f"{fs:.0f}",
            "-p",
            "128",
            "-o",
            str(out),
        ],
        check=True,
        capture_output=True,
        text=True,
        cwd=work,
    )
    return out, run.stderr


def parse_log(log: str) -> tuple[int, float, dict[int, tuple[float, float, float, float]]]:
    """GPS week, time of week at the start, and per PRN (azimuth, elevation, range, iono delay)."""
    m = re.search(r"Start time = .*\((\d+):([\d.]+)\)", log)
    if m is None:
        raise RuntimeError(f"no start time in gps-sdr-sim's output:\n{log}")
    sats = {}
    for line in log[m.end() :].splitlines():
        parts = line.split()
        if len(parts) == 5 and re.fullmatch(r"\d\d", parts[0]):
            sats[int(parts[0])] = tuple(float(p) for p in parts[1:])
    return int(m.group(1)), float(m.group(2)), sats


def add_noise(src: Path, dst: Path, cn0_dbhz: float, fs: float, rng: np.random.Generator) -> None:
    """Add complex white noise of the standard deviation that gives ``cn0_dbhz`` to every
    satellite of amplitude `AMPLITUDE_LSB`: a = sqrt(2 sigma^2 c / fs) (complex samples,
    the law of `gnssframework.signal.if_samples`), so sigma = a sqrt(fs / (2 c)). A block at
    a time (the same draws as one call), so a 40 s file never sits in memory as floats.

    Where sigma would exceed `NOISE_SIGMA_MAX_LSB` (below about 35 dB-Hz at 2.6 MHz) signal
    and noise are both scaled by ``NOISE_SIGMA_MAX_LSB / sigma`` before rounding to int16:
    the C/N0 is a ratio and does not change, the rounding adds 1/12 LSB² to a noise of
    ~2.6e7 LSB² (1e-8 dB), and the int16 range keeps its 6.4 standard deviations."""
    sigma = AMPLITUDE_LSB * np.sqrt(fs / (2 * 10 ** (cn0_dbhz / 10)))
    gain = min(1.0, NOISE_SIGMA_MAX_LSB / sigma)
    raw = np.memmap(src, dtype="<i2", mode="r")
    block = 1 << 23
    with open(dst, "wb") as out:
        for start in range(0, raw.size, block):
            noisy = raw[start : start + block] + sigma * rng.standard_normal(min(block, raw.size - start))
            if gain < 1.0:
                noisy *= gain
            if np.abs(noisy).max() > 32767:
                raise RuntimeError("noise clips int16: choose a higher C/N0")
            out.write(np.rint(noisy).astype("<i2").tobytes())
    write_sigmf_meta(
        dst.with_suffix(".sigmf-meta"),
        format="ci16_le",
        sigmf_datatype="ci16_le",
        sample_rate_hz=fs,
        if_hz=0.0,
        description=f"gps-sdr-sim at {cn0_dbhz} dB-Hz with added white noise",
    )


def noisy_recording(
    work: Path, duration_s: float, fs: float, cn0_dbhz: float, seed: int, moving: bool = False
) -> SimRecording:
    """gps-sdr-sim's recording with noise for ``cn0_dbhz`` drawn from ``seed``, as
    ``work/noisy.sigmf-data`` (the raw file is removed).

    Raises
    ------
    SimulatorError
        When gps-sdr-sim cannot be built or run (its message names ``SIM_DIR``).
    """
    try:
        sim, log = simulate(work, duration_s, fs, moving)
    except (subprocess.CalledProcessError, FileNotFoundError, OSError) as exc:
        raise SimulatorError(f"cannot build or run gps-sdr-sim from {SIM_DIR}: {exc}") from None
    week, tow0, sats = parse_log(log)
    path = work / "noisy.sigmf-data"
    add_noise(sim, path, cn0_dbhz, fs, np.random.default_rng(seed))
    sim.unlink()
    return SimRecording(path, week, tow0, sats)


def rinex_read_back(check, obs, path: Path, label: str) -> None:
    """Check that georinex reads the observation file written from ``obs`` back: every
    epoch with a pseudorange, and C1C within the file's 1 mm resolution of ``obs``."""
    import warnings

    import georinex

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        back = georinex.load(path)
    order = [list(back.sv.values).index(f"G{p:02d}") for p in obs.prn]
    epochs = [e for e in range(obs.rx_time_s.size) if np.isfinite(obs.pseudorange_m[e]).any()]
    diff = back["C1C"].values[:, order] - obs.pseudorange_m[epochs]
    check(
        back.time.size == len(epochs) and np.nanmax(np.abs(diff)) <= 0.0005 + 1e-9,
        f"{label}: {back.time.size} epochs of {len(obs.prn)} satellites read back by georinex, "
        f"C1C within {np.nanmax(np.abs(diff)) * 1e3:.2f} mm of the observables",
    )


def exit_unavailable(exc: SimulatorError) -> int:
    """Report a simulator that cannot run; the scripts' exit code for it (2)."""
    print(exc, file=sys.stderr)
    return 2
