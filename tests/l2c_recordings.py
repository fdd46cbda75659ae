r"""The receiver tests' L2C and L5 recordings: the satellites of `lnav_recordings` (real
broadcast records of tests/data/07590920.05n seen from the station of 07590920.05o), each
sending GPS CNAV (types 10, 11 and 30 of its own record and the navigation file's
Klobuchar coefficients, `cnav.cnav_symbols`) on L2 CM or L5 I5, with the code phase,
Doppler and symbol timing of the geometry at L2 (L5), 45 dB-Hz, complex int16 SigMF at
2.6 MHz for L2C (not 2.046, which meets L2C's sub-chips at two phases only: the DLL's dead
band of ±0.125 CM chip, 73 m, `CommensurateSamplingWarning`) and complex int8 at 10.5 MHz
for L5 (its main lobe's middle: the file stays small).

The satellite's L2 time is its L2 single-frequency user's: the clock's ``γ T_GD``
(IS-GPS-200 20.3.3.3.3.2) computed here from the record, not by the library. On L5 each
satellite sends ``ISC_L5I5 = -(γ_5 - 1) T_GD`` (`L5_ISC`), so that the L5 I5 user's clock
:math:`\Delta t_{SV} - T_{GD} + ISC_{L5I5}` (IS-GPS-705 20.3.3.3.1.2.2) and the rule for
a record without that ISC (`single_frequency_clock_s`: :math:`\gamma_5 T_{GD}`) agree:
the navigation file's records and the decoded ones date the signal alike. No ionosphere
(the generator has none)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssframework.navigation import cnav
from gnssframework.navigation.rinex_nav_header import read_nav_file_info
from gnssframework.signal.gps_l2c import GPS_L2C
from gnssframework.signal.gps_l5 import GPS_L5I
from gnssframework.signal.spec import SignalSpec
from light_time import C, signal_flight
from lnav_recordings import NAV, STATION
from noisy_recording import signal_chunks, write_noisy_recording

#: The week the generator's type 10 messages carry (the records' week).
WEEK = 1316
#: (f_L1 / f_L2)^2: the L2 user's factor on T_GD.
GAMMA = (1575.42 / 1227.60) ** 2
#: GPS time of the first sample: a CNAV message (12 s, on multiples of 12 s of SV time)
#: starts about 0.5 s in, so a 14 s file holds a whole one after the pull-in.
TOW0 = 518_700.0 - 0.5 + 0.075
#: The same for L5's 6 s messages, one message later: the first whole one (SV time 518706 s)
#: is a type 10, not the type 30 whose Klobuchar coefficients the receiver would apply to a
#: signal the generator sends without an ionosphere.
TOW0_L5 = TOW0 + 6.0
FS = 2.6e6
#: (f_L1 / f_L5)^2 = (154/115)^2: the L5 user's factor on T_GD without an ISC.
GAMMA_L5 = (154 / 115) ** 2
L5_FS = 10.5e6


def l2_satellite_time(eph, t_rx) -> np.ndarray:
    """The L2 SV time of the signal received at true GPS time ``t_rx`` by the station."""
    flight = signal_flight(eph, t_rx, STATION)
    return t_rx - flight.tau_s + flight.clock_s - (GAMMA - 1.0) * eph.elements["TGD"]


def l5_satellite_time(eph, t_rx) -> np.ndarray:
    """The L5 SV time of the signal received at true GPS time ``t_rx`` by the station (the
    L5 I5 user's clock with `L5_ISC`: ``γ_5 T_GD`` in all)."""
    flight = signal_flight(eph, t_rx, STATION)
    return t_rx - flight.tau_s + flight.clock_s - (GAMMA_L5 - 1.0) * eph.elements["TGD"]


def l5_isc_s(record) -> float:
    """The ISC_L5I5 a test satellite sends: ``-(γ_5 - 1) T_GD`` (module text)."""
    return float(-(GAMMA_L5 - 1.0) * record.elements["TGD"][0])


def write_l2c_recording(
    path: Path, sats, tow0: float, duration_s: float, seed: int, cn0_dbhz: float = 45.0, iono_l1_m=None
):
    """Write ``duration_s`` of L2C from the satellites ``sats`` (an `Ephemerides`, records on
    CNAV's 300 s grid of Toe) from GPS time ``tow0`` to ``path`` (``.sigmf-data``);
    ``iono_l1_m`` each satellite's ionospheric code delay on L1 (m, constant), sent on L2
    times ``GAMMA``."""
    return write_cnav_recording(path, sats, tow0, duration_s, seed, cn0_dbhz, iono_l1_m, signal=GPS_L2C)


def write_cnav_recording(
    path: Path,
    sats,
    tow0: float,
    duration_s: float,
    seed: int,
    cn0_dbhz: float = 45.0,
    iono_l1_m=None,
    *,
    signal: SignalSpec = GPS_L2C,
):
    """`write_l2c_recording` for ``signal``: GPS L2C (2.6 MHz, ci16) or L5 I5 (`L5_FS`, ci8;
    its NH10 overlay chip ``k`` on the ``k``-th millisecond of SV time, a symbol's start on
    chip 0)."""
    l5 = signal is GPS_L5I
    gamma, fs, sv_time = (GAMMA_L5, L5_FS, l5_satellite_time) if l5 else (GAMMA, FS, l2_satellite_time)
    message_s = cnav.L5_MESSAGE_S if l5 else cnav.MESSAGE_S
    iono_s = np.zeros(sats.sv.size) if iono_l1_m is None else gamma * np.asarray(iono_l1_m, float) / C
    rng = np.random.default_rng(seed)
    t_sv0 = sv_time(sats, np.array(tow0)) - iono_s
    iono = read_nav_file_info(NAV).iono
    streams = []
    for k in range(sats.sv.size):
        # A record off CNAV's 300 s grid of Toe (518384 s: uploaded 16 s early) cannot be
        # sent as types 10, 11 and 30: that satellite sends type 0 only (its TOW dates it as well).
        record = sats.subset(np.array([k])) if sats.elements["Toe"][k] % 300 == 0 else None
        symbols, into = cnav.cnav_symbols(
            int(sats.sv[k][1:]),
            float(t_sv0[k]) - 0.1,
            int(duration_s / signal.symbol_period_s) + 20,
            record,
            WEEK,
            iono,
            message_s=message_s,
            isc_l5i5_s=l5_isc_s(record) if l5 and record is not None else None,
        )
        streams.append((symbols.astype(float), float(t_sv0[k]) - 0.1 - into))  # SV time of the first symbol
    sv_time_less_iono = lambda eph, t: sv_time(eph, t) - iono_s  # noqa: E731
    chunks = signal_chunks(sats, tow0, duration_s, signal, fs, sv_time_less_iono, streams, cn0_dbhz, rng)
    return write_noisy_recording(path, chunks, fs, rng, fmt="ci8" if l5 else "ci16_le")


def l2c_tracking_config():
    """L2C's tracking settings (`channels.signal_tracking_config`: the pull-in loops narrowed
    to L2 CM's 20 ms period, taps half a chip apart), as ``track --signal gps-l2c`` takes."""
    from gnssframework.receiver.channels import signal_tracking_config

    return signal_tracking_config(GPS_L2C)
