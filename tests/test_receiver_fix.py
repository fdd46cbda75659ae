"""End to end on the project's own generator: five satellites of real broadcast records
(tests/data/07590920.05n) seen from the station of 07590920.05o, each signal carrying its
LNAV with the code phase, Doppler and data timing of the geometry (light time, Earth
rotation, satellite clock; updated every 0.5 s); acquisition, tracking, LNAV TOW, observables
and fixes (`receive`, with the RINEX records as `--ephemeris` does) put the receiver
within a few metres of the station, and the `position` command writes its files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.navigation import lnav
from gnssframework.navigation.ephemeris import read_rinex_nav, satellite_state
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording, write_recording
from gnssframework.signal.constants import L1_FREQ_HZ
from gnssframework.signal.if_samples import generate_if_samples

DATA = Path(__file__).parent / "data"
NAV = DATA / "07590920.05n"
STATION = np.array([-3976219.5082, 3382372.5671, 3652512.9849])
C = 299_792_458.0
OMEGA_E = 7.2921151467e-5
FS = 2.046e6
# GPS time of the first sample: subframe 2 starts 2.6 s in and has arrived 8.6 s in (bit sync
# needs bit transitions: the end of subframe 1 before it has them; the generator's empty page
# 25 of subframe 5 would have none).
TOW0 = 518_706.0 - 2.6
DURATION_S = 9.5
CHUNK_S = 0.5


def _satellite_time(eph, t_rx):
    """t_SV of the signal received at true GPS time t_rx by the station (receiver clock exact)."""
    tau = np.full(eph.sv.size, 0.07)
    for _ in range(6):
        st = satellite_state(eph, t_rx - tau)
        th = OMEGA_E * tau
        p = st.position_m
        rot = np.stack([np.cos(th) * p[:, 0] + np.sin(th) * p[:, 1], -np.sin(th) * p[:, 0] + np.cos(th) * p[:, 1],
                        p[:, 2]], axis=1)
        tau = np.linalg.norm(rot - STATION, axis=1) / C
    return t_rx - tau + st.clock_l1_s


def _strongest(nav, t, n):
    sel = nav.select(np.unique(nav.sv), t)
    up = STATION / np.linalg.norm(STATION)
    los = satellite_state(sel, t).position_m - STATION
    el = los @ up / np.linalg.norm(los, axis=1)
    return sel.subset(np.argsort(-el)[:n])


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    nav = read_rinex_nav(NAV)
    sats = _strongest(nav, TOW0, 5)
    rng = np.random.default_rng(2025)
    n = int(round(CHUNK_S * FS))
    source = registry.create("sample_source", "ci16_le")
    path = tmp_path_factory.mktemp("fix") / "five.sigmf-data"
    t_sv0 = _satellite_time(sats, np.array(TOW0))
    symbols = [lnav.lnav_symbols(sats.subset(np.array([k])), 1316, float(t_sv0[k]) - 0.1, int(DURATION_S * 50) + 20)
               for k in range(sats.sv.size)]
    phase = np.zeros(sats.sv.size)
    with open(path, "wb") as out:
        for c in range(int(round(DURATION_S / CHUNK_S))):
            t0 = c * CHUNK_S
            start, end = _satellite_time(sats, TOW0 + t0), _satellite_time(sats, TOW0 + t0 + CHUNK_S)
            doppler = L1_FREQ_HZ * ((end - start) / CHUNK_S - 1)
            x = np.zeros(n, complex)
            for k in range(sats.sv.size):
                bits, into = symbols[k]
                first_tsv = float(t_sv0[k]) - 0.1 - into  # t_SV of the first bit edge
                x += generate_if_samples(int(sats.sv[k][1:]), CHUNK_S, FS, 0.0, 45.0, rng, doppler_hz=doppler[k],
                                         code_phase_chips=(start[k] * 1e3 % 1.0) * 1023, carrier_phase_rad=phase[k],
                                         complex_samples=True, data_bits=bits,
                                         first_bit_edge_s=first_tsv - start[k], noise=False).samples
                phase[k] += 2 * np.pi * doppler[k] * CHUNK_S
            x += rng.standard_normal(n) + 1j * rng.standard_normal(n)
            out.write(source.encode(x * 300.0))
    write_recording(path.with_suffix(".tmp"), np.zeros(2, complex), "ci16_le", FS, 0.0)
    path.with_suffix(".tmp").with_suffix(".sigmf-meta").rename(path.with_suffix(".sigmf-meta"))
    path.with_suffix(".tmp").unlink()
    return path, sats


def test_receive_positions_the_generated_recording_at_the_station(recording):
    path, sats = recording
    result = receive(open_recording(path), registry.create("acquisition", "pcps"), tracking_config(), rate_hz=5.0,
                     rinex=read_rinex_nav(NAV))
    table = result.positions
    assert table is not None and len(table) >= 3
    assert np.all(table.columns["n_sats"] == 5)
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    # 45 dB-Hz, a 2 Hz DLL with 1-chip spacing: about 1.7 m of code noise per satellite; PDOP-scaled.
    assert np.sqrt(np.mean(err**2)) < 4 * np.max(table.columns["hdop"] + table.columns["vdop"]) * 1.7
    # The receiver clock is GPS time here: the solution's time is each epoch's sample time after TOW0.
    assert np.allclose(table.columns["tow_s"], TOW0 + table.sample_time_s, atol=30e-9)
    speed = np.linalg.norm(np.stack([table.columns[k] for k in ("vel_e_mps", "vel_n_mps", "vel_u_mps")], 1), axis=1)
    assert np.all(speed < 0.5)


def test_position_command_writes_positions_rinex_and_nmea(recording, tmp_path, capsys):
    path, _ = recording
    lat, lon, h = (float(v) for v in __import__("pymap3d").ecef2geodetic(*STATION))
    code = main(["position", str(path), "--out", str(tmp_path / "pos"), "--ephemeris", str(NAV), "--rate", "5",
                 "--truth", f"{lat},{lon},{h}"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "against --truth: horizontal RMS" in out
    assert (tmp_path / "pos" / "positions.csv").read_text().count("\n") >= 4
    # No subframe 1 in the file: the week is unknown, so no RINEX or NMEA, and the command says so.
    assert "the GPS week is unknown" in out and not (tmp_path / "pos" / "nmea.txt").exists()
