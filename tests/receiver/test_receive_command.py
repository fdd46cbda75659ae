"""The `receive` command on the project's own generated recording (`test_receiver_fix`'s:
five satellites of real broadcast records seen from a known station, with LNAV): its
files read back by independent parsers (georinex, pynmea2), its report, its determinism,
its filter choice by options and by a TOML config, and the ekf-pv filter on the
recording's pseudoranges and Dopplers against the least squares."""

from __future__ import annotations

import csv
import warnings
from datetime import datetime, timedelta

import numpy as np
import pymap3d
import pynmea2
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.plugin_ref import PluginSpec
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.fixes import POSITION_COLUMNS
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.navigation.receiver_config import load_receiver_config
from lnav_recordings import NAV, STATION, TOW0
from test_receiver_fix import recording  # noqa: F401 - the module's fixture

WEEK = 1316  # the week the fixture's LNAV carries (no subframe 1 arrives in its 9.5 s)
TRUTH = tuple(float(v) for v in pymap3d.ecef2geodetic(*STATION))


def _run(path, out, *extra):
    return main(
        [
            "receive",
            str(path),
            "--out",
            str(out),
            "--ephemeris",
            str(NAV),
            "--rate",
            "10",
            "--week",
            str(WEEK),
            "--truth",
            ",".join(f"{v:.10f}" for v in TRUTH),
            "--quiet",
            *extra,
        ]
    )


@pytest.fixture(scope="module")
def outputs(recording, tmp_path_factory):  # noqa: F811
    path, sats = recording
    first, second = tmp_path_factory.mktemp("first"), tmp_path_factory.mktemp("second")
    assert _run(path, first) == 0
    assert _run(path, second, "--outputs", "default,kml,parquet,rtcm") == 0  # the defaults' bytes the same
    return first, second, sats


@pytest.mark.slow
def test_positions_csv_has_the_columns_and_a_row_per_fix_near_the_station(outputs):
    out, _, sats = outputs
    with (out / "positions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == POSITION_COLUMNS
    assert len(rows) >= 5
    assert {int(r["gps_week"]) for r in rows} == {WEEK}
    # tow is each epoch's GPS time: within the recording (from TOW0, 9.5 s), 0.1 s apart
    # (the receiver clock's grid; its bias is constant here to well under a millisecond).
    tow = np.array([float(r["tow_s"]) for r in rows])
    assert np.all((tow > TOW0) & (tow < TOW0 + 9.5))
    assert np.allclose(np.diff(tow), 0.1, atol=1e-3)
    xyz = np.stack(
        pymap3d.geodetic2ecef(*(np.array([float(r[k]) for r in rows]) for k in ("lat_deg", "lon_deg", "height_m"))),
        axis=1,
    )
    # 45 dB-Hz, 1.7 m of code noise per satellite scaled by the PDOP (under 4 here).
    assert np.all(np.linalg.norm(xyz - STATION, axis=1) < 4 * 4 * 1.7)
    assert all(int(r["n_sats"]) == sats.sv.size for r in rows)


@pytest.mark.slow
def test_observations_rnx_reads_back_through_georinex(outputs):
    import georinex

    out, _, sats = outputs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        obs = georinex.load(out / "observations.rnx")
    assert sorted(obs.sv.values) == sorted(sats.sv)
    assert set(obs.data_vars) >= {"C1C", "L1C", "D1C", "S1C"}
    t = obs.time.values
    assert np.allclose(np.diff(t).astype("timedelta64[ns]").astype(float) / 1e9, 0.1, atol=1e-6)
    # The epochs are GPS time of week TOW0 + recording time, in the fixture's week.
    first = datetime(1980, 1, 6) + timedelta(weeks=WEEK, seconds=float(np.floor(TOW0)))
    assert abs((t[0] - np.datetime64(first)).astype("timedelta64[ns]").astype(float) / 1e9 - (TOW0 % 1)) < 12.0
    pr = obs["C1C"].values
    assert np.all((pr > 1.9e7) & (pr < 2.7e7))
    assert np.all((obs["S1C"].values > 35) & (obs["S1C"].values < 55))


@pytest.mark.slow
def test_nmea_sentences_parse_and_match_positions_csv(outputs):
    out, _, _ = outputs
    lines = (out / "nmea.txt").read_text().splitlines()
    parsed = [pynmea2.parse(line, check=True) for line in lines]
    with (out / "positions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    # Per fix GGA, RMC, GSA, then two GSV pages (five satellites, four a page).
    assert [p.sentence_type for p in parsed] == ["GGA", "RMC", "GSA", "GSV", "GSV"] * len(rows)
    gga = parsed[0::5]
    for g, r in zip(gga, rows):
        assert g.latitude == pytest.approx(float(r["lat_deg"]), abs=1e-7)
        assert g.longitude == pytest.approx(float(r["lon_deg"]), abs=1e-7)
        assert int(g.num_sats) == int(r["n_sats"])
    utc = datetime(1980, 1, 6) + timedelta(weeks=WEEK, seconds=float(rows[0]["tow_s"]) - 18)  # 18 leap seconds
    assert parsed[1].datestamp == utc.date()
    for gsa, r in zip(parsed[2::5], rows):
        assert float(gsa.hdop) == pytest.approx(float(r["hdop"]), abs=0.0051)
        assert float(gsa.vdop) == pytest.approx(float(r["vdop"]), abs=0.0051)
        # PDOP² = HDOP² + VDOP² of the unrounded DOPs; the CSV's are rounded to 0.01 each.
        assert float(gsa.pdop) == pytest.approx(np.hypot(float(r["hdop"]), float(r["vdop"])), abs=0.0125)


@pytest.mark.slow
def test_gsv_gives_each_satellites_elevation_and_azimuth_from_the_station(outputs):
    from gnssframework.navigation.ephemeris import satellite_state

    out, _, sats = outputs
    lines = (out / "nmea.txt").read_text().splitlines()
    parsed = [pynmea2.parse(line, check=True) for line in lines[3:5]]  # the first fix's GSV pages
    seen = {
        int(getattr(p, f"sv_prn_num_{i}")): (
            float(getattr(p, f"elevation_deg_{i}")),
            float(getattr(p, f"azimuth_{i}")),
            float(getattr(p, f"snr_{i}")),
        )
        for p in parsed
        for i in range(1, 5)
        if getattr(p, f"sv_prn_num_{i}", None)
    }
    assert sorted(seen) == sorted(int(s[1:]) for s in sats.sv)
    # The truth: the navigation file's records seen from the station (not the fixes) at the
    # fixture's first epochs; a satellite moves under 0.01 deg/s, the fix is metres off.
    pos = satellite_state(sats, TOW0 + 3.0).position_m
    for k, sv in enumerate(sats.sv):
        az, el, _ = pymap3d.ecef2aer(*pos[k], *TRUTH)
        got_el, got_az, snr = seen[int(sv[1:])]
        assert abs(got_el - el) <= 0.5 + 0.1 and abs((got_az - az + 180) % 360 - 180) <= 0.5 + 0.1
        assert 40 <= snr <= 50  # the recording's 45 dB-Hz


@pytest.mark.slow
def test_track_geojson_is_written_by_default_and_no_navigation_rnx_without_a_decoded_ephemeris(outputs):
    import json

    out, _, _ = outputs
    track = json.loads((out / "track.geojson").read_text())
    with (out / "positions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    lon_lat = np.array(track["features"][0]["geometry"]["coordinates"])[:, :2]
    assert np.allclose(lon_lat, [[float(r["lon_deg"]), float(r["lat_deg"])] for r in rows], atol=1e-9)
    # The fixture's 9.5 s hold no subframe 1 (its records come from --ephemeris): nothing
    # decoded, so no navigation file (test_receiver_outputs checks one of decoded records).
    assert not (out / "navigation.rnx").exists()


@pytest.mark.slow
def test_the_outputs_asked_for_read_back_through_their_own_readers(outputs):
    """KML (ElementTree), Parquet (pandas) and RTCM MSM7 (pyrtcm) of the run with
    ``--outputs default,kml,parquet,rtcm``, against positions.csv, the recording and the
    pseudoranges of observations.rnx (georinex)."""
    import io
    import xml.etree.ElementTree as ET

    import georinex
    import pandas as pd
    from pyrtcm import RTCMReader, parse_msm

    _, out, sats = outputs
    with (out / "positions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    line = ET.parse(out / "track.kml").getroot().find(".//k:LineString/k:coordinates", ns).text.split()
    assert np.allclose(
        [[float(v) for v in c.split(",")[:2]] for c in line],
        [[float(r["lon_deg"]), float(r["lat_deg"])] for r in rows],
        atol=1e-9,
    )
    frame = pd.read_parquet(out / "tracking.parquet")
    assert set(frame["prn"]) == {int(s[1:]) for s in sats.sv}
    assert frame["time_s"].is_monotonic_increasing and 9.0 < frame["time_s"].max() <= 9.5  # the 9.5 s recording
    locked = frame[frame["lock"]]
    for _, one in locked.groupby("prn"):  # the recording's 45 dB-Hz, each channel's own estimate
        assert 42.0 < one["cn0_dbhz"].median() < 48.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        rnx = georinex.load(out / "observations.rnx")
    # GPS seconds of week of the epochs from the file's own epoch lines: georinex's times are
    # truncated to the microsecond (12.1000000 s reads as 12.099999), and a microsecond is
    # half a millimetre of range at 2.5 kHz of Doppler.
    epochs = [line.split() for line in (out / "observations.rnx").read_text().splitlines() if line.startswith(">")]
    tow_rnx = np.array(
        [(datetime(*map(int, e[1:6])) - datetime(1980, 1, 6)).total_seconds() % 604_800 + float(e[6]) for e in epochs]
    )
    messages = [msg for _, msg in RTCMReader(io.BytesIO((out / "observations.rtcm3").read_bytes()), validate=1)]
    assert len(messages) == rnx.time.size and all(m.identity == "1077" for m in messages)
    for k, msg in enumerate(messages):
        meta, sat_rows, cells = parse_msm(msg)
        dt = meta["epoch"] / 1e3 - tow_rnx[k]  # to the message's whole millisecond
        assert abs(dt) <= 0.5e-3
        for sat, cell in zip(sat_rows, cells):
            one = rnx.isel(time=k).sel(sv=f"G{cell['CELLPRN'][-2:]}")
            pr = (sat["DF397"] + sat["DF398"] + cell["DF405"]) * 299_792.458
            # RINEX's millimetre and MSM7's 2^-29 ms (0.56 mm), after the Doppler's move over dt.
            moved = float(one["C1C"]) - 299_792_458.0 / 1575.42e6 * float(one["D1C"]) * dt
            assert pr == pytest.approx(moved, abs=1e-3)


@pytest.mark.slow
def test_report_has_ttff_errors_satellites_and_figures(outputs):
    out, _, sats = outputs
    text = (out / "report.md").read_text()
    assert "time to first fix" in text and "horizontal RMS" in text and "vertical RMS" in text
    table = [line for line in text.splitlines() if line.startswith("| ") and line[2:4].strip().isdigit()]
    assert sorted(int(line.split("|")[1]) for line in table) == sorted(int(s[1:]) for s in sats.sv)
    for name in ("sky", "cn0_lock", "track", "enu_errors"):
        assert f"plots/{name}.png" in text
        assert (out / "plots" / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_the_same_recording_gives_the_same_bytes(outputs):
    first, second, _ = outputs
    for name in ("positions.csv", "observations.rnx", "nmea.txt", "report.md", "track.geojson"):
        assert (first / name).read_bytes() == (second / name).read_bytes(), name


@pytest.mark.slow
def test_ekf_pv_on_the_recordings_pseudoranges_is_as_accurate_and_smoother(recording):  # noqa: F811
    path, _ = recording
    result = receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        tracking_config(),
        rate_hz=10.0,
        rinex=read_rinex_nav(NAV),
        nav_filter=PluginSpec("nav_filter", "ekf-pv", {}),
    )
    wls, ekf = result.least_squares, result.positions
    assert len(wls) >= 5 and len(ekf) >= len(wls)
    assert ekf.sample_time_s[0] == wls.sample_time_s[0]  # it starts from the first fix

    def rms(table):
        return float(np.sqrt(np.mean(np.sum((table.ecef_m - STATION) ** 2, axis=1))))

    def velocity_std(table):
        vel = np.stack([table.columns[k] for k in ("vel_e_mps", "vel_n_mps", "vel_u_mps")], 1)
        return float(np.sqrt(np.sum(vel.var(axis=0))))

    # At most the least squares' order: its error, or the PDOP-scaled code noise when that is
    # smaller (a lucky epoch-by-epoch run), and a steadier velocity.
    assert rms(ekf) <= max(rms(wls), 4 * 1.7)
    assert velocity_std(ekf) < velocity_std(wls)
    assert np.all(ekf.columns["n_sats"] == 5) and np.all(np.isfinite(ekf.columns["hdop"]))


@pytest.mark.slow
def test_the_nav_filter_option_runs_the_filter_and_says_so(recording, tmp_path, capsys):  # noqa: F811
    path, _ = recording
    config = tmp_path / "receiver.toml"
    config.write_text(
        '[channel_filter]\nname = "scalar"\nparams = { pll_bandwidth_hz = 12.0 }\n\n'
        '[nav_filter]\nname = "ekf-pv"\nparams = { accel_psd = 0.5 }\n'
    )
    assert _run(path, tmp_path / "out", "--config", str(config)) == 0
    out = capsys.readouterr().out
    assert "channel filter scalar, nav filter ekf-pv" in out
    report = (tmp_path / "out" / "report.md").read_text()
    assert "nav filter ekf-pv" in report and "the least-squares fixes of the same run" in report


def test_position_is_the_same_command(recording, tmp_path, capsys):  # noqa: F811
    path, _ = recording
    assert (
        main(
            [
                "position",
                str(path),
                "--out",
                str(tmp_path / "p"),
                "--ephemeris",
                str(NAV),
                "--rate",
                "10",
                "--week",
                str(WEEK),
                "--quiet",
            ]
        )
        == 0
    )
    assert (tmp_path / "p" / "report.md").exists()


@pytest.mark.parametrize(
    "text, message",
    [
        ('[nav_filter]\nname = "ekf-pv"\nparams = { accel_psd = -1 }\n', "nav_filter.params.accel_psd"),
        ('[nav_filter]\nname = "ekf-p"\n', "did you mean 'ekf-pv'"),
        ('nav_filter = "position-ca"\n', "nav_filter.name: nav_filter 'position-ca' cannot run on pseudoranges"),
        (
            '[channel_filter]\nname = "scalar"\nparams = { pll_bandwidth_hz = 0 }\n',
            "channel_filter.params.pll_bandwidth_hz",
        ),
        ('[navfilter]\nname = "ekf-pv"\n', "navfilter: unknown parameter; valid: channel_filter, nav_filter"),
    ],
)
def test_a_bad_receiver_config_names_the_field(tmp_path, text, message):
    path = tmp_path / "receiver.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_receiver_config(path)
    assert message in str(info.value) and "\n" not in str(info.value)


@pytest.mark.slow
@pytest.mark.parametrize(
    "options, message",
    [
        (["--nav-filter", "ekf-p"], "--nav-filter: unknown nav_filter 'ekf-p'; known: "),
        (["--nav-filter", "ins-ekf"], "--nav-filter: nav_filter 'ins-ekf' cannot run on pseudoranges and Dopplers"),
        (["--channel-filter", "scalr"], "--channel-filter: unknown channel_filter 'scalr'"),
        (["--channel-params", '{"pll_bandwidth_hz": -1}'], "--channel-params.pll_bandwidth_hz"),
        (["--week", "-3"], "--week: a full GPS week"),
        (
            ["--tracking", "vector", "--nav-filter", "ekf-pv"],
            "--tracking: vector tracking runs its own navigation filter",
        ),
    ],
)
def test_receive_refuses_bad_options_with_one_line(recording, tmp_path, capsys, options, message):  # noqa: F811
    path, _ = recording
    assert main(["receive", str(path), "--out", str(tmp_path / "p"), *options]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_progress_lines_off_a_terminal_a_bar_on_one(recording, tmp_path, capsys, monkeypatch):  # noqa: F811
    import sys

    path, _ = recording

    def run(out):
        return main(
            [
                "receive",
                str(path),
                "--out",
                str(tmp_path / out),
                "--ephemeris",
                str(NAV),
                "--week",
                str(WEEK),
                "--rate",
                "10",
            ]
        )

    assert run("a") == 0
    err = capsys.readouterr().err  # captured stderr is no terminal: a line per tenth, no bar
    assert f"{path.name}: 100/100 % (100 %)" in err and "%|" not in err
    assert (
        main(
            [
                "receive",
                str(path),
                "--out",
                str(tmp_path / "q"),
                "--ephemeris",
                str(NAV),
                "--week",
                str(WEEK),
                "--rate",
                "10",
                "--quiet",
            ]
        )
        == 0
    )
    # --quiet: no progress; what may still come is the library's warning about the file
    # (this recording's 2.046 MHz is commensurate with the chip rate), one line.
    err = capsys.readouterr().err.splitlines()
    assert all(line.startswith("warning: sample rate 2.046 MHz") for line in err) and len(err) <= 1, err
    monkeypatch.setattr(type(sys.stderr), "isatty", lambda self: True, raising=False)
    assert run("b") == 0
    assert "100%" in capsys.readouterr().err


def test_a_missing_or_broken_config_file_is_named(tmp_path):
    from gnssframework.errors import DataFileError

    with pytest.raises(DataFileError) as info:
        load_receiver_config(tmp_path / "none.toml")
    assert "none.toml" in str(info.value)
    broken = tmp_path / "broken.toml"
    broken.write_text('[nav_filter]\nname = "ekf-pv"\nparams = { accel_psd = }\n')
    with pytest.raises(DataFileError) as info:
        load_receiver_config(broken)
    assert "broken.toml" in str(info.value) and "line 3" in str(info.value)


@pytest.mark.slow
def test_receive_takes_a_nav_filter_or_vector_tracking_not_both():
    """The vector loop closes its own ekf-pv: a second filter on the observables would
    be a different receiver, so the library refuses the pair before reading anything."""
    from gnssframework.errors import ConfigError
    from gnssframework.plugin_ref import PluginSpec
    from gnssframework.receiver.navigation.receive import receive
    from gnssframework.receiver.navigation.vector_tracking import vector_config

    with pytest.raises(ConfigError, match="nav_filter: vector tracking runs its own navigation filter"):
        receive(None, None, None, nav_filter=PluginSpec("nav_filter", "ekf-pv", {}), vector=vector_config())


@pytest.mark.slow
def test_a_run_without_position_keeps_its_tracking_and_says_why(recording, tmp_path, capsys):  # noqa: F811
    """5 s of the recording: every channel locks, but a subframe arrives 8.6 s in. The run
    writes tracking.csv and a report of what it decoded and why no satellite was used, then
    exits 1."""
    path, sats = recording
    out = tmp_path / "o"
    assert main(["receive", str(path), "--out", str(out), "--duration", "5", "--quiet"]) == 1
    said = capsys.readouterr().out
    assert "no position: no LNAV subframe decoded (5 of 5 satellites found locked" in said
    prns = sorted(int(s[1:]) for s in sats.sv)
    with (out / "tracking.csv").open() as fh:
        assert sorted({int(r["prn"]) for r in csv.DictReader(fh)}) == prns
    text = (out / "report.md").read_text()
    assert "no position" in text
    rows = [line.split("|") for line in text.splitlines() if line.startswith("| ") and line[2:4].strip().isdigit()]
    assert sorted(int(r[1]) for r in rows) == prns
    assert all(r[4].strip() == "0" and r[-2].strip() == "no LNAV subframe decoded (no transmit time)" for r in rows)
    assert not (out / "positions.csv").exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "extra, start",
    [
        ([], "a position"),
        (
            [
                "--tracking",
                "vector",
                "--approx-position",
                ",".join(f"{v:.6f}" for v in TRUTH),
                "--start-time",
                f"{WEEK},{TOW0}",
            ],
            "an assisted start",
        ),
    ],
)
def test_too_few_satellites_found_is_said_with_the_count(recording, tmp_path, capsys, extra, start):  # noqa: F811
    path, sats = recording
    two = sorted(int(s[1:]) for s in sats.sv)[:2]
    code = main(
        [
            "receive",
            str(path),
            "--out",
            str(tmp_path / "o"),
            "--ephemeris",
            str(NAV),
            "--duration",
            "1",
            "--quiet",
            "--prns",
            *map(str, two),
            *extra,
        ]
    )
    said = capsys.readouterr().out
    assert code == 1
    assert f"only 2 satellites found (PRN {two[0]}, {two[1]}): {start} needs 4" in said and "LNAV" not in said


@pytest.mark.slow
def test_an_ephemeris_of_another_week_is_named_as_the_reason(recording, tmp_path, capsys):  # noqa: F811
    # Not an assisted start: NAV's records moved a week later (each epoch's day and each
    # record's week), and the recording's week given. No LNAV ephemeris is decoded in the
    # file, so no fix: the reason is the file's dates, not "no LNAV subframe".
    path, _ = recording
    lines = NAV.read_text().splitlines(keepends=True)
    end = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    for i in range(end, len(lines)):
        if (i - end) % 8 == 0:  # a record's first line: PRN, YY MM DD ...
            lines[i] = lines[i][:9] + f"{int(lines[i][9:11]) + 7:2d}" + lines[i][11:]
        lines[i] = lines[i].replace("1.316000000000D+03", "1.317000000000D+03")
    later = tmp_path / "later.05n"
    later.write_text("".join(lines))
    argv = ["receive", str(path), "--out", str(tmp_path / "o"), "--ephemeris", str(later), "--week", "1316"]
    assert main([*argv, "--quiet"]) == 1
    said = capsys.readouterr().out
    assert "the ephemeris does not cover the recording (its records span 2005-04-08" in said, said
    assert "recording is at GPS week 1316" in said and "no LNAV" not in said
    assert "the ephemeris does not cover the recording" in (tmp_path / "o" / "report.md").read_text()


@pytest.mark.slow
def test_the_report_says_why_a_tracked_satellite_is_unused(recording, tmp_path):  # noqa: F811
    """One satellite's records taken out of the ephemeris (none is decoded in the file): the
    other four give the fixes, and the report says why it is in none."""
    from gnssframework.receiver.navigation.report import write_receive_report

    path, sats = recording
    nav = read_rinex_nav(NAV)
    gone = sats.sv[0]
    rinex = nav.subset(np.flatnonzero(nav.sv != gone))
    result = receive(
        open_recording(path), registry.create("acquisition", "pcps"), tracking_config(), rate_hz=5.0, rinex=rinex
    )
    assert len(result.positions) and all(int(gone[1:]) not in u for u in result.positions.used_prns)
    write_receive_report(tmp_path, result, result.positions, None, rinex)
    rows = {
        int(r[1]): r
        for r in (
            line.split("|")
            for line in (tmp_path / "report.md").read_text().splitlines()
            if line.startswith("| ") and line[2:4].strip().isdigit()
        )
    }
    assert rows[int(gone[1:])][2].strip() == "0"
    assert rows[int(gone[1:])][-2].strip() == "no healthy ephemeris (none decoded, none in --ephemeris)"
    assert all(r[-2].strip() == "-" for prn, r in rows.items() if prn != int(gone[1:]))
