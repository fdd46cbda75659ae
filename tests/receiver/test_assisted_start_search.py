"""The assisted start's search: long non-coherent sums that follow the code Doppler
(`fft_search.search_grid(code_doppler=True)`), and the Dopplers an approximate position and
start time predict (`assisted_search.predicted_dopplers`), each against an independent truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pymap3d
import pytest

from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.receiver.acquisition.fft_search import search_grid
from gnssframework.receiver.frontend.synthetic import SatelliteSignal, synthesize_samples
from gnssframework.receiver.navigation.assisted_search import predicted_dopplers
from gnssframework.receiver.navigation.vector_config import assistance
from gnssframework.signal.gps_l1ca import GPS_L1CA

FS = 2.046e6  # 2 samples a chip
T = 0.010


def test_long_sum_keeps_its_gain_when_it_follows_the_code_doppler():
    """60 blocks of 10 ms at 4.5 kHz: the code moves 60 * 20460 * 4500 / 1575.42e6 = 3.5
    samples (1.75 chips). Summed at one lag, the blocks' peaks spread over 3.5 samples of a
    correlation triangle 2 samples wide each side: the sum's peak keeps about 0.4 of the
    blocks' (the mean of (1 - |x|/2)^2 over x uniform in +-1.75 samples: 0.39). Followed,
    each block lands on block 0's lag with at most the grid's own sub-sample loss: 0.77
    (the same mean over +-0.5 samples); the signal is noise-free in effect (60 dB-Hz)."""
    sat = SatelliteSignal(7, 60.0, 4500.0, 100.0, 0.3)
    blocks = 60
    x = synthesize_samples([sat], blocks * T + 0.001, FS, 0.0, np.random.default_rng(1))
    d = np.array([4500.0])
    one = search_grid(x, FS, 0.0, (7,), T, 1, d)[0, 0]  # block 0 alone: its peak on the grid
    fixed = search_grid(x, FS, 0.0, (7,), T, blocks, d)[0, 0]
    followed = search_grid(x, FS, 0.0, (7,), T, blocks, d, code_doppler=True)[0, 0]
    ideal = blocks * one.max()
    assert fixed.max() / ideal < 0.5
    assert followed.max() / ideal > 0.7
    assert followed.argmax() % 2046 == one.argmax() % 2046  # the grid's lag is block 0's (modulo a code period)
    # No Doppler, no drift: following changes nothing.
    still = SatelliteSignal(7, 60.0, 0.0, 100.0, 0.3)
    y = synthesize_samples([still], 4 * T + 0.001, FS, 0.0, np.random.default_rng(2))
    zero = np.array([0.0])
    np.testing.assert_allclose(
        search_grid(y, FS, 0.0, (7,), T, 4, zero, code_doppler=True),
        search_grid(y, FS, 0.0, (7,), T, 4, zero),
        rtol=1e-4,
        atol=1e-3,
    )


NAV = Path(__file__).resolve().parents[1] / "data" / "VILL00ESP_R_20181700000_06H_MN.rnx"


def test_predicted_dopplers_are_the_pseudorange_rate_by_finite_differences():
    """Against the change of the geometric range minus the satellite clock over +-0.5 s
    (no velocity or clock drift used), at the station, for every satellite above 5 deg."""
    nav = read_rinex_nav(NAV, "G")
    lat, lon, h = 40.4433, -3.9522, 647.0
    tow = 2 * 86400.0 + 1.5 * 3600.0
    week = 2006
    dop = predicted_dopplers(nav, assistance((lat, lon, h), week, tow), 5.0)
    assert set(dop) == {5, 7}  # the file's two GPS satellites, both up
    r = np.array(pymap3d.geodetic2ecef(lat, lon, h))
    c = 299792458.0
    for prn, f in dop.items():
        eph = nav.select([f"G{prn:02d}"], tow)

        def pseudorange(t, eph=eph):
            st = satellite_state(eph, np.array([t]))
            return np.linalg.norm(st.position_m[0] - r) - c * float(st.clock_l1_s[0])

        rate = pseudorange(tow - 0.075 + 0.5) - pseudorange(tow - 0.075 - 0.5)
        assert f == pytest.approx(-rate / GPS_L1CA.wavelength_m, abs=0.5), prn


def test_the_pcps_option_follows_the_code_doppler_in_its_grid_and_its_fine_search():
    """``pcps`` with ``code_doppler = true`` (``--code-doppler``): 100 blocks of 5 ms at 4.5
    kHz, the code moving 2.9 samples over the search. The reported code phase is block 0's
    (the generator's, to the nearest sample), and the fine search's C/N0 (which now replays
    each block's drift) reads what the same search reads on the same signal without Doppler,
    within 0.5 dB: the straddle of block 0's lag is then all that is lost. Not followed,
    the blocks' peaks spread over 2.9 samples of a triangle 2 samples wide each side: the
    statistic keeps under 0.8 of the followed one's (measured 0.73) and the C/N0 reads more
    than 1.5 dB lower (measured 2.7)."""
    from gnssframework import registry

    sat = SatelliteSignal(7, 45.0, 4500.0, 100.0, 0.3)
    still = SatelliteSignal(7, 45.0, 0.0, 100.0, 0.3)
    rng = np.random.default_rng(5)
    n = 100 * 5
    x = synthesize_samples([sat], n * 1e-3 + 0.001, FS, 0.0, rng)
    y = synthesize_samples([still], n * 1e-3 + 0.001, FS, 0.0, np.random.default_rng(5))
    kw = {"coherent_ms": 5, "noncoherent": 100, "doppler_max_hz": 4600.0, "xcorr_margin_db": None}
    followed = registry.create("acquisition", "pcps", code_doppler=True, **kw)
    fixed = registry.create("acquisition", "pcps", **kw)
    f = followed.acquire(x, FS, 0.0, prns=(7,))[0]
    s = followed.acquire(y, FS, 0.0, prns=(7,))[0]
    g = fixed.acquire(x, FS, 0.0, prns=(7,))[0]
    assert f.detected and abs(f.doppler_hz - 4500.0) <= 10.0
    d = (f.code_phase_chips - 100.0) % 1023
    assert min(d, 1023 - d) <= GPS_L1CA.chip_rate_hz / FS
    assert abs(f.cn0_dbhz - s.cn0_dbhz) < 0.5, (f.cn0_dbhz, s.cn0_dbhz)
    assert g.test_statistic < 0.8 * f.test_statistic and g.cn0_dbhz < f.cn0_dbhz - 1.5
