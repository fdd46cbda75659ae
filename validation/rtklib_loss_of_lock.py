"""RTKLIB on a RINEX file of ours whose loss-of-lock indicators are set.

    python validation/rtklib_loss_of_lock.py [--duration 24] [--blank 12 14] [--seed 77] [--out DIR]

The project's own LNAV recording (`tests/lnav_recordings.py`: five satellites of real
broadcast records, ``tests/data/07590920.05n``, seen from the station of
``07590920.05o``, 45 dB-Hz, complex int16 at 2.046 MHz, no ionosphere and no
troposphere) with one satellite blanked over ``--blank`` seconds: the receiver
(`receive`, ephemerides from the navigation file) loses it, re-acquires it and flags its
return in the observables, and `write_rinex_obs` writes them as RINEX 3.04. Checks, each
a line of the report:

- the file carries the flags (read back by georinex, an independent reader): the blanked
  satellite's carrier phase has bit 0 (lock lost) on exactly one epoch, its first after
  the gap, and bit 1 (half cycle unresolved) from there until its new run's preamble; no
  other satellite has a flag;
- RTKLIB's ``rnx2rtkp`` (Debian package ``rtklib``) reads the file: a single-point
  solution (the options of `gps_sdr_sim_navigation.RTKLIB_OPTIONS` with its Klobuchar
  switched off, as the signals have none) at every epoch we solve, the flagged ones
  included, with the same number of satellites as ours at each (the returned satellite's
  pseudorange is used, its flags notwithstanding: they concern the phase);
- its positions are within 1 m of ours (least squares on the same observables and
  navigation file, equal weights as RTKLIB's) at every epoch, and at the flagged ones.

Exits 1 when a check fails, 2 when ``rnx2rtkp`` is not on PATH (the check cannot run).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))  # the project's LNAV recording generator

from gps_sdr_sim_navigation import RTKLIB_OPTIONS  # noqa: E402
from gps_sdr_sim_run import Checks  # noqa: E402
from lnav_recordings import NAV, TOW0, WEEK, _strongest, write_lnav_recording  # noqa: E402

from gnssframework import registry  # noqa: E402
from gnssframework.navigation.ephemeris import read_rinex_nav  # noqa: E402
from gnssframework.receiver.channels import tracking_config  # noqa: E402
from gnssframework.receiver.frontend import open_recording  # noqa: E402
from gnssframework.receiver.navigation.fixes import solve_epochs  # noqa: E402
from gnssframework.receiver.navigation.observables import LLI_HALF_CYCLE, LLI_LOST_LOCK  # noqa: E402
from gnssframework.receiver.navigation.receive import receive  # noqa: E402
from gnssframework.receiver.navigation.rinex_obs import write_rinex_obs  # noqa: E402

#: The signals carry no ionospheric delay: RTKLIB's Klobuchar (from the file's header) off.
OPTIONS = {**RTKLIB_OPTIONS, "pos1-ionoopt": "off"}
BLANKED = 2  # index of the blanked satellite among the five
RATE_HZ = 1.0
AIM_M = 1.0


def parse_pos(text: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GPS times of week ``(n,)``, ECEF positions ``(n, 3)`` and satellite counts ``(n,)``
    of an rnx2rtkp solution file written with ``out-solformat=xyz`` and
    ``out-timeform=tow`` (rows ``week tow x y z Q ns sdx ...``; ``%`` lines are comments).

    Examples
    --------
    >>> tow, xyz, ns = parse_pos("% header\\n1316 518712.000 -3976219.1 3382372.2 3652512.3 5 5 1 1 1\\n")
    >>> tow.tolist(), xyz.tolist(), ns.tolist()
    ([518712.0], [[-3976219.1, 3382372.2, 3652512.3]], [5])
    """
    rows = [line.split() for line in text.splitlines() if line.strip() and not line.startswith("%")]
    tow = np.array([float(r[1]) for r in rows])
    xyz = np.array([[float(v) for v in r[2:5]] for r in rows]).reshape(-1, 3)
    return tow, xyz, np.array([int(r[6]) for r in rows], int)


def match_epochs(theirs_s: np.ndarray, ours_s: np.ndarray, tol_s: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``ours_s``, the index of the nearest of ``theirs_s`` (sorted) and whether
    it is within ``tol_s``.

    Examples
    --------
    >>> k, ok = match_epochs(np.array([1.0, 2.0, 3.0]), np.array([2.0004, 2.5, 9.0]))
    >>> k.tolist(), ok.tolist()
    ([1, 1, 2], [True, False, False])
    """
    if theirs_s.size == 0:
        return np.zeros(ours_s.size, int), np.zeros(ours_s.size, bool)
    k = np.searchsorted(theirs_s, ours_s).clip(1, max(theirs_s.size - 1, 1))
    k = np.where(np.abs(theirs_s[k - 1] - ours_s) <= np.abs(theirs_s[k] - ours_s), k - 1, k).clip(0, theirs_s.size - 1)
    return k, np.abs(theirs_s[k] - ours_s) < tol_s


def rnx2rtkp(exe: str, obs_path: Path, nav_path: Path, work: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """rnx2rtkp's single-point solution with `OPTIONS` (`parse_pos`'s arrays)."""
    conf, out = work / "spp.conf", work / "rtklib.pos"
    conf.write_text("".join(f"{k:<18}={v}\n" for k, v in OPTIONS.items()))
    subprocess.run(
        [exe, "-k", str(conf), "-o", str(out), str(obs_path), str(nav_path)], check=True, capture_output=True, text=True
    )
    return parse_pos(out.read_text())


def rtklib_slips(exe: str, obs_path: Path, nav_path: Path, work: Path) -> dict[int, int]:
    """Per PRN, the epochs on which RTKLIB's kinematic PPP (``ppp-kine``, the carrier
    phase's user) declares a cycle slip from the loss-of-lock indicator: its trace (level
    3) logs ``detslp_ll: slip detected sat=N`` for each observation whose LLI has bit 0
    or 1 set (RTKLIB ppp.c, ``detslp_ll``)."""
    conf, out = work / "ppp.conf", work / "ppp.pos"
    conf.write_text("".join(f"{k:<18}={v}\n" for k, v in {**OPTIONS, "pos1-posmode": "ppp-kine"}.items()))
    subprocess.run(
        [exe, "-k", str(conf), "-x", "3", "-o", str(out), str(obs_path), str(nav_path)],
        check=True,
        capture_output=True,
        text=True,
    )
    return count_slips(out.with_name(out.name + ".trace").read_text())


def count_slips(trace: str) -> dict[int, int]:
    """Per satellite number, the ``detslp_ll: slip detected`` lines of an RTKLIB trace.

    Examples
    --------
    >>> count_slips("3 detslp_ll: n=5\\n3 detslp_ll: slip detected sat=20 f=1\\n3 detslp_ll: slip detected sat= 7 f=1\\n"
    ...             "3 detslp_ll: slip detected sat=20 f=1\\n")
    {7: 1, 20: 2}
    """
    found = [int(v) for v in re.findall(r"detslp_ll: slip detected sat=\s*(\d+)", trace)]
    return {v: found.count(v) for v in sorted(set(found))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=24.0, help="recording length (s)")
    ap.add_argument(
        "--blank",
        type=float,
        nargs=2,
        default=(12.0, 14.0),
        metavar=("START", "END"),
        help="interval (s) without the blanked satellite's signal (after the first epochs with it, 10 s in)",
    )
    ap.add_argument("--seed", type=int, default=77, help="seed of the recording's noise")
    ap.add_argument("--out", type=Path, default=None, help="keep the recording and files here")
    args = ap.parse_args(argv)
    exe = shutil.which("rnx2rtkp")
    if exe is None:
        print("rnx2rtkp is not on PATH (Debian package rtklib): the check cannot run", file=sys.stderr)
        return 2
    if not 10.0 < args.blank[0] < args.blank[1] < args.duration - 3.0:
        print(
            f"--blank must lie between 10 s (after the first fix, 8.6 s in, and an epoch with the satellite) and 3 s before the end; got {args.blank}",
            file=sys.stderr,
        )
        return 2
    check = Checks()
    with tempfile.TemporaryDirectory(prefix="gnssframework-rtklib-lli-") as tmp:
        work = args.out or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        nav = read_rinex_nav(NAV)
        sats = _strongest(nav, TOW0, 5)
        prn = int(sats.sv[BLANKED][1:])
        print(
            f"recording: {args.duration:g} s, PRNs {', '.join(s[1:] for s in sats.sv)}, PRN {prn} blanked "
            f"{args.blank[0]:g}-{args.blank[1]:g} s"
        )
        path = write_lnav_recording(
            work / "blanked.sigmf-data", sats, TOW0, args.duration, args.seed, blank=(BLANKED, *args.blank)
        )
        result = receive(
            open_recording(path),
            registry.create("acquisition", "pcps"),
            tracking_config(),
            rate_hz=RATE_HZ,
            rinex=nav,
            ionosphere=False,
            reference_week=WEEK,
        )
        obs = result.observables
        rinex_path = write_rinex_obs(work / "observations.rnx", obs, WEEK)

        # 1. The flags, as an independent reader sees them.
        import georinex

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            data = georinex.load(rinex_path, useindicators=True)
        lli = np.nan_to_num(data["L1Clli"].values, nan=0.0).astype(int)
        sv = list(data.sv.values)
        j = sv.index(f"G{prn:02d}")
        lost = np.flatnonzero(lli[:, j] & LLI_LOST_LOCK)
        half = np.flatnonzero(lli[:, j] & LLI_HALF_CYCLE)
        others = int(np.count_nonzero(np.delete(lli, j, axis=1)))
        flags = np.union1d(lost, half)  # the flagged epochs of the file
        check(
            lost.size == 1 and half.size >= 1 and half[0] == lost[0] and np.all(np.diff(half) == 1) and others == 0,
            f"observations.rnx (georinex): PRN {prn} lost-lock bit on {lost.size} epoch(s), half-cycle bit on "
            f"{half.size} consecutive epoch(s) from it, {others} flags on the other satellites",
        )
        slips = rtklib_slips(exe, rinex_path, NAV, work)
        check(
            slips == {prn: flags.size},
            f"RTKLIB reads the flags: its kinematic PPP declares slips from them "
            f"(detslp_ll) on {slips.get(prn, 0)} epochs of PRN {prn} (flagged: {flags.size}) and "
            f"{sum(v for p, v in slips.items() if p != prn)} of the others",
        )

        # 2-3. RTKLIB on the file, against our least squares on the same observables.
        ours = solve_epochs(obs, nav, ionosphere=False, reference_week=WEEK, elevation_weights=False)
        tow, xyz, ns = rnx2rtkp(exe, rinex_path, NAV, work)
        k, both = match_epochs(tow, ours.columns["tow_s"])
        # The file's epochs are the observables' rows with a pseudorange (`write_rinex_obs`).
        rows = np.flatnonzero(np.isfinite(obs.pseudorange_m).any(axis=1))
        flagged = obs.sample_time_s[rows[flags]] if rows.size == data.time.size else np.zeros(0)
        at_flag = np.isin(np.round(ours.sample_time_s, 6), np.round(flagged, 6))
        n_ours = ours.columns["n_sats"]
        where = f" ({flagged.min():.1f}-{flagged.max():.1f} s into the recording)" if flagged.size else ""
        check(
            bool(both.all()) and at_flag.sum() == flagged.size > 0 and np.array_equal(ns[k[both]], n_ours[both]),
            f"rnx2rtkp: solutions at {int(both.sum())} of our {len(ours)} epochs, {int((both & at_flag).sum())} "
            f"of the {flagged.size} flagged ones{where}, the same satellite count as ours at every one "
            f"({n_ours.min()}-{n_ours.max()})",
        )
        if both.any():
            d = np.linalg.norm(xyz[k[both]] - ours.ecef_m[both], axis=1)
            d_flag = d[at_flag[both]]
            check(
                bool(d.max() <= AIM_M) and d_flag.size > 0,
                f"rnx2rtkp single point against ours (equal weights): 3-D difference max {d.max():.3f} m, RMS "
                f"{np.sqrt(np.mean(d**2)):.3f} m over {d.size} epochs; at the flagged epochs max "
                f"{d_flag.max() if d_flag.size else float('nan'):.3f} m (aim: within {AIM_M:g} m)",
            )
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
