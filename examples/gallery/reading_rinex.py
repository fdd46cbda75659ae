"""Reading RINEX: carrier-smooth one satellite's pseudorange from a RINEX 3 file.

Run: python examples/gallery/reading_rinex.py
"""

import pathlib

import numpy as np

import gnssframework as gf
from gnssframework.io.observations import read_code_carrier

DATA = pathlib.Path(__file__).resolve().parents[1] / "data" / "simulated_pass.rnx"

obs = read_code_carrier(DATA, "G08")
hatch = gf.registry.create("channel_filter", "hatch")
hatch.reset((), gf.RunContext(epoch_interval_s=float(np.median(np.diff(obs.time_s)))))
smoothed = np.array(
    [
        hatch.step({"pseudorange_m": np.asarray(r), "carrier_m": np.asarray(c)})["smoothed_m"]
        for r, c in zip(obs.pseudorange_m, obs.carrier_m)
    ]
)
# Code minus carrier removes the geometry; its scatter is the code noise (plus a constant).
raw_noise = np.std(np.diff(obs.pseudorange_m - obs.carrier_m))
smooth_noise = np.std(np.diff(smoothed - obs.carrier_m))
print(f"G08: {len(obs.time_s)} epochs; epoch-to-epoch code noise {raw_noise:.2f} m raw, {smooth_noise:.2f} m smoothed")
assert smooth_noise < 0.5 * raw_noise
