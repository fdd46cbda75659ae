"""Reference 004 (Liu et al. 2020) position filters on real fixes with a stated truth.

- the u-blox ZED-F9P NMEA log of gpsd's regression tests (static; its header states the
  antenna at 45.877591500 S, 170.500124833 E, no height): horizontal error of every fix;
- the Google Smartphone Decimeter Challenge 2022 excerpt: the baseline WLS fix of each
  epoch against the reference trajectory at the same UTC millisecond.

Each track is filtered by the four candidates of ``gnssframework.io.positions`` (UKF,
UKF1, AUKF, AUKF1) and the horizontal errors (m) of raw and filtered fixes are reported.

Run: python examples/positions_real.py [--data DIR] [--out DIR]
(``DIR`` holding ``nmea/`` and ``phone/`` as the shared data folder; default
``../shared/data`` beside the repository). Writes ``positions_real.md`` and ``.json``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pymap3d

from gnssframework.io.gsdc import read_gsdc_truth, read_gsdc_wls
from gnssframework.io.nmea import NmeaFixes, read_nmea
from gnssframework.io.positions import CANDIDATES, filter_positions

ROOT = Path(__file__).resolve().parents[1]
F9P_TRUTH_DEG = (-45.877591500, 170.500124833)  # the log's header: "Location: 45.877591500S 170.500124833E"
#: Fewer epochs than this and the page gives values only, no paired statistics: the
#: errors of consecutive fixes of one receiver are strongly correlated (multipath, the
#: receiver's own filter), so tens of epochs are not tens of independent samples.
MIN_EPOCHS_FOR_STATISTICS = 200


def horizontal_error_m(lat_deg, lon_deg, truth_lat_deg, truth_lon_deg) -> np.ndarray:
    """Horizontal distance (m) from the truth, in its local east/north plane (pymap3d)."""
    e, n, _ = pymap3d.geodetic2enu(lat_deg, lon_deg, 0.0, truth_lat_deg, truth_lon_deg, 0.0)
    return np.hypot(e, n)


def _evaluate(fixes: NmeaFixes, truth_lat, truth_lon) -> dict:
    out = {"epochs": int(fixes.time_s.size),
           "raw": _stats(horizontal_error_m(fixes.lat_deg, fixes.lon_deg, truth_lat, truth_lon))}
    for name in CANDIDATES:
        lat, lon, _, _ = filter_positions(fixes, name)
        out[name] = _stats(horizontal_error_m(lat, lon, truth_lat, truth_lon))
    return out


def _stats(err: np.ndarray) -> dict:
    return {"rms_m": float(np.sqrt(np.mean(err**2))), "mean_m": float(np.mean(err)), "max_m": float(np.max(err))}


def run(data: Path) -> dict:
    f9p = read_nmea(data / "nmea" / "ublox-zed-f9p-nmea.log")
    wls = read_gsdc_wls(data / "phone" / "gsdc2022_device_gnss.csv")
    truth = read_gsdc_truth(data / "phone" / "gsdc2022_ground_truth.csv")
    at = np.searchsorted(truth.utc_ms, wls.utc_ms).clip(0, truth.utc_ms.size - 1)
    if not np.array_equal(truth.utc_ms[at], wls.utc_ms):
        raise SystemExit("the ground truth has no epoch at some WLS epoch")
    wls_fixes = NmeaFixes((wls.utc_ms - wls.utc_ms[0]) / 1e3, wls.lat_deg, wls.lon_deg, wls.height_m, wls.line)
    return {"zed-f9p": _evaluate(f9p, *F9P_TRUTH_DEG),
            "gsdc2022": _evaluate(wls_fixes, truth.lat_deg[at], truth.lon_deg[at])}


def markdown(s: dict) -> str:
    lines = ["| track | epochs | raw | " + " | ".join(CANDIDATES) + " |",
             "| --- | --- | --- | " + " | ".join("---" for _ in CANDIDATES) + " |"]
    for track, r in s.items():
        cells = [f"{r[c]['rms_m']:.2f} ({r[c]['max_m']:.2f})" for c in ("raw", *CANDIDATES)]
        lines.append(f"| {track} | {r['epochs']} | " + " | ".join(cells) + " |")
    lines += ["", "Horizontal error against the stated truth: RMS (max), m."]
    short = [t for t, r in s.items() if r["epochs"] < MIN_EPOCHS_FOR_STATISTICS]
    if short:
        lines.append(f"{', '.join(short)}: fewer than {MIN_EPOCHS_FOR_STATISTICS} epochs of one receiver; "
                     "too few, and too correlated, for paired differences: values only.")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "positions_real")
    args = parser.parse_args(argv)
    summary = run(args.data)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "positions_real.json").write_text(json.dumps(summary, indent=2) + "\n")
    text = markdown(summary)
    (args.out / "positions_real.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
