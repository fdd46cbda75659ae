"""Generate examples/data/simulated_pass.rnx: RINEX 3.04, two GPS satellites, 721 epochs at
1 s, C1C and L1C from the carrier-smoothing simulation (with cycle slips). The primary
satellite is labelled G08, as in reference 001; the geometry is that of the nominal
constellation's highest satellite.

    python examples/data/make_rinex.py
"""

from __future__ import annotations

import datetime as dt
import pathlib

import numpy as np
import pymap3d

from gnssframework.experiments import get_scenario
from gnssframework.io.rinex import write_rinex3_nav, write_rinex3_obs
from gnssframework.signal.constants import L1_WAVELENGTH_M
from gnssframework.simulation.constellation import nominal_constellation

OUT = pathlib.Path(__file__).resolve().parent / "simulated_pass.rnx"
NAV = pathlib.Path(__file__).resolve().parent / "nominal_brdc.nav"


def write_nominal_nav() -> None:
    """The nominal 24-slot almanac as broadcast ephemeris: e = 0, omega = 0, Toe = 0, so
    seconds of week equal the almanac's seconds of day for the first half week."""
    const = nominal_constellation()
    eph = {
        int(prn): {
            "sqrtA": np.sqrt(const.radius_m),
            "Eccentricity": 0.0,
            "Io": const.inclination_rad,
            "Omega0": float(raan),
            "omega": 0.0,
            "M0": float(u),
            "Toe": 0.0,
        }
        for prn, raan, u in zip(const.prn, const.raan_rad, const.arg_lat_rad)
    }
    write_rinex3_nav(NAV, dt.datetime(2020, 4, 26, 0, 0, 0), eph)
    print(f"wrote {NAV}")


def main() -> None:
    scen = get_scenario({"kind": "carrier-smoothing", "epochs": 721})
    p = scen.params
    _, code, carrier, _ = scen.simulate(2, np.random.default_rng(8))  # two independent draws
    const = nominal_constellation()
    idx = const.visible(p.start_time_s, p.lat_deg, p.lon_deg, p.height_m, 10.0, 2)
    # The simulation's satellite is the highest; give the second draw the second satellite's range.
    pos, _, _ = const.subset(idx).state(p.start_time_s + np.arange(p.epochs) * p.dt_s)
    rx = np.array(pymap3d.geodetic2ecef(p.lat_deg, p.lon_deg, p.height_m))
    ranges = np.linalg.norm(pos - rx, axis=-1)
    code[:, 1] += ranges[:, 1] - ranges[:, 0]
    carrier[:, 1] += ranges[:, 1] - ranges[:, 0]
    # Reference 001 smooths PRN 8: the simulated primary satellite is labelled G08.
    labels = ["G08", f"G{const.prn[idx[1]]:02d}"]
    obs = {lab: (code[:, j], carrier[:, j] / L1_WAVELENGTH_M) for j, lab in enumerate(labels)}
    write_rinex3_obs(OUT, dt.datetime(2020, 5, 1, 10, 30, 0), p.dt_s, obs, tuple(rx))
    print(f"wrote {OUT}: {', '.join(obs)}")


if __name__ == "__main__":
    main()
    write_nominal_nav()
