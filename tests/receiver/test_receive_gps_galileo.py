"""GPS L1 C/A and Galileo E1-B in one `receive` run: ``--signal gps-l1ca,galileo-e1b-boc11``
on the project's generated recording of both (`mixed_recordings`: three GPS and three
Galileo satellites seen from VILL, 45 dB-Hz, GST = GPS time), each signal dated by its own
message, fixes of all six satellites with a receiver clock per time system; the files read
back by georinex and pynmea2 and checked against the generator's geometry."""

from __future__ import annotations

import csv
import warnings

import numpy as np
import pymap3d
import pynmea2
import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import Ephemerides, satellite_state
from gnssframework.receiver.navigation.multi_receive import SignalSet
from gnssframework.signal.galileo_e1 import GALILEO_E1B_BOC11, GALILEO_E1C_BOC11
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C
from gnssframework.signal.qzss_l1ca import QZSS_L1CA

from inav_recordings import GPS_WEEK, STATION, galileo_records
from light_time import signal_flight
from mixed_recordings import highest, moved_gps_records, write_mixed_nav, write_mixed_recording

# GPS: a subframe starts 2.6 s in (arrives 8.6 s in, as lnav_recordings); Galileo: a GST page 1.6 s in.
TOW0 = 18015.4
DURATION_S = 10.0
C = 299_792_458.0
SIGMA_M = 1.7  # code noise at 45 dB-Hz (test_receive_command's, test_inav_fix's)


def _receive_args(path, nav, out, *more: str) -> list[str]:
    """The receive command of both signals at 5 Hz (no ionosphere: the generator has none)."""
    signals = "gps-l1ca,galileo-e1b-boc11"
    return ["receive", str(path), "--signal", signals, "--rate", "5", "--no-iono", "--ephemeris", str(nav)] + [
        *more,
        "--out",
        str(out),
        "--quiet",
    ]


@pytest.fixture(scope="module")
def mixed_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("mixed")
    gps, gal = highest(moved_gps_records(), TOW0, 3), highest(galileo_records(), TOW0, 3)
    nav = write_mixed_nav(folder / "mixed.rnx", gps)
    path = write_mixed_recording(folder / "mix.sigmf-data", gps, gal, TOW0, DURATION_S, seed=3)
    out = folder / "out"
    code = main(_receive_args(path, nav, out, "--outputs", "default,kml,parquet,rtcm"))
    return code, out, gps, gal


def _rows(out):
    with (out / "positions.csv").open() as fh:
        return list(csv.DictReader(fh))


def _offset_sigma_ns(sats, t, xyz) -> float:
    """Standard deviation (ns) of the Galileo-GPS clock offset of a weighted least-squares fix
    (weights sin^2 E, `pvt.solve_position`'s) whose pseudoranges each have SIGMA_M of noise."""
    los = satellite_state(sats, t).position_m - xyz
    u = los / np.linalg.norm(los, axis=1, keepdims=True)
    up = xyz / np.linalg.norm(xyz)
    w = np.diag((u @ up) ** 2)
    galileo = np.char.startswith(sats.sv.astype(str), "E").astype(float)
    H = np.column_stack([-u, np.ones(len(u)), galileo])  # GPS clock, then Galileo minus GPS
    A = np.linalg.solve(H.T @ w @ H, H.T @ w)
    return float(np.sqrt((A @ A.T)[4, 4]) * SIGMA_M / C * 1e9)


@pytest.mark.slow
def test_gps_and_galileo_fixes_use_all_six_satellites_with_an_inter_system_clock(mixed_run):
    code, out, gps, gal = mixed_run
    assert code == 0
    rows = _rows(out)
    assert len(rows) >= 4  # 5 Hz from GPS's first subframe (8.6 s in) to the end (10 s)
    assert all(int(r["n_sats"]) == 6 for r in rows)
    assert {int(r["gps_week"]) for r in rows} == {GPS_WEEK}
    xyz = np.stack(
        pymap3d.geodetic2ecef(*(np.array([float(r[k]) for r in rows]) for k in ("lat_deg", "lon_deg", "height_m"))),
        axis=1,
    )
    hdop, vdop = (np.array([float(r[k]) for r in rows]) for k in ("hdop", "vdop"))
    assert np.all(np.linalg.norm(xyz - STATION, axis=1) < 4 * (hdop + vdop) * SIGMA_M)
    # The generator has no GGTO and one receiver: the offset is noise about 0, within 4 of its sigma.
    both = Ephemerides(
        np.concatenate([gps.sv, gal.sv]),
        np.concatenate([gps.toc_s, gal.toc_s]),
        {k: np.concatenate([gps.elements[k], gal.elements[k]]) for k in gps.elements},
        np.concatenate([gps.health, gal.health]),
        np.concatenate([gps.iode, gal.iode]),
    )
    for r in rows:
        sigma_ns = _offset_sigma_ns(both, float(r["tow_s"]), STATION)
        assert abs(float(r["system_offset_ns"])) < 4 * sigma_ns, (r["system_offset_ns"], sigma_ns)


@pytest.mark.slow
def test_the_mixed_observation_file_holds_each_systems_codes_and_the_geometrys_ranges(mixed_run):
    import georinex

    _, out, gps, gal = mixed_run
    text = (out / "observations.rnx").read_text().splitlines()
    assert text[0][40:41] == "M"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        obs = georinex.load(out / "observations.rnx")
    assert sorted(obs.sv.values) == sorted(list(gps.sv) + list(gal.sv))
    codes = {"G": "C1C", "E": "C1B"}  # L1 C/A; E1-B, the I/NAV data component (RINEX 3.04)
    for sv in obs.sv.values:
        other = codes["E" if sv[0] == "G" else "G"]
        assert np.all(np.isnan(obs[other].sel(sv=sv).values))  # each satellite only its own code
    rows = _rows(out)
    epoch_tow = (obs.time.values - np.datetime64("1980-01-06")).astype("timedelta64[ns]").astype(
        float
    ) / 1e9 - GPS_WEEK * 604_800.0
    fixes = {round(float(r["tow_s"]) + float(r["clock_bias_m"]) / C, 3): r for r in rows}
    checked = 0
    for e, t_clock in enumerate(epoch_tow):
        r = fixes.get(round(t_clock, 3))
        if r is None:
            continue  # an epoch before the GPS channels were dated: no fix
        bias_m = float(r["clock_bias_m"])
        for sats in (gps, gal):
            for k, sv in enumerate(sats.sv):
                flight = signal_flight(sats.subset(np.array([k])), t_clock - bias_m / C, STATION)
                # Galileo's ranges carry its own receiver clock: GPS's plus the offset column
                clock_m = bias_m + (float(r["system_offset_ns"]) * 1e-9 * C if sv[0] == "E" else 0.0)
                expected = C * (flight.tau_s[0] - flight.clock_s[0]) + clock_m
                got = float(obs[codes[sv[0]]].sel(sv=sv).values[e])
                assert abs(got - expected) < 5 * SIGMA_M, (sv, e, got - expected)
                checked += 1
    assert checked >= 6 * 4


@pytest.mark.slow
def test_the_nmea_of_a_two_system_fix_is_from_the_gn_talker(mixed_run):
    _, out, _, _ = mixed_run
    parsed = [pynmea2.parse(line, check=True) for line in (out / "nmea.txt").read_text().splitlines()]
    assert {p.talker for p in parsed if p.sentence_type in ("GGA", "RMC", "GSA")} == {"GN"}
    rows = _rows(out)
    gga = [p for p in parsed if p.sentence_type == "GGA"]
    assert len(gga) == len(rows)
    for g, r in zip(gga, rows):
        assert g.latitude == pytest.approx(float(r["lat_deg"]), abs=1e-7)
        assert g.longitude == pytest.approx(float(r["lon_deg"]), abs=1e-7)
        assert int(g.num_sats) == 6


def _fix_groups(out):
    """nmea.txt's sentences, one list per fix (from its GGA on)."""
    groups: list[list] = []
    for line in (out / "nmea.txt").read_text().splitlines():
        p = pynmea2.parse(line, check=True)
        if p.sentence_type == "GGA":
            groups.append([])
        groups[-1].append(p)
    return groups


@pytest.mark.slow
def test_gsa_and_gsv_go_per_system_with_the_satellites_used_at_the_geometrys_elevations(mixed_run):
    _, out, gps, gal = mixed_run
    groups = _fix_groups(out)
    rows = _rows(out)
    assert len(groups) == len(rows)
    truth = {"1": sorted(int(s[1:]) for s in gps.sv), "3": sorted(int(s[1:]) for s in gal.sv)}
    for group, r in zip(groups, rows):
        gsa = [p for p in group if p.sentence_type == "GSA"]
        # NMEA 4.10: a GNGSA per system, its system ID last (1 GPS, 3 Galileo), its own IDs
        assert {p.data[-1]: sorted(int(v) for v in p.data[2:14] if v) for p in gsa} == truth
        tow = float(r["tow_s"])
        xyz = np.array(pymap3d.geodetic2ecef(float(r["lat_deg"]), float(r["lon_deg"]), float(r["height_m"])))
        for talker, sats, system in (("GP", gps, "1"), ("GA", gal, "3")):
            gsv = [p for p in group if p.sentence_type == "GSV" and p.talker == talker]
            assert gsv and {int(p.num_sv_in_view) for p in gsv} == {len(truth[system])}  # the satellites used
            seen = {int(p.data[i]): int(p.data[i + 1]) for p in gsv for i in range(3, len(p.data) - 1, 4) if p.data[i]}
            assert sorted(seen) == truth[system]
            pos = satellite_state(sats, tow - 0.075).position_m
            for k, sv in enumerate(sats.sv):
                _, el, _ = pymap3d.ecef2aer(*pos[k], *pymap3d.ecef2geodetic(*xyz))
                assert abs(seen[int(sv[1:])] - float(el)) <= 1.0, (sv, seen, float(el))  # whole degrees


def _msm_messages(path):
    import io

    from pyrtcm import RTCMReader, parse_msm

    out = []
    for _raw, msg in RTCMReader(io.BytesIO(path.read_bytes()), validate=1):  # checks each CRC-24Q
        meta, sats, cells = parse_msm(msg)
        out.append((msg.identity, meta["epoch"], int(msg.DF393), sats, cells))
    return out


@pytest.mark.slow
def test_rtcm_sends_1077_and_1097_with_the_observation_files_pseudoranges(mixed_run):
    import georinex

    _, out, gps, gal = mixed_run
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        obs = georinex.load(out / "observations.rnx")
    # The epochs from the file's own lines (F11.7 s): georinex reads 15.6000000 s as
    # 15.599999 s (whole microseconds, truncated), and a microsecond is up to 0.8 mm of range.
    epochs = [ln.split() for ln in (out / "observations.rnx").read_text().splitlines() if ln.startswith("> ")]
    t_rx = np.array([(int(f[4]) * 60 + int(f[5])) * 60 + float(f[6]) for f in epochs])
    t_rx += (np.datetime64(f"{epochs[0][1]}-{epochs[0][2]}-{epochs[0][3]}") - np.datetime64("1980-01-06")).astype(
        "timedelta64[s]"
    ).astype(float) - GPS_WEEK * 604_800.0
    assert t_rx.size == obs.time.size
    messages = _msm_messages(out / "observations.rtcm3")
    by_epoch: dict[int, list] = {}
    for m in messages:
        by_epoch.setdefault(m[1], []).append(m)
    wavelength = C / 1575.42e6
    codes = {"1077": ("G", "C1C", "D1C", "1C"), "1097": ("E", "C1B", "D1B", "1B")}
    checked = {"1077": 0, "1097": 0}
    for e, t in enumerate(t_rx):
        epoch_ms = round(t * 1e3)
        sent = by_epoch.get(epoch_ms, [])
        has = {k: np.isfinite(obs[codes[k][1]].values[e]).any() for k in codes}
        assert [m[0] for m in sent] == [k for k in ("1077", "1097") if has[k]]  # the set's order, each once
        assert [m[2] for m in sent] == [1] * (len(sent) - 1) + [0] * bool(sent)  # DF393: more to come
        for ident, _, _, sats, cells in sent:
            letter, code, dop, sig = codes[ident]
            assert {c["CELLSIG"] for c in cells} == {sig}
            for sat, cell in zip(sats, cells):
                sv = f"{letter}{int(cell['CELLPRN']):02d}"
                pr = float(obs[code].sel(sv=sv).values[e])
                d = float(obs[dop].sel(sv=sv).values[e])
                # The MSM's instant is the whole millisecond: the range moved there by the Doppler.
                expected = pr - wavelength * d * (epoch_ms * 1e-3 - t)
                got = (sat["DF397"] + sat["DF398"] + cell["DF405"]) * C * 1e-3
                # half an LSB of DF405 (2^-30 ms, 0.28 mm) and RINEX's 1 mm (F14.3, half of it)
                assert got == pytest.approx(expected, abs=2.0**-30 * C * 1e-3 + 0.5e-3), (sv, e)
                checked[ident] += 1
    assert checked["1077"] >= 3 * len(_rows(out)) and checked["1097"] >= 3 * len(_rows(out))
    assert {m[0] for m in messages} == {"1077", "1097"}
    assert sum(m[0] == "1077" for m in messages) == int(np.isfinite(obs["C1C"].values).any(axis=1).sum())


@pytest.mark.slow
def test_the_track_and_the_parquet_table_name_each_systems_satellites(mixed_run):
    import json
    import xml.etree.ElementTree as ET

    import pandas as pd

    _, out, gps, gal = mixed_run
    rows = _rows(out)
    features = json.loads((out / "track.geojson").read_text())["features"]
    points = [f for f in features if f["geometry"]["type"] == "Point"]
    assert len(points) == len(rows)
    for f, r in zip(points, rows):
        lon, lat, _ = f["geometry"]["coordinates"]
        assert (lat, lon) == pytest.approx((float(r["lat_deg"]), float(r["lon_deg"])), abs=1e-9)
        assert sorted(f["properties"]["satellites_used"]) == sorted(list(gps.sv) + list(gal.sv))
    kml = ET.parse(out / "track.kml").getroot()
    placemarks = kml.findall(".//{http://www.opengis.net/kml/2.2}Placemark")
    assert len(placemarks) == len(rows) + 1  # the line and one per fix
    table = pd.read_parquet(out / "tracking.parquet")
    got = {(str(s), int(p)) for s, p in zip(table["signal"], table["prn"])}
    assert got == {("gps-l1ca", int(s[1:])) for s in gps.sv} | {("galileo-e1b-boc11", int(s[1:])) for s in gal.sv}
    # The 10 s of each channel: a GPS row per 1 ms integration or more, a Galileo one per 4 ms code period.
    per = table.groupby(["signal", "prn"])["time_s"].agg(["min", "max"])
    assert np.all(per["max"] - per["min"] > 0.8 * DURATION_S)


def test_a_signal_set_names_satellites_by_system_and_refuses_what_it_cannot_position():
    both = SignalSet((GPS_L1CA, GALILEO_E1B_BOC11))
    assert both.rinex_satellite(both.key(0, 5)) == "G05" and both.rinex_satellite(both.key(1, 11)) == "E11"
    assert both.wavelength_m == GPS_L1CA.wavelength_m
    for bad, word in (
        ((GPS_L1CA,), "two signals"),
        ((GPS_L1CA, QZSS_L1CA, GPS_L1CA), "twice"),
        ((GPS_L1CA, GALILEO_E1C_BOC11), "galileo-e1c-boc11"),
        ((GPS_L1CA, GPS_L2C), "gps-l2c"),
    ):
        with pytest.raises(ConfigError, match=word) as exc:
            SignalSet(bad)
        assert len(str(exc.value).splitlines()) == 1


def test_receive_refuses_options_it_does_not_take_with_several_signals(tmp_path, capsys):
    from gnssframework.receiver.frontend import write_recording

    path = write_recording(tmp_path / "zeros.sigmf-data", np.zeros(4000, complex), "ci16_le", 4e6, 0.0)
    for extra, word in (
        (["--prns", "5"], "--prns"),
        (["--tracking", "vector"], "--tracking vector"),
        (["--signal", "gps-l1ca,galileo-e1c-boc11"], "galileo-e1c-boc11"),
    ):
        args = [
            "receive",
            str(path),
            "--signal",
            "gps-l1ca,galileo-e1b-boc11",
            "--out",
            str(tmp_path / "o"),
            "--quiet",
            *extra,
        ]
        assert main(args) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and word in err[0], err
    with pytest.raises(SystemExit):  # an unknown name: argparse's usage error
        main(["receive", str(path), "--signal", "gps-l1ca,galileo-e9", "--out", str(tmp_path / "o")])
    assert "galileo-e9" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("workers", ["1", "3"])
def test_each_signals_channels_in_worker_processes_give_the_same_files(mixed_run, tmp_path, workers):
    # Each signal's channels in 1 or 3 processes (the fixture: the default, one per core):
    # the same positions and observations, byte for byte.
    _, out, *_ = mixed_run
    code = main(_receive_args(out.parent / "mix.sigmf-data", out.parent / "mixed.rnx", tmp_path, "--workers", workers))
    assert code == 0
    for name in ("positions.csv", "observations.rnx", "nmea.txt"):
        assert (tmp_path / name).read_bytes() == (out / name).read_bytes(), name
