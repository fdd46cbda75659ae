"""RTKLIB's SBAS single-point solution on an SBAS stream and observations of ours.

    python validation/sbas_rtklib.py [--out DIR] [--store]

A scenario whose truth is known (`tests/data/07590920.05n`'s broadcast orbits, seen from
GEONET 0759's station of ``07590920.05o``, 2 April 2005 00:30-00:34:30 GPST, ten epochs 30 s
apart, satellites above 10°):

- each satellite's true orbit is the broadcast one plus an offset (up to 8 m an axis) and
  its clock the broadcast one plus a slow and a fast offset (up to 10 m and 5 m); the
  ionosphere is a plane of vertical delay over the pierce points, 1.9-4.1 m
  (``3 + 0.025 (lat - 35) - 0.025 (lon - 140)`` m, degrees); the troposphere is DO-229's
  MOPS model; the pseudoranges (RINEX 3.04, `io.rinex.write_rinex3_obs`) carry all of it,
  a receiver clock of 100 µs and no noise;
- an SBAS stream of GEO PRN 137 written by `navigation.sbas_encode` carries exactly those
  errors (each a multiple of its field's LSB): the mask, fast corrections every 6 s, the
  long-term corrections (velocity code 0), the IGP masks of bands 7 and 8 (15-55° N,
  110-170° E) and their delays, one message a second from 120 s before the first epoch,
  written as RTKLIB's SBAS log (`navigation.sbas_files.write_rtklib_sbs`).

Checks, each a line of the report:

- RTKLIB's ``rnx2rtkp`` (Debian package ``rtklib``; ``pos1-sateph=brdc+sbas``,
  ``pos1-ionoopt=sbas``, ``pos1-tropopt=sbas``, 5° mask) decodes the stream itself and
  solves every epoch with every satellite, within 1 cm of the truth;
- our `sbas_pvt.solve_position_sbas` on the same files (read back by georinex and
  `sbas_files.read_sbas_messages`; no range-rate term, which RTKLIB does not apply by
  default) lands within 1 cm of the truth and of RTKLIB at every epoch;
- without SBAS (broadcast orbits and clocks, Klobuchar off, Saastamoinen) our fix is metres
  off: the corrections are what both solutions use.

``--store`` copies the three files (``sbas_sim_0759.rnx``, ``.sbs``, ``.rtklib.pos``) into
``tests/data`` for `tests/navigation/test_sbas_rtklib.py`. Exits 1 when a check fails, 2 when
``rnx2rtkp`` is not on PATH (the check cannot run).
"""

from __future__ import annotations

import argparse
import datetime as dt
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pymap3d

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))  # the tests' SBAS stream writer
from gps_sdr_sim_run import Checks  # noqa: E402
from rtklib_loss_of_lock import parse_pos  # noqa: E402
from sbas_streams import sbas_stream, vertical_delay_m  # noqa: E402

from gnssframework.io.rinex import write_rinex3_obs  # noqa: E402
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state, single_frequency_clock_s  # noqa: E402
from gnssframework.navigation.sbas_files import SbasRecord, write_rtklib_sbs  # noqa: E402
from gnssframework.navigation.sbas_iono import mops_troposphere, sbas_pierce_point  # noqa: E402
from gnssframework.receiver.navigation.sbas_fixes import day_of_year  # noqa: E402

DATA = HERE.parent / "tests" / "data"
NAV = DATA / "07590920.05n"
RECEIVER = np.array([-3976219.5082, 3382372.5671, 3652512.9849])  # 07590920.05o's header
WEEK, TOW0, N_EPOCHS, STEP_S = 1316, 6 * 86_400.0 + 1800.0, 10, 30.0
START = dt.datetime(2005, 4, 2, 0, 30)
GEO_PRN = 137
CLOCK_RX_S = 1e-4
C = 299_792_458.0
OMEGA_E = 7.2921151467e-5
RTKLIB_OPTIONS = {
    "pos1-posmode": "single",
    "pos1-navsys": "1",
    "pos1-elmask": "5",
    "pos1-sateph": "brdc+sbas",
    "pos1-ionoopt": "sbas",
    "pos1-tropopt": "sbas",
    "pos1-sbassatsel": "0",
    "pos1-posopt5": "off",
    "out-solformat": "xyz",
    "out-timesys": "gpst",
    "out-timeform": "tow",
    "out-timendec": "3",
}
AIM_M = 0.01


def scenario():
    """Records, injected errors and the IGPs of the scenario (module text)."""
    eph_all = read_rinex_nav(NAV, "G")
    eph = eph_all.select(sorted(set(eph_all.sv.tolist())), TOW0)
    lat, lon, h = pymap3d.ecef2geodetic(*RECEIVER)
    _, el, _ = pymap3d.ecef2aer(*satellite_state(eph, TOW0).position_m.T, lat, lon, h)
    eph = eph.subset(np.flatnonzero(el > 10.0))
    n = eph.sv.size
    rng = np.random.default_rng(2005)
    errors = {
        "dpos_m": 0.125 * rng.integers(-64, 65, (n, 3)),
        "dclock_s": 2.0**-31 * rng.integers(-71, 72, n),
        "fast_m": 0.125 * rng.integers(-40, 41, n),
    }
    return eph, errors


def pseudoranges(eph, errors) -> np.ndarray:
    """``(epochs, S)`` C1 (m) at receiver-clock times ``TOW0 + k STEP_S`` (module text)."""
    lat, lon, h = pymap3d.ecef2geodetic(*RECEIVER)
    out = []
    for k in range(N_EPOCHS):
        t_rx = TOW0 + k * STEP_S - CLOCK_RX_S  # GPS time of reception
        tau = np.full(eph.sv.size, 0.075)
        for _ in range(8):
            p = satellite_state(eph, t_rx - tau).position_m + errors["dpos_m"]
            th = OMEGA_E * tau
            rot = np.column_stack(
                [np.cos(th) * p[:, 0] + np.sin(th) * p[:, 1], -np.sin(th) * p[:, 0] + np.cos(th) * p[:, 1], p[:, 2]]
            )
            tau = np.linalg.norm(rot - RECEIVER, axis=1) / C
        st = satellite_state(eph, t_rx - tau)
        clock_s = single_frequency_clock_s(eph, st, 1575.42e6) + errors["dclock_s"] + errors["fast_m"] / C
        az, el, _ = (np.asarray(v) for v in pymap3d.ecef2aer(*rot.T, lat, lon, h))
        lat_pp, lon_pp, slant = sbas_pierce_point(lat, lon, az, el)
        iono = slant * vertical_delay_m(lat_pp, lon_pp)
        tropo, _ = mops_troposphere(lat, h, el, day_of_year(WEEK, t_rx))
        out.append(C * (tau + CLOCK_RX_S - clock_s) + iono + tropo)
    return np.array(out)


def stream(eph, errors) -> list[SbasRecord]:
    """One message a second from 120 s before the first epoch to the last (module text)."""
    last = TOW0 + (N_EPOCHS - 1) * STEP_S
    return sbas_stream(eph, errors["dpos_m"], errors["dclock_s"], errors["fast_m"], WEEK, TOW0 - 120.0, last, GEO_PRN)


def write_files(work: Path) -> tuple[Path, Path]:
    eph, errors = scenario()
    pr = pseudoranges(eph, errors)
    obs = {str(s): (pr[:, k], pr[:, k] / 0.19029367279836487) for k, s in enumerate(eph.sv)}
    obs_path = work / "sbas_sim_0759.rnx"
    write_rinex3_obs(obs_path, START, STEP_S, obs, tuple(RECEIVER))
    sbs_path = write_rtklib_sbs(work / "sbas_sim_0759.sbs", stream(eph, errors))
    return obs_path, sbs_path


def our_fixes(obs_path: Path, sbs_path: Path, range_rate: bool = False):
    """Per epoch of the files: its GPS seconds of week, our SBAS solution
    (`sbas_pvt.solve_position_sbas`) and our fix without SBAS (`pvt.solve_position`:
    broadcast orbits and clocks, no ionospheric correction, Saastamoinen). The test
    (`tests/navigation/test_sbas_rtklib.py`) solves the stored files the same way."""
    import warnings

    import georinex

    from gnssframework.navigation.ephemeris import gps_seconds_of_week
    from gnssframework.navigation.pvt import solve_position
    from gnssframework.navigation.sbas_files import SbasReplay, read_sbas_messages
    from gnssframework.navigation.sbas_pvt import solve_position_sbas

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        data = georinex.load(obs_path)
    tow = gps_seconds_of_week(data.time.values)
    records = read_sbas_messages(sbs_path)
    eph_all = read_rinex_nav(NAV, "G")
    replay = SbasReplay(records, GEO_PRN, history_s=np.inf)  # the whole stream, as RTKLIB reads it
    fixes, plain = [], []
    for k, t in enumerate(tow):
        c1 = data["C1C"].isel(time=k)
        sv = [str(s) for s, v in zip(c1.sv.values, c1.values) if np.isfinite(v)]
        pr = np.array([float(c1.sel(sv=s)) for s in sv])
        eph = eph_all.select(sv, float(t))
        corr = replay.at(WEEK, float(t))
        tx = float(t) - pr / C
        doy = day_of_year(WEEK, float(t))
        fixes.append(solve_position_sbas(pr, tx, eph, corr, day_of_year=doy, range_rate=range_rate))
        plain.append(solve_position(pr, tx, eph, troposphere=True))
    return tow, fixes, plain


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="keep the files here (default: a temporary directory)")
    ap.add_argument("--store", action="store_true", help="copy the files into tests/data")
    args = ap.parse_args(argv)
    exe = shutil.which("rnx2rtkp")
    if exe is None:
        print("rnx2rtkp is not on PATH (Debian package rtklib): the check cannot run", file=sys.stderr)
        return 2
    work = args.out or Path(tempfile.mkdtemp(prefix="sbas_rtklib_"))
    work.mkdir(parents=True, exist_ok=True)
    obs_path, sbs_path = write_files(work)
    conf, pos_path = work / "sbas.conf", work / "sbas_sim_0759.rtklib.pos"
    conf.write_text("".join(f"{k:<18}={v}\n" for k, v in RTKLIB_OPTIONS.items()))
    subprocess.run(
        [exe, "-k", str(conf), "-o", str(pos_path), str(obs_path), str(NAV), str(sbs_path)],
        check=True,
        capture_output=True,
        text=True,
    )
    tow_r, xyz_r, ns_r = parse_pos(pos_path.read_text())
    n_sats = scenario()[0].sv.size
    checks = Checks()
    err_r = np.linalg.norm(xyz_r - RECEIVER, axis=1) if tow_r.size else np.array([np.inf])
    checks(
        tow_r.size == N_EPOCHS and bool(np.all(ns_r == n_sats)) and float(err_r.max()) < AIM_M,
        f"rnx2rtkp (SBAS): {tow_r.size} of {N_EPOCHS} epochs, {ns_r.min() if ns_r.size else 0}-"
        f"{ns_r.max() if ns_r.size else 0} of {n_sats} satellites, largest error {err_r.max():.4f} m "
        f"(aim < {AIM_M} m)",
    )
    tow, fixes, plain = our_fixes(obs_path, sbs_path)
    nan3 = np.full(3, np.nan)
    ours = np.array([f.fix.position_ecef_m if f is not None else nan3 for f in fixes])
    err = np.linalg.norm(ours - RECEIVER, axis=1)
    diff = np.linalg.norm(ours - xyz_r, axis=1) if tow_r.size == N_EPOCHS else np.full(N_EPOCHS, np.inf)
    checks(
        bool(np.all(err < AIM_M)) and bool(np.all(diff < AIM_M)),
        f"solve_position_sbas: largest error {np.max(err):.4f} m, largest difference from RTKLIB "
        f"{np.max(diff):.4f} m (aim < {AIM_M} m each)",
    )
    plain_err = np.linalg.norm(
        np.array([f.position_ecef_m if f is not None else nan3 for f in plain]) - RECEIVER, axis=1
    )
    checks(
        bool(np.all(plain_err > 1.0)),
        f"without SBAS (broadcast only, Saastamoinen): errors {np.min(plain_err):.2f}-{np.max(plain_err):.2f} m",
    )
    if args.store:
        for p in (obs_path, sbs_path):
            shutil.copy(p, DATA / p.name)
        # The header's input-file lines shortened to the files' names (no temporary paths).
        text = re.sub(r"(% inp file  : ).*/", r"\1", pos_path.read_text())
        (DATA / pos_path.name).write_text(text)
        print(f"stored {obs_path.name}, {sbs_path.name}, {pos_path.name} in {DATA}")
    return checks.summary()


if __name__ == "__main__":
    sys.exit(main())
