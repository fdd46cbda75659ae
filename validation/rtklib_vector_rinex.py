"""RTKLIB on the RINEX file of a vector-tracking run.

    python validation/rtklib_vector_rinex.py [--duration 20] [--seed 7] [--out DIR]

The project's own LNAV recording (`tests/lnav_recordings.py`: five satellites of real
broadcast records, ``tests/data/07590920.05n``, seen from the station of ``07590920.05o``,
45 dB-Hz, no ionosphere and no troposphere) through `receive` with vector tracking: the
LNAV hand-over comes about 9 s in, and from then on the navigation filter closes every
channel. Its observables are written as RINEX 3.04 (`write_rinex_obs`). Checks, each a line
of the report (issue 41: the file used to keep only the channels not handed over):

- every epoch of the file after the hand-over lists all five satellites;
- RTKLIB's ``rnx2rtkp`` (Debian package ``rtklib``; single point, the options of
  `gps_sdr_sim_navigation.RTKLIB_OPTIONS` with Klobuchar off, as the signals have none)
  solves every epoch of the file, with five satellites after the hand-over;
- its positions are within 0.5 m of our least squares on the same observables with
  RTKLIB's error model (``weighting="rtklib"``) at every epoch;
- and within 0.5 m of the vector loop's own positions (``positions.csv``) from a second
  after the hand-over (the first second is the navigation filter's settling; its largest
  difference is printed).

Exits 1 when a check fails, 2 when ``rnx2rtkp`` is not on PATH (the check cannot run).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))  # the project's LNAV recording generator

from gps_sdr_sim_run import Checks  # noqa: E402
from lnav_recordings import NAV, TOW0, WEEK, _strongest, write_lnav_recording  # noqa: E402
from rtklib_loss_of_lock import match_epochs, rnx2rtkp  # noqa: E402

from gnssframework import registry  # noqa: E402
from gnssframework.navigation.ephemeris import read_rinex_nav  # noqa: E402
from gnssframework.receiver.channels import tracking_config  # noqa: E402
from gnssframework.receiver.frontend import open_recording  # noqa: E402
from gnssframework.receiver.navigation.fixes import solve_epochs  # noqa: E402
from gnssframework.receiver.navigation.receive import receive  # noqa: E402
from gnssframework.receiver.navigation.rinex_obs import write_rinex_obs  # noqa: E402
from gnssframework.receiver.navigation.vector_tracking import vector_config  # noqa: E402

RATE_HZ = 5.0
AIM_M = 0.5
SETTLE_S = 1.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=20.0, help="recording length (s; the hand-over is ~9 s in)")
    ap.add_argument("--seed", type=int, default=7, help="seed of the recording's noise")
    ap.add_argument("--out", type=Path, default=None, help="keep the recording and files here")
    args = ap.parse_args(argv)
    exe = shutil.which("rnx2rtkp")
    if exe is None:
        print("rnx2rtkp is not on PATH (Debian package rtklib): the check cannot run", file=sys.stderr)
        return 2
    check = Checks()
    with tempfile.TemporaryDirectory(prefix="gnssframework-rtklib-vector-") as tmp:
        work = args.out or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        nav = read_rinex_nav(NAV)
        sats = _strongest(nav, TOW0, 5)
        print(f"recording: {args.duration:g} s, PRNs {', '.join(s[1:] for s in sats.sv)}, 45 dB-Hz, vector tracking")
        path = write_lnav_recording(work / "vector.sigmf-data", sats, TOW0, args.duration, args.seed)
        result = receive(
            open_recording(path),
            registry.create("acquisition", "pcps"),
            tracking_config(),
            rate_hz=RATE_HZ,
            rinex=nav,
            ionosphere=False,
            reference_week=WEEK,
            vector=vector_config(solution_rate_hz=RATE_HZ),
        )
        handover = result.vector.handover_s
        obs = result.observables
        rinex_path = write_rinex_obs(work / "observations.rnx", obs, WEEK)
        rows = np.flatnonzero(np.isfinite(obs.pseudorange_m).any(axis=1))
        after = obs.sample_time_s[rows] > handover
        counts = np.isfinite(obs.pseudorange_m[rows]).sum(axis=1)
        check(
            after.sum() > 0 and bool(np.all(counts[after] == 5)),
            f"observations.rnx: {rows.size} epochs, {int(after.sum())} after the hand-over at {handover:.2f} s, "
            f"satellites per epoch after it {counts[after].min() if after.any() else 0}-"
            f"{counts[after].max() if after.any() else 0}",
        )

        tow, xyz, ns = rnx2rtkp(exe, rinex_path, NAV, work)
        ours = solve_epochs(obs, nav, ionosphere=False, reference_week=WEEK, weighting="rtklib")
        k, both = match_epochs(tow, ours.columns["tow_s"])
        late = ours.sample_time_s > handover
        check(
            tow.size == rows.size and bool(both.all()) and bool(np.all(ns[k[late]] == 5)),
            f"rnx2rtkp: {tow.size} solutions for the file's {rows.size} epochs, {int(both.sum())} of our "
            f"{len(ours)} epochs matched, satellites after the hand-over {ns[k[late]].min()}-{ns[k[late]].max()}",
        )
        d = np.linalg.norm(xyz[k[both]] - ours.ecef_m[both], axis=1)
        check(
            bool(d.max() <= AIM_M),
            f"rnx2rtkp against our least squares with RTKLIB's weighting: 3-D difference "
            f"max {d.max():.4f} m, RMS {np.sqrt(np.mean(d**2)):.4f} m over {d.size} epochs (aim: {AIM_M:g} m)",
        )

        # The vector loop's positions: rows at the solution epochs nearest each RINEX epoch.
        table = result.positions
        vec = table.sample_time_s > handover
        kv, near = match_epochs(tow, table.columns["tow_s"][vec], tol_s=0.02)
        dv = np.linalg.norm(xyz[kv[near]] - table.ecef_m[vec][near], axis=1)
        settled = table.sample_time_s[vec][near] > handover + SETTLE_S
        check(
            bool(settled.any() and dv[settled].max() <= AIM_M),
            f"rnx2rtkp against the vector loop's positions from {SETTLE_S:g} s after the hand-over: 3-D difference "
            f"max {dv[settled].max():.3f} m, RMS {np.sqrt(np.mean(dv[settled] ** 2)):.3f} m over "
            f"{int(settled.sum())} epochs (aim: {AIM_M:g} m); in the first {SETTLE_S:g} s (the filter settling) "
            f"max {dv[~settled].max() if (~settled).any() else float('nan'):.2f} m",
        )
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
