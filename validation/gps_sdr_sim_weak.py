"""Weak signals: acquisition, scalar and vector tracking and positions at 35 dB-Hz and below on gps-sdr-sim.

    python validation/gps_sdr_sim_weak.py [--cn0 35 [32 30 ...]] [--duration 20] [--fs 2.6e6] [--seed 1]
                                          [--positions] [--moving] [--full-search] [--table rows.md]
                                          [--cold-start]

gps-sdr-sim (``../shared/tools/gps-sdr-sim``, as `gps_sdr_sim_navigation` runs it) simulates
the static receiver of `gps_sdr_sim_navigation` from ``brdc0010.22n`` (``--moving``: its
receiver on the 100 m circle at 15 m/s, the truth at each fix's time); complex white noise
is added for the chosen C/N0 (every satellite at it). Ephemerides come from the RINEX file
(``--ephemeris``). Reported, beside GNSS-SDR 0.0.17's figures quoted in issue 25 (at 35
dB-Hz: no fix at all, even with weak-signal settings):

- acquisition: satellites found by the default search (1 ms coherent, 8 non-coherent) and
  by 10 ms blocks summed by parity (``alternate_blocks``), each at the same false-alarm
  probability; the weak search's pairs of blocks from detection theory at the file's
  C/N0 (`weak_search_pairs`: detection probability 0.9 with the grid's worst straddle
  losses, at least the 4 pairs of 35 dB-Hz, at most 7: the search does not follow the
  code Doppler); checked: the weak search finds every simulated satellite and nothing else
  (where the pairs are capped: at least four and nothing else, enough for the assisted start,
  whose aided search finds the others);
- the assisted start's own search (`receiver.navigation.assisted_search`): only the
  satellites the approximate position, start time and RINEX file put above 5 deg, each
  within 500 Hz of its predicted Doppler over the whole code period, 10 ms blocks by parity
  with the code Doppler followed, as many pairs as detection theory asks at the file's
  C/N0 (`assisted_search_pairs`: Pd 0.9 with the worst straddle losses, 4 to 50 pairs);
  checked: at least four found and nothing that is not simulated. Below 35 dB-Hz the full
  sky searches above run only with ``--full-search`` (minutes of CPU);
- assisted vector tracking (``--tracking vector --approx-position --start-time``) on the
  assisted search's satellites: the
  navigation filter closes every channel from pull-in on, from an approximate position
  (30 km off: 0.3 deg of latitude) and the recording's start time (gps-sdr-sim's), no LNAV:
  satellites used, time to first fix, horizontal and vertical RMS error against
  gps-sdr-sim's position; checked: a fix with every healthy satellite acquired,
  horizontal RMS under 5 m and vertical under 10 m (below 35 dB-Hz these bounds, and the
  pseudorange spread's, times `noise_scale`: the code thermal noise's growth, 3.6 at 25
  dB-Hz) (gps-sdr-sim models no troposphere:
  none is applied; Klobuchar from the RINEX header, which gps-sdr-sim applies); the
  navigation filter ``ekf-pv`` at its default white acceleration (0.1 m²/s³) when static,
  at the circle's ``v³/R`` (34 m²/s³, as `gps_sdr_sim_navigation`) when moving;
- the assisted receiver's observables (no LNAV: each vector channel dated from its
  assisted transmit time, `receive.assisted_observables`): pseudorange minus gps-sdr-sim's
  (`sim_truth`) one common term per epoch, its spread under 3 m RMS from 2 s after the
  hand-over; written as RINEX 3.04 and read back by georinex to the millimetre; and, where
  ``rnx2rtkp`` is on PATH, RTKLIB's single-point solution on that file within 1 m of ours
  on the same observables (static and ``--moving``);
- with ``--positions`` (minutes of CPU: CI runs the checks above), the scalar receiver and the
  vector receiver that hands over at the scalar receiver's first fix (``--tracking vector``
  alone), on the same acquisition and file, reported the same way.

With ``--cold-start`` (issue 40): the unassisted receiver instead, as ``gnssframework receive
--weak`` runs it (no position, time or ephemeris: `cli.WEAK_SEARCH` over all 32 PRNs, then
`channels.weak_signal_tracking`, LNAV decoded, least-squares fixes), and the same with vector
tracking handed over at its first fix; checked: a fix using every acquired healthy
satellite when static (the vector loop admits a channel that locks after its hand-over),
four or more when moving (two channels there decode their ephemeris after a 42 s file's
end), horizontal RMS under 5 m and vertical under 10 m times `noise_scale`.
A first fix needs subframes 1-3 after bit synchronisation: about 37 s of recording from
gps-sdr-sim's start (``--duration 42`` in CI).

Several ``--cn0`` values run one after the other on one simulation (noise from the same
seed for each); ``--table`` appends one markdown row per C/N0 (receiver, motion, C/N0,
satellites acquired, first fix in recording time, fixes of the recording's whole seconds,
satellites used, H and V RMS, checks) to a file, the rows of the navigation page's table.
Below 35 dB-Hz the int16 file is scaled (`gps_sdr_sim_run.add_noise`): the C/N0 is a ratio.

Exits 1 when a check fails, 2 when gps-sdr-sim cannot be built or run.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import sim_truth  # noqa: E402
from gps_sdr_sim_navigation import header_klobuchar, rtklib_check  # noqa: E402
from gps_sdr_sim_run import (
    CIRCLE_RADIUS_M,
    CIRCLE_SPEED_MPS,
    LOCATION,
    NAV,
    SIM_DIR,
    Checks,
    add_noise,  # noqa: E402
    circle_truth,
    parse_log,
    rinex_read_back,
    simulate,
)

from gnssframework import registry  # noqa: E402
from gnssframework.navigation.ephemeris import read_rinex_nav  # noqa: E402
from gnssframework.navigation.lnav import IonoUtc  # noqa: E402
from gnssframework.receiver.acquisition.report import acquire_recording  # noqa: E402
from gnssframework.receiver.channels import tracking_config  # noqa: E402
from gnssframework.receiver.frontend import open_recording  # noqa: E402
from gnssframework.receiver.navigation.fixes import solve_epochs  # noqa: E402
from gnssframework.receiver.navigation.receive import position_errors, receive  # noqa: E402
from gnssframework.receiver.navigation.rinex_obs import write_rinex_obs  # noqa: E402
from gnssframework.receiver.navigation.assisted_search import assisted_search  # noqa: E402
from gnssframework.receiver.navigation.vector_tracking import assistance, vector_config  # noqa: E402

#: GNSS-SDR 0.0.17 on the same kind of file (issue 25): at 45 dB-Hz, and at 35 dB-Hz.
GNSS_SDR_45 = "6-8 satellites acquired, first fix 42-48 s, 4-5 used, horizontal RMS 3.4-10.9 m, vertical 7.7-25 m"
GNSS_SDR_35 = "no fix"


def truth_errors(table, moving: bool) -> tuple[np.ndarray, np.ndarray]:
    """East, north, up position errors ``(F, 3)`` and velocity errors ``(F, 3)`` of the
    fixes against gps-sdr-sim's receiver: the static point, or the circle at each fix's
    recording time (ENU at LOCATION's axes: 100 m away they turn by 3 arc seconds)."""
    import pymap3d

    vel = np.stack([table.columns[k] for k in ("vel_e_mps", "vel_n_mps", "vel_u_mps")], 1)
    if not moving:
        return position_errors(table, LOCATION), vel
    xyz, vel_truth = circle_truth(table.sample_time_s)
    d = table.ecef_m - xyz
    return np.stack(pymap3d.ecef2enuv(d[:, 0], d[:, 1], d[:, 2], *LOCATION[:2]), axis=-1), vel - vel_truth


def summary(name: str, table, healthy: list[int], moving: bool = False) -> tuple[str, float, float, bool]:
    """One line of the report, the H and V RMS errors and whether every healthy satellite was used."""
    if table is None or len(table) == 0:
        return f"{name}: no fix", np.inf, np.inf, False
    err, dvel = truth_errors(table, moving)
    h = float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1))))
    v = float(np.sqrt(np.mean(err[:, 2] ** 2)))
    speed = float(np.sqrt(np.mean(np.sum(dvel**2, axis=1))))
    n = table.columns["n_sats"]
    every = all(set(healthy) <= set(u) for u in table.used_prns)
    return (
        f"{name}: {len(table)} fixes, first {table.sample_time_s[0]:.1f} s into the recording, {n.min()}-{n.max()} "
        f"satellites (every healthy one: {every}), horizontal RMS {h:.2f} m, vertical RMS {v:.2f} m, velocity "
        f"error {speed:.2f} m/s RMS",
        h,
        v,
        every,
    )


def pseudorange_spread_m(
    obs, used_by_sim, sats: dict, tow0: float, moving: bool, from_s: float = 0.0
) -> tuple[float, float, int]:
    """RMS over the epochs from recording time ``from_s`` on of the spread over the satellites of pseudorange minus gps-sdr-sim's
    (`sim_truth`: its geometry, satellite clock and printed Klobuchar delay), the RMS of the
    common term (the receiver clock: zero for a start time that is gps-sdr-sim's) and the epochs."""
    import pymap3d

    static = np.array(pymap3d.geodetic2ecef(*LOCATION))
    ephs = {}
    for p in obs.prn:
        k = np.flatnonzero(used_by_sim.sv == f"G{int(p):02d}")
        ephs[int(p)] = {
            **{n: float(v[k[0]]) for n, v in used_by_sim.elements.items()},
            "toc_tow": float(used_by_sim.toc_s[k[0]]),
        }
    spread, common = [], []
    for e in range(obs.rx_time_s.size):
        ok = np.flatnonzero(np.isfinite(obs.pseudorange_m[e]))
        if ok.size < 2 or obs.sample_time_s[e] < from_s:
            continue
        receiver = circle_truth(obs.sample_time_s[e : e + 1])[0][0] if moving else static
        t_true = np.array([tow0 + obs.sample_time_s[e]])
        diff = [
            obs.pseudorange_m[e, j]
            - sim_truth.pseudorange_m(ephs[int(obs.prn[j])], receiver, t_true, sats[int(obs.prn[j])][3])[0][0]
            for j in ok
        ]
        spread.append(np.std(diff))
        common.append(np.mean(diff))

    def rms(x):
        return float(np.sqrt(np.mean(np.square(x)))) if x else np.inf

    return rms(spread), rms(common), len(spread)


def noise_scale(cn0_dbhz: float, T: float = 0.010) -> float:
    """Code thermal noise at ``cn0_dbhz`` over that at 35 dB-Hz (the checks' bounds are 35 dB-Hz's
    times this): the early-minus-late DLL's standard deviation grows as
    sqrt((1 + 1/(T C/N0)) / (C/N0)) (Kaplan & Hegarty, *Understanding GPS/GNSS*, 3rd ed., sec.
    8.7: thermal noise with its squaring loss), T the vector channels' 10 ms; 1 at and above 35."""

    def var(c):
        return (1 + 1 / (T * c)) / c

    c, c35 = 10 ** (min(cn0_dbhz, 35.0) / 10), 10**3.5
    return float(np.sqrt(var(c) / var(c35)))


def assisted_rinex(
    check, result, work: Path, rinex, used_by_sim, sats: dict, week: int, tow0: float, moving: bool, scale: float = 1.0
) -> None:
    """The assisted receiver's observables (no LNAV: dated from the assisted transmit times)
    against gps-sdr-sim's geometry, as observations.rnx read back by georinex, and rnx2rtkp's
    single-point solution on that file against ours on the same observables."""
    obs = result.observables
    if obs is None:
        check(False, "assisted observables: none (no vector channel dated)")
        return
    # From 2 s after the hand-over: the channels go over from pull-in a quarter chip off, which
    # the loop steers out in about 1.5 s (all epochs printed too).
    settled = result.vector.handover_s + 2.0
    for since in (0.0, settled):
        spread, common, n = pseudorange_spread_m(obs, used_by_sim, sats, tow0, moving, since)
        text = (
            f"assisted pseudoranges minus gps-sdr-sim's from {since:.1f} s: spread over the satellites {spread:.2f} "
            f"m RMS over {n} epochs, common term {common:.2f} m RMS (the receiver clock at the start time)"
        )
        if since == settled:
            check(spread < 3.0 * scale, text + f" (aim: under {3.0 * scale:.1f} m)")
        else:
            print("  --    " + text)
    path = write_rinex_obs(work / "observations.rnx", obs, week)
    rinex_read_back(check, obs, path, "assisted observations.rnx")
    ours = solve_epochs(obs, rinex, reference_week=week, elevation_weights=False)
    # Checked for the moving receiver too: the assisted receiver clock is the start time, so
    # RTKLIB's epochs (receive time less its clock estimate) are ours to nanoseconds.
    rtklib_check(check, path, ours, work, False)


def cold_start(args, cn0: float, check: Checks, rec_path: Path, healthy: list[int]) -> str:
    """The unassisted receiver of ``receive --weak`` on the file at ``cn0``, scalar and with
    vector tracking from its first fix; the scalar row of the table."""
    from gnssframework.cli import WEAK_SEARCH
    from gnssframework.receiver.channels import weak_signal_tracking

    before = len(check.failures)
    rec = open_recording(rec_path)
    acq = registry.create("acquisition", "pcps", **WEAK_SEARCH)
    t = time.perf_counter()
    results = acquire_recording(rec, acq)
    found = sorted(r.prn for r in results if r.detected)
    print(
        f"  cold start: the weak search (10 ms x {WEAK_SEARCH['noncoherent']}, by parity, code Doppler "
        f"followed) found {len(found)} {found} in {time.perf_counter() - t:.0f} s"
    )
    acquired_healthy = sorted(set(healthy) & set(found))
    motion = "moving" if args.moving else "static"
    row = f"| unassisted (--weak) | {motion} | {cn0:g} | {len(found)} of 32 searched | no fix | 0 | - | - | - |"
    accel_psd = CIRCLE_SPEED_MPS**3 / CIRCLE_RADIUS_M if args.moving else 0.1
    epochs = int(np.ceil(args.duration)) - 1
    k = noise_scale(cn0)
    for name, vector in (
        ("scalar", None),
        ("vector from the first fix", vector_config(nav_params={"accel_psd": accel_psd})),
    ):
        t = time.perf_counter()
        result = receive(rec, acq, weak_signal_tracking(), vector=vector, acquisitions=results)
        line, h, v, _ = summary(
            f"cold start, {name} ({time.perf_counter() - t:.0f} s wall)",
            result.positions,
            acquired_healthy,
            args.moving,
        )
        table = result.positions
        used = set().union(*map(set, table.used_prns)) if table is not None and len(table) else set()
        # Static: every acquired healthy satellite is used (the vector loop admits a channel that
        # locks after its hand-over, `vector_handover.admit_locked`). Moving: four or more, as
        # two channels there decode their ephemeris after a 42 s file's end.
        enough = len(used) >= 4 if args.moving else set(acquired_healthy) <= used
        check(
            table is not None and len(table) > 0 and enough and h < 5.0 * k and v < 10.0 * k,
            line + f" ({len(used & set(acquired_healthy))} of the {len(acquired_healthy)} acquired healthy satellites "
            f"used; aim: a fix on {'four or more' if args.moving else 'every one'}, under {5.0 * k:.1f} and "
            f"{10.0 * k:.1f} m)",
        )
        if vector is None and table is not None and len(table):
            row = table_row("unassisted (--weak)", motion, cn0, f"{len(found)} of 32 searched", table, epochs, h, v)
    return row + checks_cell(check, before)


def weak_search_pairs(cn0_dbhz: float, fs: float) -> tuple[int, str]:
    """Pairs of 10 ms blocks of the weak search at ``cn0_dbhz`` (`WEAK_PD`, `WEAK_PFA`; at
    least the 4 of 35 dB-Hz, at most `MAX_PAIRS`) and why, from detection theory
    (`threshold.blocks_for_detection`) with the grid's worst straddle losses: a code lag
    half a sample off (amplitude 1 - chips per sample / 2) and a Doppler a quarter bin
    off (amplitude sinc(1/4) at bins of 1/(2T))."""
    from gnssframework.receiver.acquisition.threshold import blocks_for_detection

    T = 0.010
    chips_per_sample = 1.023e6 / fs
    loss_db = -20 * np.log10(1 - chips_per_sample / 2) - 20 * np.log10(np.sinc(0.25))
    cells = (2 * int(5000 * 2 * T) + 1) * int(round(fs * T))  # +-5 kHz at 50 Hz, the lags of a block (as pcps)
    try:
        need = blocks_for_detection(cn0_dbhz, T, WEAK_PD, WEAK_PFA, cells, alternate=True, loss_db=loss_db)
    except Exception:  # noqa: BLE001 (beyond 100 blocks: the cap decides)
        need = 101
    pairs = min(max(need, 4), MAX_PAIRS)
    why = (
        f"theory: {need} pairs for Pd {WEAK_PD} at pfa {WEAK_PFA} over {cells} cells with {loss_db:.1f} dB of "
        f"straddle loss" + (f"; capped at {MAX_PAIRS} (code Doppler smear)" if need > MAX_PAIRS else "")
    )
    return pairs, why


def main(argv: list[str] | None = None) -> int:
    # Each line as it comes, off a terminal too: CI's lane log showed nothing for the cold
    # start's 10 minutes of search and tracking, block-buffered, until the script ended.
    sys.stdout.reconfigure(line_buffering=True)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--cn0",
        type=float,
        nargs="+",
        default=[35.0],
        help="C/N0 of every satellite (dB-Hz); several: one noisy file each from the same simulation",
    )
    ap.add_argument("--duration", type=float, default=20.0, help="seconds simulated")
    ap.add_argument("--fs", type=float, default=2.6e6, help="sample rate")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--positions", action="store_true", help="also track and position, scalar and vector")
    ap.add_argument(
        "--moving",
        action="store_true",
        help=f"a receiver on a {CIRCLE_RADIUS_M:.0f} m circle at {CIRCLE_SPEED_MPS:.0f} m/s, not static",
    )
    ap.add_argument(
        "--full-search",
        action="store_true",
        help="below 35 dB-Hz also the full sky searches (1 ms, and 10 ms blocks by parity; minutes)",
    )
    ap.add_argument("--table", type=Path, help="append the assisted receiver's row per C/N0 to this markdown file")
    ap.add_argument(
        "--cold-start",
        action="store_true",
        help="the unassisted receiver with the weak-signal settings (receive --weak), scalar and vector",
    )
    args = ap.parse_args(argv)
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        try:
            sim, log = simulate(work, args.duration, args.fs, args.moving)
        except (subprocess.CalledProcessError, FileNotFoundError, OSError) as exc:
            print(f"cannot build or run gps-sdr-sim from {SIM_DIR}: {exc}", file=sys.stderr)
            return 2
        week, tow0, sats = parse_log(log)
        rinex = read_rinex_nav(NAV)
        used_by_sim = rinex.select([f"G{p:02d}" for p in sats], tow0, healthy_only=False)
        healthy = sorted(p for p, h in zip(sats, used_by_sim.health) if h == 0)
        for cn0 in args.cn0:
            rec_path = work / "noisy.sigmf-data"
            add_noise(sim, rec_path, cn0, args.fs, np.random.default_rng(args.seed))
            if args.cold_start:
                row = cold_start(args, cn0, check, rec_path, healthy)
            else:
                row = run_one(args, cn0, check, work, rec_path, rinex, used_by_sim, sats, healthy, week, tow0)
            if args.table is not None:
                new = not args.table.exists()
                with open(args.table, "a") as fh:
                    if new:
                        fh.write(TABLE_HEADER)
                    fh.write(row + "\n")
        sim.unlink()
    return check.summary()


#: The weak search's aims: detection probability per satellite, false alarms per PRN's search.
WEAK_PD, WEAK_PFA = 0.9, 1e-3
#: Most pairs of 10 ms blocks: the search does not follow the code Doppler, which at 5 kHz
#: moves the code by 5000 / 1540 = 3.2 chips/s: half a chip in 154 ms, 7 pairs.
MAX_PAIRS = 7
#: Most pairs of the assisted search (which follows the code Doppler): one second of samples.
MAX_ASSISTED_PAIRS = 50
TABLE_HEADER = (
    "| receiver | motion | C/N0 (dB-Hz) | acquired (assisted search) | first fix (s) | fixes | satellites used "
    "| H RMS (m) | V RMS (m) | checks |\n|---|---|---|---|---|---|---|---|---|---|\n"
)


def assisted_search_pairs(cn0_dbhz: float, fs: float) -> tuple[int, str]:
    """Pairs of 10 ms blocks of the assisted start's search (`assisted_search`: a 500 Hz
    Doppler half width, the code Doppler followed) at ``cn0_dbhz``, as `weak_search_pairs`
    over its window's cells; at least 4, at most `MAX_ASSISTED_PAIRS`."""
    from gnssframework.receiver.acquisition.threshold import blocks_for_detection

    T = 0.010
    loss_db = -20 * np.log10(1 - 1.023e6 / fs / 2) - 20 * np.log10(np.sinc(0.25))
    cells = (2 * int(np.ceil(500 * 2 * T)) + 1) * int(round(fs * T))
    try:
        need = blocks_for_detection(cn0_dbhz, T, WEAK_PD, WEAK_PFA, cells, alternate=True, loss_db=loss_db)
    except Exception:  # noqa: BLE001 (beyond 100 blocks: the cap decides)
        need = 101
    pairs = min(max(need, 4), MAX_ASSISTED_PAIRS)
    return pairs, (
        f"theory: {need} pairs for Pd {WEAK_PD} at pfa {WEAK_PFA} per satellite over {cells} cells with "
        f"{loss_db:.1f} dB of straddle loss" + (f"; capped at {MAX_ASSISTED_PAIRS}" if need > pairs else "")
    )


def run_one(
    args,
    cn0: float,
    check: Checks,
    work: Path,
    rec_path: Path,
    rinex,
    used_by_sim,
    sats: dict,
    healthy: list[int],
    week: int,
    tow0: float,
) -> str:
    """Acquisition and the assisted receiver on the file at ``cn0``; its table row."""
    before = len(check.failures)
    print(
        f"gps-sdr-sim: week {week}, tow {tow0:.0f} s, {len(sats)} satellites {sorted(sats)} ({len(healthy)} "
        f"healthy), {args.duration} s at {args.fs:g} Hz, noise for {cn0} dB-Hz, "
        f"{'moving on a circle' if args.moving else 'static'}"
    )
    print(f"GNSS-SDR 0.0.17 (issue 25): at 45 dB-Hz {GNSS_SDR_45}; at 35 dB-Hz {GNSS_SDR_35}")
    rec = open_recording(rec_path)

    pairs, why = weak_search_pairs(cn0, args.fs)
    weak = registry.create(
        "acquisition", "pcps", coherent_ms=10, noncoherent=2 * pairs, alternate_blocks=True, pfa=WEAK_PFA
    )
    results: list = []
    found: list[int] = []
    if args.full_search or cn0 >= 35:
        default = registry.create("acquisition", "pcps")
        for name, acq in (
            ("default search (1 ms x 8)", default),
            (f"10 ms blocks by parity (2 x {pairs}; {why})", weak),
        ):
            t = time.perf_counter()
            results = acquire_recording(rec, acq)
            found = sorted(r.prn for r in results if r.detected)
            t = time.perf_counter() - t
            print(f"  acquisition, {name}: {len(found)} found {found} in {t:.1f} s")
        if "capped" not in why:
            check(found == sorted(sats), f"the weak search finds every simulated satellite and nothing else: {found}")
        else:  # fewer pairs than theory asks: four are enough to start, the aided search finds the others
            check(
                len(found) >= 4 and set(found) <= set(sats),
                f"the weak search finds at least four simulated satellites and nothing else: {found}",
            )
    motion = "moving" if args.moving else "static"

    alpha, beta = header_klobuchar(NAV)
    lat, lon, height = LOCATION
    assist = assistance((lat + 0.3, lon, height), week, tow0, IonoUtc(tuple(alpha), tuple(beta)))
    # The assisted start's own search: the satellites and Dopplers the assistance predicts.
    a_pairs, a_why = assisted_search_pairs(cn0, args.fs)
    t = time.perf_counter()
    a_results = assisted_search(rec, rinex, assist, 2 * a_pairs, pfa=WEAK_PFA)
    t = time.perf_counter() - t
    a_found = sorted(r.prn for r in a_results if r.detected)
    print(
        f"  assisted search ({len(a_results)} predicted satellites, 500 Hz about each predicted Doppler, 2 x "
        f"{a_pairs} blocks of 10 ms, code Doppler followed; {a_why}): {len(a_found)} found {a_found} in {t:.1f} s"
    )
    check(
        len(a_found) >= 4 and set(a_found) <= set(sats),
        f"the assisted search finds at least four simulated satellites and nothing else: {a_found}",
    )
    acquired = f"{len(set(a_found) & set(sats))} of {len(a_results)} predicted" + (
        f" (+{len(set(a_found) - set(sats))} false)" if set(a_found) - set(sats) else ""
    )
    # ekf-pv's white acceleration: its default for the static receiver; on the circle v³/R
    # (the centripetal acceleration as white noise, as gps_sdr_sim_navigation sets it).
    accel_psd = CIRCLE_SPEED_MPS**3 / CIRCLE_RADIUS_M if args.moving else 0.1
    vector = vector_config(nav_params={"accel_psd": accel_psd})
    print(
        f"  assistance: approximate position {lat + 0.3:.6f} {lon:.6f} {height:.1f} m (0.3 deg, 33 km, north "
        f"of the {'circle centre' if args.moving else 'receiver'}), start time week {week} tow {tow0:.3f} s "
        f"(gps-sdr-sim's first sample), Klobuchar from the RINEX header; ekf-pv accel_psd {accel_psd:g} m²/s³"
    )
    runs = [("assisted vector", vector, assist, a_results, a_found)]
    if args.positions and results:
        runs += [("scalar", None, None, results, found), ("vector from the scalar fix", vector, None, results, found)]
    row = f"| assisted vector | {motion} | {cn0:g} | {acquired} | no fix | 0 | - | - | - |"
    epochs = int(np.ceil(args.duration)) - 1  # whole seconds of the recording after its start
    for name, vector, helper, results, found in runs:
        if len(found) < 4:
            print(f"  {name}: not run (fewer than four satellites acquired)")
            continue
        t = time.perf_counter()
        result = receive(
            rec,
            weak,
            tracking_config(),
            rinex=rinex,
            reference_week=week,
            vector=vector,
            acquisitions=results,
            assist=helper,
        )
        t = time.perf_counter() - t
        acquired_healthy = sorted(set(healthy) & set(found))
        line, h, v, every = summary(
            f"{name} tracking ({t:.0f} s wall)", result.positions, acquired_healthy, args.moving
        )
        if result.vector is not None and result.vector.handover_s is not None:
            print(
                f"  {name}: the loop closed at {result.vector.handover_s:.2f} s on PRN "
                f"{', '.join(map(str, result.vector.prns))}"
            )
        if helper is None:
            print("  " + line)
            continue
        k = noise_scale(cn0)
        check(every and h < 5.0 * k and v < 10.0 * k, line + f" (aim: under {5.0 * k:.1f} and {10.0 * k:.1f} m)")
        assisted_rinex(check, result, work, rinex, used_by_sim, sats, week, tow0, args.moving, k)
        table = result.positions
        if table is not None and len(table):
            row = table_row("assisted vector", motion, cn0, acquired, table, epochs, h, v)
    return row + checks_cell(check, before)


def table_row(receiver: str, motion: str, cn0: float, acquired: str, table, epochs: int, h: float, v: float) -> str:
    """The table's row of a receiver with fixes, less its checks cell (`checks_cell`)."""
    n = table.columns["n_sats"]
    return (
        f"| {receiver} | {motion} | {cn0:g} | {acquired} | {table.sample_time_s[0]:.1f} | "
        f"{len(table)} of {epochs} | {n.min()}-{n.max()} | {h:.2f} | {v:.2f} |"
    )


def checks_cell(check: Checks, before: int) -> str:
    """The checks cell of a row: pass, or how many checks failed since ``before`` of them."""
    failed = len(check.failures) - before
    return " pass |" if failed == 0 else f" {failed} failed |"


if __name__ == "__main__":
    sys.exit(main())
