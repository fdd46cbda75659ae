"""One LSB of each LNAV field, typed from IS-GPS-200 (Tables 20-I, 20-III and 20-X) and kept
apart from `gnssframework.navigation.lnav`'s own layouts, so that an encode -> decode round
trip is checked against the spec and not against the code under test; the LNAV tests
(tests/navigation/test_lnav.py) and the gps-sdr-sim validation
(validation/gps_sdr_sim_navigation.py) share it."""

from __future__ import annotations

import numpy as np

PI = 3.1415926535898  # IS-GPS-200 20.3.3.4.3
#: The LSB of each RINEX ephemeris field (angles: semicircles x pi).
LSB = {
    "SVclockBias": 2.0**-31,
    "SVclockDrift": 2.0**-43,
    "SVclockDriftRate": 2.0**-55,
    "TGD": 2.0**-31,
    "Crs": 2.0**-5,
    "Crc": 2.0**-5,
    "Cuc": 2.0**-29,
    "Cus": 2.0**-29,
    "Cic": 2.0**-29,
    "Cis": 2.0**-29,
    "DeltaN": 2.0**-43 * PI,
    "M0": 2.0**-31 * PI,
    "Omega0": 2.0**-31 * PI,
    "Io": 2.0**-31 * PI,
    "omega": 2.0**-31 * PI,
    "OmegaDot": 2.0**-43 * PI,
    "IDOT": 2.0**-43 * PI,
    "Eccentricity": 2.0**-33,
    "sqrtA": 2.0**-19,
    "Toe": 16.0,
}
#: The LSBs of page 18's Klobuchar alpha_0..3 (s, s/sc, ...) and beta_0..3 (s, s/sc, ...), Table 20-X.
ALPHA_LSB = np.array([2.0**-30, 2.0**-27, 2.0**-24, 2.0**-24])
BETA_LSB = np.array([2.0**11, 2.0**14, 2.0**16, 2.0**16])
