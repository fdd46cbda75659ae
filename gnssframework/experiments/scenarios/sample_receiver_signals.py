"""The recordings of the ``sample-receiver`` scenario: LNAV-carrying GPS L1 C/A signals of a
static receiver, with the code, carrier and data timing of the geometry.

The satellites are the nominal 24-slot constellation (`nominal_constellation`) written as
broadcast ephemerides (circular orbits: e = 0, omega = 0, no harmonic terms, no clock
error), quantised by an LNAV encode/decode round trip so that the generator and the
receiver propagate the same record with the same algorithm (IS-GPS-200 Table 20-IV,
`satellite_state`). For each satellite and each 0.5 s chunk, the transmit time of the
signal received at the chunk's edges (light time and Earth rotation during the flight,
solved by fixed-point iteration) gives the code phase, the Doppler and the data timing,
and `generate_if_samples` writes the chunk without noise. With an `Atmosphere` the signals
carry an ionosphere (a multiple of the broadcast Klobuchar model's delay: code delayed,
carrier advanced) and a troposphere (the receiver model's delay plus a zenith residual),
and the receiver corrects both with its own models; without one they have neither and
the receiver switches both models off (a clean control). The noise-free sum depends on
the case only; the white noise (unit variance per real dimension, which sets each signal's C/N0) is drawn
per run from the run's own stream, so every candidate of a comparison sees the same
samples in the same run (common random numbers).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pymap3d

from ... import registry
from ...errors import ConfigError
from ...navigation import lnav
from ...navigation.ephemeris import OMEGA_EARTH_RAD_S, Ephemerides, satellite_state
from ...navigation.pvt import klobuchar_delay_s, troposphere_delay_m
from ...signal.gps_l1ca import GPS_L1CA
from ...signal.if_samples import generate_if_samples
from ...signal.spec import SignalSpec
from ...simulation.constellation import nominal_constellation
from ...simulation.propagation import elevation_deg

__all__ = [
    "Atmosphere",
    "SignalPlan",
    "nominal_ephemerides",
    "signal_plan",
    "noise_free_samples",
    "with_atmosphere",
    "write_run_recording",
    "transmit_times",
    "CHUNK_S",
    "SAMPLE_FORMAT",
    "SAMPLE_SCALE",
]

#: Seconds of samples generated at a time (the geometry is updated at each chunk edge:
#: over 0.5 s a Doppler drifts by under 0.5 Hz for a static receiver).
CHUNK_S = 0.5
#: Format of the recordings the receiver reads, and the factor from unit noise to its
#: integer levels (16 levels per noise sigma: clipping at 8 sigma, a quantisation loss
#: below 0.01 dB).
SAMPLE_FORMAT = "ci8"
SAMPLE_SCALE = 16.0
_SPEED_OF_LIGHT_MPS = 299_792_458.0
_TOE_STEP_S = 16.0  # LNAV sends toe and toc in units of 16 s (IS-GPS-200 Table 20-III)


def nominal_ephemerides(toe_s: float, week: int) -> Ephemerides:
    """The nominal constellation as broadcast records with reference time ``toe_s``.

    Circular orbits map to Keplerian elements with e = 0 and omega = 0: the argument of
    latitude is the mean anomaly, ``M0 = u(toe)``, and the Earth-fixed node longitude
    ``raan - omega_E t`` is IS-GPS-200's ``Omega_k`` with ``Omega0 = raan`` and
    ``OmegaDot = 0``. The constellation's time is GPS seconds of week. Each record is
    passed through the LNAV encoder and decoder, so it holds exactly what a satellite
    broadcasts.
    """
    const = nominal_constellation()
    toe_s = float(np.round(toe_s / _TOE_STEP_S) * _TOE_STEP_S)
    s = const.prn.size
    zeros = np.zeros(s)
    wrap = lambda a: (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi  # noqa: E731 - LNAV angles are signed
    elements = {
        k: zeros.copy()
        for k in (
            "Eccentricity",
            "omega",
            "DeltaN",
            "OmegaDot",
            "IDOT",
            "Cuc",
            "Cus",
            "Crc",
            "Crs",
            "Cic",
            "Cis",
            "SVclockBias",
            "SVclockDrift",
            "SVclockDriftRate",
            "TGD",
        )
    }
    elements |= {
        "sqrtA": np.full(s, np.sqrt(const.radius_m)),
        "Io": np.full(s, const.inclination_rad),
        "M0": wrap(const.arg_lat_rad + const.mean_motion_rad_s * toe_s),
        "Omega0": wrap(const.raan_rad),
        "Toe": np.full(s, toe_s),
    }
    raw = Ephemerides(
        np.array([f"G{p:02d}" for p in const.prn]),
        np.full(s, toe_s),
        elements,
        zeros.copy(),
        np.full(s, 17.0),
        np.full(s, 2.0),
    )
    first_tow = np.floor(toe_s / 30.0) * 30.0  # a frame: subframes 1-5
    decoded = []
    for k in range(s):
        bits = lnav.encode_lnav(raw.subset(np.array([k])), week, first_tow, 5)
        decoded.append(lnav.decode_lnav(1 - 2 * bits.astype(np.int8), int(const.prn[k])).ephemeris)
    return Ephemerides.concatenate(decoded)


def transmit_times(
    eph: Ephemerides, receiver_ecef_m: np.ndarray, t_rx_s: float, delay_m: np.ndarray | None = None
) -> np.ndarray:
    """Satellite time ``t_SV`` (s of week, ``(S,)``) of the signals received at GPS time
    ``t_rx_s`` at ``receiver_ecef_m``: the flight time ``tau`` solves
    ``c tau = |R(omega_E tau) r_sat(t_rx - tau) - r_rx|`` (the Earth turns during the flight,
    IS-GPS-200 20.3.3.4.3.3.2), then the satellite's L1 clock offset is added
    (20.3.3.3.3.1-2). Six iterations reach 1e-12 s from a 70 ms start. ``delay_m`` ``(S,)``:
    a propagation delay beyond the vacuum's (the atmosphere's, m), subtracted as ``delay/c``
    (the satellite moves under 0.1 mm in that time)."""
    tau = np.full(eph.sv.size, 0.07)
    for _ in range(6):
        st = satellite_state(eph, t_rx_s - tau)
        th = OMEGA_EARTH_RAD_S * tau
        p = st.position_m
        rotated = np.stack(
            [np.cos(th) * p[:, 0] + np.sin(th) * p[:, 1], -np.sin(th) * p[:, 0] + np.cos(th) * p[:, 1], p[:, 2]], axis=1
        )
        tau = np.linalg.norm(rotated - receiver_ecef_m, axis=1) / _SPEED_OF_LIGHT_MPS
    extra = 0.0 if delay_m is None else np.asarray(delay_m, float) / _SPEED_OF_LIGHT_MPS
    return t_rx_s - tau - extra + st.clock_l1_s


@dataclass(frozen=True)
class Atmosphere:
    """A recording's ionosphere and troposphere, and what its receiver is told of them.

    Attributes
    ----------
    iono_alpha, iono_beta
        Broadcast Klobuchar coefficients (IS-GPS-200 20.3.3.5.1.7), handed to the receiver
        as a navigation file's header gives them (the recording is too short for page 18).
    iono_scale
        The true ionospheric delay is this times the broadcast model's (IS-GPS-200
        20.3.3.5.2.5) along each line of sight: the receiver's correction leaves
        ``(iono_scale - 1)`` of the model's delay (the model removes about half of the
        real delay in RMS: Klobuchar 1987; Kaplan and Hegarty 2017, section 10.2.4).
        It delays the code and advances the carrier.
    tropo_zenith_residual_m
        The true zenith tropospheric delay minus the receiver model's (Saastamoinen with a
        standard atmosphere, `navigation.pvt.troposphere_delay_m`), mapped as that model
        maps; delays code and carrier alike.
    """

    iono_alpha: tuple[float, float, float, float]
    iono_beta: tuple[float, float, float, float]
    iono_scale: float
    tropo_zenith_residual_m: float
    #: Each satellite's broadcast orbit and clock error along its line of sight (m, the
    #: plan's satellites in order; empty: none): the signal comes that much later than the
    #: broadcast ephemeris the receiver uses says, on code and carrier alike.
    orbit_clock_m: tuple[float, ...] = ()

    def iono_utc(self) -> lnav.IonoUtc:
        """The coefficients as the receiver's fallback (`receive(..., iono_fallback=...)`)."""
        return lnav.IonoUtc(self.iono_alpha, self.iono_beta)

    def delays_m(
        self, sat_ecef_m: np.ndarray, lat_lon_h: tuple[float, float, float], gps_tow_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Code and carrier delays (m, ``(S,)``) of satellites at ``sat_ecef_m`` ``(S, 3)``
        seen from the receiver at geodetic ``lat_lon_h`` at ``gps_tow_s``."""
        lat, lon, h = lat_lon_h
        az, el, _ = pymap3d.ecef2aer(sat_ecef_m[:, 0], sat_ecef_m[:, 1], sat_ecef_m[:, 2], lat, lon, h)
        iono = (
            self.iono_scale
            * _SPEED_OF_LIGHT_MPS
            * klobuchar_delay_s(self.iono_alpha, self.iono_beta, lat, lon, az, el, gps_tow_s)
        )
        sin_e = np.sin(np.radians(np.maximum(el, 1.0)))
        tropo = troposphere_delay_m(lat, h, el) + self.tropo_zenith_residual_m / sin_e
        common = tropo + (np.asarray(self.orbit_clock_m, float) if self.orbit_clock_m else 0.0)
        return common + iono, common - iono

    def drawn(
        self, rng: np.random.Generator, satellites: int, iono_scale_std: float, tropo_std_m: float, sisre_m: float
    ) -> Atmosphere:
        """One run's atmosphere and orbit and clock errors, drawn around this case's: the
        ionosphere's scale ``iono_scale + iono_scale_std N`` (at least 0), the zenith
        troposphere's residual ``tropo_zenith_residual_m + tropo_std_m N``, and each of the
        ``satellites`` satellites' orbit and clock error ``sisre_m N`` (N independent
        standard normal draws from ``rng``, in that order)."""
        z = rng.standard_normal(2 + satellites)
        return replace(
            self,
            iono_scale=max(0.0, self.iono_scale + iono_scale_std * float(z[0])),
            tropo_zenith_residual_m=self.tropo_zenith_residual_m + tropo_std_m * float(z[1]),
            orbit_clock_m=tuple(float(v) for v in sisre_m * z[2:]),
        )


@dataclass(frozen=True)
class SignalPlan:
    """What one case's recording holds: the satellites (records, PRNs, C/N0) seen from the
    receiver, the GPS time of the first sample, and the recording's rate and length."""

    ephemerides: Ephemerides
    prns: tuple[int, ...]
    cn0_dbhz: float
    receiver_ecef_m: tuple[float, float, float]
    receiver_lat_lon_h: tuple[float, float, float]
    start_tow_s: float
    week: int
    duration_s: float
    sample_rate_hz: float
    #: The recording's ionosphere and troposphere (None: neither, and the receiver's models off).
    atmosphere: Atmosphere | None
    #: The arguments of `signal_plan` that made it (sorted items): what the noise-free
    #: samples are cached by.
    key: tuple


def signal_plan(
    *,
    lat_deg: float,
    lon_deg: float,
    height_m: float,
    subframe_tow_s: float,
    lead_s: float,
    week: int,
    satellites: int,
    cn0_dbhz: float,
    duration_s: float,
    sample_rate_hz: float,
    mask_deg: float,
    atmosphere: Atmosphere | None = None,
) -> SignalPlan:
    """The ``satellites`` highest satellites above ``mask_deg`` at the recording's start,
    which is ``lead_s`` before the subframe starting at GPS time ``subframe_tow_s``.

    Raises
    ------
    ConfigError
        If fewer satellites are above the mask (naming ``satellites``).
    """
    key = tuple(
        sorted(
            dict(
                lat_deg=lat_deg,
                lon_deg=lon_deg,
                height_m=height_m,
                subframe_tow_s=subframe_tow_s,
                lead_s=lead_s,
                week=week,
                satellites=satellites,
                cn0_dbhz=cn0_dbhz,
                duration_s=duration_s,
                sample_rate_hz=sample_rate_hz,
                mask_deg=mask_deg,
                atmosphere=atmosphere,
            ).items()
        )
    )
    start = subframe_tow_s - lead_s
    eph = nominal_ephemerides(start, week)
    rx = np.array(pymap3d.geodetic2ecef(lat_deg, lon_deg, height_m))
    el = elevation_deg(satellite_state(eph, np.full(eph.sv.size, start)).position_m, rx, lat_deg, lon_deg)
    order = np.argsort(-el)
    above = order[el[order] > mask_deg]
    if above.size < satellites:
        raise ConfigError(
            "satellites",
            f"only {above.size} satellites are above the {mask_deg} deg mask at "
            f"this place and time; ask for at most {above.size}",
        )
    pick = np.sort(above[:satellites])
    sats = eph.subset(pick)
    return SignalPlan(
        sats,
        tuple(int(s[1:]) for s in sats.sv),
        float(cn0_dbhz),
        tuple(float(v) for v in rx),
        (lat_deg, lon_deg, height_m),
        float(start),
        int(week),
        float(duration_s),
        float(sample_rate_hz),
        atmosphere,
        key,
    )


def with_atmosphere(plan: SignalPlan, atmosphere: Atmosphere) -> SignalPlan:
    """``plan`` with another atmosphere (one run's), and the key its samples are cached by."""
    key = tuple((k, atmosphere if k == "atmosphere" else v) for k, v in plan.key)
    return replace(plan, atmosphere=atmosphere, key=key)


def noise_free_samples(plan: SignalPlan) -> np.ndarray:
    """The sum of the plan's signals without noise, ``complex64`` (the amplitude law of
    `generate_if_samples` with unit noise sigma, so each signal has the plan's C/N0).
    The last case's samples are kept: the runner runs every candidate of a case in turn."""
    return _noise_free(plan.key)


@functools.lru_cache(maxsize=1)
def _noise_free(key: tuple, signal: SignalSpec = GPS_L1CA) -> np.ndarray:
    plan = signal_plan(**dict(key))
    sats, rx = plan.ephemerides, np.array(plan.receiver_ecef_m)
    fs, n_chunks = plan.sample_rate_hz, int(round(plan.duration_s / CHUNK_S))
    n = int(round(CHUNK_S * fs))
    out = np.zeros(n_chunks * n, np.complex64)

    def delays(t_rx: float) -> tuple[np.ndarray, np.ndarray]:
        """The atmosphere's code and carrier delays (m) of the signals received at ``t_rx``."""
        if plan.atmosphere is None:
            return np.zeros(sats.sv.size), np.zeros(sats.sv.size)
        pos = satellite_state(sats, np.full(sats.sv.size, t_rx - 0.075)).position_m
        return plan.atmosphere.delays_m(pos, plan.receiver_lat_lon_h, t_rx)

    code_m, carrier_m = delays(plan.start_tow_s)
    t_sv0 = transmit_times(sats, rx, plan.start_tow_s, code_m)
    bits_per_s, periods_per_s = 1.0 / signal.symbol_period_s, 1.0 / signal.code_period_s  # 50, 1000 for C/A
    # Bits from the one in force 0.1 s before the first sample's transmit time on.
    symbols = [
        lnav.lnav_symbols(
            sats.subset(np.array([k])), plan.week, float(t_sv0[k]) - 0.1, int(plan.duration_s * bits_per_s) + 20
        )
        for k in range(sats.sv.size)
    ]
    phase = np.zeros(sats.sv.size)
    start, start_carrier = t_sv0, transmit_times(sats, rx, plan.start_tow_s, carrier_m)
    for c in range(n_chunks):
        t_end = plan.start_tow_s + (c + 1) * CHUNK_S
        code_m, carrier_m = delays(t_end)
        end, end_carrier = transmit_times(sats, rx, t_end, code_m), transmit_times(sats, rx, t_end, carrier_m)
        # the carrier's Doppler follows the carrier's range (the ionosphere advances it)
        doppler_hz = signal.carrier_freq_hz * ((end_carrier - start_carrier) / CHUNK_S - 1)
        for k, prn in enumerate(plan.prns):
            bits, into = symbols[k]
            first_edge_tsv = float(t_sv0[k]) - 0.1 - into
            out[c * n : (c + 1) * n] += generate_if_samples(
                prn,
                CHUNK_S,
                fs,
                0.0,
                plan.cn0_dbhz,
                None,
                doppler_hz=doppler_hz[k],
                code_phase_chips=(start[k] * periods_per_s % 1.0) * signal.code_length_chips,
                carrier_phase_rad=phase[k],
                complex_samples=True,
                data_bits=bits,
                first_bit_edge_s=first_edge_tsv - start[k],
                noise=False,
                signal=signal,
            ).samples
        phase += 2 * np.pi * doppler_hz * CHUNK_S
        start, start_carrier = end, end_carrier
    return out


def write_run_recording(plan: SignalPlan, rng: np.random.Generator, path: str | Path) -> Path:
    """The case's signals plus one run's unit-variance complex white noise drawn from
    ``rng``, written to ``path`` as `SAMPLE_FORMAT` (chunk by chunk: memory of one chunk)."""
    clean = noise_free_samples(plan)
    source = registry.create("sample_source", SAMPLE_FORMAT)
    n = int(round(CHUNK_S * plan.sample_rate_hz))
    path = Path(path)
    with open(path, "wb") as out:
        for first in range(0, clean.size, n):
            x = (
                clean[first : first + n]
                + rng.standard_normal(min(n, clean.size - first))
                + 1j * rng.standard_normal(min(n, clean.size - first))
            )
            out.write(source.encode(x * SAMPLE_SCALE))
    return path
