"""Generate examples/data/static_receiver.nmea: 500 s of GGA and RMC sentences of a static
receiver whose positions carry AR(1) colored multipath noise (psi 0.95, 3 m) plus 0.5 m
white noise, as in examples/multipath.toml. Written with pynmea2.

    python examples/data/make_nmea.py
"""

from __future__ import annotations

import datetime as dt
import pathlib

import numpy as np
import pymap3d
import pynmea2

from gnssframework.experiments import get_scenario

LAT0, LON0, H0 = 30.5281, 114.3545, 35.0
OUT = pathlib.Path(__file__).resolve().parent / "static_receiver.nmea"


def _dm(value: float, width: int) -> str:
    deg = int(abs(value))
    return f"{deg:0{width}d}{(abs(value) - deg) * 60:07.4f}"


def main() -> None:
    scen = get_scenario({"kind": "multipath", "epochs": 500})
    err = scen.simulate(1, np.random.default_rng(2024))[:, 0, :]  # north, east (m)
    lat, lon, h = pymap3d.enu2geodetic(err[:, 1], err[:, 0], 0.0, LAT0, LON0, H0)
    start = dt.datetime(2020, 5, 1, 3, 0, 0)
    lines = []
    for k in range(err.shape[0]):
        t = (start + dt.timedelta(seconds=k)).strftime("%H%M%S.00")
        ns, ew = ("N" if lat[k] >= 0 else "S"), ("E" if lon[k] >= 0 else "W")
        gga = pynmea2.GGA(
            "GN",
            "GGA",
            (t, _dm(lat[k], 2), ns, _dm(lon[k], 3), ew, "1", "12", "0.8", f"{h[k]:.1f}", "M", "0.0", "M", "", ""),
        )
        rmc = pynmea2.RMC(
            "GN",
            "RMC",
            (
                t,
                "A",
                _dm(lat[k], 2),
                ns,
                _dm(lon[k], 3),
                ew,
                "0.0",
                "0.0",
                (start + dt.timedelta(seconds=k)).strftime("%d%m%y"),
                "",
                "",
            ),
        )
        lines += [str(gga), str(rmc)]
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT} ({len(lines)} sentences)")


if __name__ == "__main__":
    main()
