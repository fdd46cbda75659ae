"""Vector tracking started without LNAV (`vector_tracking.Assistance`) on the project's own
generator: the five satellites of `test_receiver_fix` (real broadcast orbits seen from a
known station, LNAV, light time and Earth rotation), at one weak C/N0 for the whole file.

The scalar receiver needs a decoded subframe (its HOW's TOW) for a transmit time: six
seconds of a locked, bit-synchronised channel after bit sync. The assisted start needs
none: the approximate position (30 km off here) and the recording's start time resolve
each code phase's millisecond, and the navigation filter closes the channels as soon as
four are bit-aligned. Both outcomes are asserted on the same file."""

from __future__ import annotations


import numpy as np
import pymap3d
import pytest

import test_receiver_fix as fix
from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.acquisition.report import acquire_recording
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.navigation.vector_tracking import assistance, vector_config
from lnav_recordings import WEEK, true_dopplers, write_lnav_recording

pytestmark = pytest.mark.slow  # end to end (issue 37: the fast lane leaves these out)

DURATION_S = 6.0
CN0_DBHZ = 32.0
#: The approximate position: the station moved 30 km east and 20 km north, 500 m up.
OFFSET_ENU_M = (30e3, 20e3, 500.0)


def write_weak(path, cn0_dbhz: float, duration_s: float, seed: int, blank_until_s: tuple[int, float] | None = None):
    """`fix.recording`'s five signals at ``cn0_dbhz`` for ``duration_s``; the true Doppler per
    chunk. ``blank_until_s`` ``(k, t)``: the ``k``-th satellite's signal is absent before ``t``."""
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    blank = None if blank_until_s is None else (blank_until_s[0], 0.0, blank_until_s[1])
    write_lnav_recording(path, sats, fix.TOW0, duration_s, seed, blank=blank, cn0_dbhz=cn0_dbhz)
    return [int(s[1:]) for s in sats.sv], true_dopplers(sats, fix.TOW0, duration_s)


def approximate_position() -> tuple[float, float, float]:
    lat, lon, h = pymap3d.ecef2geodetic(*fix.STATION)
    return tuple(float(v) for v in pymap3d.enu2geodetic(*OFFSET_ENU_M, lat, lon, h))


@pytest.fixture(scope="module")
def weak(tmp_path_factory):
    path = tmp_path_factory.mktemp("assisted") / "weak.sigmf-data"
    prns, dopplers = write_weak(path, CN0_DBHZ, fix.DURATION_S, seed=3)
    return path, prns, dopplers


#: The search's results per recording: every run of a file starts from the same first samples,
#: so it is searched once (about 12 CPU-seconds at 2 MHz; `receive`'s ``acquisitions``).
_ACQUISITIONS: dict[str, list] = {}


def _receive(path, **kw):
    # The 10 ms parity search: the default 1 ms search finds none of them at this C/N0.
    acq = registry.create("acquisition", "pcps", coherent_ms=10, noncoherent=8, alternate_blocks=True)
    recording = open_recording(path)
    if str(path) not in _ACQUISITIONS:
        _ACQUISITIONS[str(path)] = acquire_recording(recording, acq, None)
    return receive(
        recording,
        acq,
        tracking_config(),
        rate_hz=5.0,
        rinex=read_rinex_nav(fix.NAV),
        acquisitions=_ACQUISITIONS[str(path)],
        **kw,
    )


@pytest.mark.slow
def test_the_scalar_receiver_has_no_fix_at_this_cn0(weak):
    """The same signals, timing and duration as `test_receiver_fix`, whose 45 dB-Hz file
    gives a fix 8.6 s in: here the 1 ms loops lose lock before bit sync and no channel
    decodes a subframe."""
    path, prns, _ = weak
    result = _receive(path)
    assert result.positions is None or len(result.positions) == 0
    assert set(result.tracking.channels) == set(prns)  # every one acquired: tracking is what fails
    assert any("lost" in text for ch in result.tracking.channels.values() for _, text in ch.events)


@pytest.fixture(scope="module")
def assisted(weak):
    return _receive(
        weak[0], vector=vector_config(solution_rate_hz=5.0), assist=assistance(approximate_position(), WEEK, fix.TOW0)
    )


@pytest.mark.slow
def test_assisted_vector_tracking_positions_every_satellite(weak, assisted):
    _, prns, _ = weak
    solution = assisted.vector
    assert set(solution.prns) == set(prns) and solution.handover_s < 0.5
    table = assisted.positions
    settled = table.sample_time_s > 2.0
    assert settled.sum() >= (fix.DURATION_S - 2.0) * 5 - 2 and np.all(table.columns["n_sats"][settled] == 5)
    err = np.linalg.norm(table.ecef_m[settled] - fix.STATION, axis=1)
    # Against the filter's own position covariance (four sigma of its 3D error, as RMS).
    k = np.searchsorted(np.asarray(solution.sample_time_s), table.sample_time_s[settled])
    sigma_3d = np.sqrt(np.trace(np.asarray(solution.cov)[k][:, :3, :3], axis1=1, axis2=2))
    assert np.sqrt(np.mean(err**2)) < 4 * np.sqrt(np.mean(sigma_3d**2)), (err, sigma_3d)
    # The week and time of week come from the assistance (no subframe decoded).
    assert np.all(table.columns["gps_week"] == WEEK)
    assert np.allclose(table.columns["tow_s"], fix.TOW0 + table.sample_time_s, atol=1e-6)


@pytest.mark.slow
def test_assisted_channels_follow_the_true_code_and_doppler(weak, assisted):
    """Every channel's code phase and Doppler in the loop against the generator's: within
    four standard deviations of the range and rate the filter predicts (its covariance on
    the line of sight, `test_vector_samples.sats_los`), plus the half chunk of Doppler the
    generator holds constant."""
    from test_vector_samples import sats_los

    _, prns, dopplers = weak
    solution = assisted.vector
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    t_sol, x, cov = np.asarray(solution.sample_time_s), np.asarray(solution.state), np.asarray(solution.cov)
    for k, prn in enumerate(prns):
        ch = assisted.tracking.channels[prn]
        t, dop, chips = ch.column("time_s"), ch.column("doppler_hz"), ch.column("code_phase_chips")
        rows = (t > 2.0) & (ch.column("stage") == 4)
        assert rows.sum() > 100
        j = np.clip(np.searchsorted(t_sol, t[rows]) - 1, 0, t_sol.size - 1)
        h = np.concatenate([-sats_los(sats, k, x[j, :3]), np.ones((j.size, 1))], axis=1)
        pc, vd = np.r_[0:3, 6], np.r_[3:6, 7]
        sigma_range = np.sqrt(np.einsum("ki,kij,kj->k", h, cov[j][:, pc][:, :, pc], h))
        sigma_rate = np.sqrt(np.einsum("ki,kij,kj->k", h, cov[j][:, vd][:, :, vd], h))
        truth_dop = dopplers[np.minimum((t[rows] / fix.CHUNK_S).astype(int), len(dopplers) - 1), k]
        assert np.sqrt(np.mean((dop[rows] - truth_dop) ** 2)) < 4 * np.sqrt(np.mean(sigma_rate**2)) / 0.1903
        t_sv = np.array([fix._satellite_time(sats, np.array(fix.TOW0 + ti))[k] for ti in t[rows]])
        code_err_m = ((chips[rows] - (t_sv * 1e3 % 1.0) * 1023 + 511.5) % 1023 - 511.5) * 293.05
        assert np.sqrt(np.mean(code_err_m**2)) < 4 * np.sqrt(np.mean(sigma_range**2))


@pytest.mark.slow
@pytest.mark.parametrize("lat_offset_deg", [3.0, 15.0])
def test_a_far_approximate_position_gives_no_wrong_fix(weak, lat_offset_deg):
    """330 km off, the range errors' differences still resolve every millisecond (the
    common part goes into the clock); 1700 km off they cannot: either way no loop is closed
    on a wrong fix (a fix far from the approximate position is refused)."""
    lat, lon, h = approximate_position()
    result = _receive(
        weak[0],
        vector=vector_config(solution_rate_hz=5.0),
        duration_s=2.0,
        assist=assistance((lat + lat_offset_deg, lon, h), WEEK, fix.TOW0),
    )
    table = result.positions
    if result.vector.handover_s is None:
        assert any("assisted fix failed" in text for _, text in result.vector.events)
        assert table is None or len(table) == 0
    else:
        assert np.all(np.linalg.norm(table.ecef_m - fix.STATION, axis=1) < 100.0)


def test_an_odd_block_count_of_the_parity_search_names_the_field():
    with pytest.raises(ConfigError, match="reacquire_noncoherent"):
        vector_config(reacquire_noncoherent=7)
    assert vector_config(reacquire_coherent_ms=1, reacquire_noncoherent=7).reacquire_noncoherent == 7


def test_bad_assistance_names_the_field():
    with pytest.raises(ConfigError, match="approx_position"):
        assistance((95.0, 0.0, 0.0), WEEK, 0.0)
    with pytest.raises(ConfigError, match="start_time"):
        assistance((45.0, 0.0, 0.0), WEEK, 700_000.0)


@pytest.mark.slow
def test_receive_refuses_assistance_without_vector_or_ephemeris(weak):
    rec = open_recording(weak[0])
    acq = registry.create("acquisition", "pcps")
    a = assistance(approximate_position(), WEEK, fix.TOW0)
    with pytest.raises(ConfigError, match="approx_position"):
        receive(rec, acq, tracking_config(), assist=a, duration_s=0.1)
    with pytest.raises(ConfigError, match="approx_position"):
        receive(rec, acq, tracking_config(), vector=vector_config(), assist=a, duration_s=0.1)


def test_position_command_starts_vector_tracking_from_the_assistance(weak, tmp_path, capsys):
    from gnssframework.cli import main

    lat, lon, h = approximate_position()
    args = [
        "position",
        str(weak[0]),
        "--out",
        str(tmp_path / "pos"),
        "--ephemeris",
        str(fix.NAV),
        "--rate",
        "5",
        "--tracking",
        "vector",
        "--coherent-ms",
        "10",
        "--noncoherent",
        "8",
        "--alternate-blocks",
        "--approx-position",
        f"{lat},{lon},{h}",
        "--start-time",
        f"{WEEK},{fix.TOW0}",
        "--duration",
        "3",
    ]
    code = main(args)
    out = capsys.readouterr().out
    assert code == 0, out
    assert "vector tracking from 0.1 s" in out
    assert len((tmp_path / "pos" / "positions.csv").read_text().splitlines()) > 5
    # No LNAV, yet observations: the vector channels dated from the assisted transmit times.
    assert (tmp_path / "pos" / "observations.rnx").read_text().count("\n> ") >= 10


@pytest.mark.parametrize(
    "extra",
    [
        ["--approx-position", "35,139,10"],
        ["--start-time", "1316,1.5"],
        ["--approx-position", "35,139", "--start-time", "1316,1.5"],
        ["--approx-position", "35,139,10", "--start-time", "1316"],
    ],
)
def test_bad_assistance_options_exit_2(weak, tmp_path, extra):
    from gnssframework.cli import main

    assert (
        main(
            [
                "position",
                str(weak[0]),
                "--out",
                str(tmp_path),
                "--ephemeris",
                str(fix.NAV),
                "--tracking",
                "vector",
                *extra,
            ]
        )
        == 2
    )


BLANK_S = 3.0  # the first satellite's signal is absent before this


@pytest.fixture(scope="module")
def blanked(tmp_path_factory):
    """35 dB-Hz, 6 s; the first of the five satellites blanked for its first 3 s."""
    path = tmp_path_factory.mktemp("blanked") / "blanked.sigmf-data"
    prns, _ = write_weak(path, 35.0, 6.0, seed=5, blank_until_s=(0, BLANK_S))
    result = _receive(
        path, vector=vector_config(solution_rate_hz=5.0), assist=assistance(approximate_position(), WEEK, fix.TOW0)
    )
    return prns, result


@pytest.mark.slow
def test_a_blanked_satellite_is_reacquired_in_the_predicted_window_and_joins_the_loop(blanked):
    """The loop starts on the four others; the blanked one is searched each second in the
    window the solution predicts (4 sigma of its range and rate), not found while absent
    (no false alarm), found at the first search after it returns, and then used."""
    prns, result = blanked
    gone = prns[0]
    solution = result.vector
    first = next(text for _, text in solution.events if text.startswith("assisted fix"))
    closed = {int(p) for p in first.split("vector tracking of PRN ")[1].split(", ")}
    assert solution.handover_s < 0.5 and closed == set(prns) - {gone}
    events = result.tracking.channels[gone].events
    found = [t for t, text in events if "re-acquired in the window predicted by the navigation solution" in text]
    assert len(found) == 1 and all(t >= BLANK_S for t, _ in events)
    # The searches run every reacquire_every_ms (1 s) of recording time.
    time_to_reacquire_s = found[0] - BLANK_S
    assert 0.0 <= time_to_reacquire_s <= tracking_config().reacquire_every_ms * 1e-3 + 0.1
    assert any(text == "vector tracking" for _, text in events)
    table = result.positions
    late = table.sample_time_s > found[0] + 1.0
    assert late.sum() >= 5 and np.all(table.columns["n_sats"][late] == 5)
    assert all(gone in used for used, keep in zip(table.used_prns, late) if keep)
    err = np.linalg.norm(table.ecef_m[late] - fix.STATION, axis=1)
    k = np.searchsorted(np.asarray(solution.sample_time_s), table.sample_time_s[late])
    sigma_3d = np.sqrt(np.trace(np.asarray(solution.cov)[k][:, :3, :3], axis1=1, axis2=2))
    assert np.sqrt(np.mean(err**2)) < 4 * np.sqrt(np.mean(sigma_3d**2)), (err, sigma_3d)


#: After the assisted start, the first satellite absent from 2 s to 4 s of a 7 s, 35 dB-Hz file.
MID_BLANK = (0, 2.0, 4.0)


@pytest.mark.slow
def test_a_blanked_vector_channel_is_dropped_and_reacquired_after_an_assisted_start(tmp_path):
    from test_vector_samples import assert_dropped_and_rejoined

    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    path = write_lnav_recording(tmp_path / "mid.sigmf-data", sats, fix.TOW0, 7.0, 13, blank=MID_BLANK, cn0_dbhz=35.0)
    result = _receive(
        path, vector=vector_config(solution_rate_hz=5.0), assist=assistance(approximate_position(), WEEK, fix.TOW0)
    )
    gone = int(sats.sv[0][1:])
    assert result.vector.handover_s < 0.5 and gone in result.vector.prns
    assert_dropped_and_rejoined(result, gone, MID_BLANK[1], MID_BLANK[2], settled_s=1.0)


#: PRN 1 is 2.4 deg above the station's horizon at the file's start (the other five 30-68 deg).
LOW_PRN, LOW_SET = 1, ("G01", "G11", "G19", "G20", "G24", "G28")


@pytest.mark.slow
def test_a_satellite_below_the_elevation_mask_is_tracked_but_not_used(tmp_path):
    """Six signals at 45 dB-Hz, one of them 2.4 deg up: the assisted start closes all six
    (the low one is driven by the solution) but only the five above the 5 deg mask enter
    the navigation filter's updates, as they would a least-squares fix."""
    nav = read_rinex_nav(fix.NAV)
    sats = nav.select(list(LOW_SET), fix.TOW0)
    path = write_lnav_recording(tmp_path / "low.sigmf-data", sats, fix.TOW0, 2.0, seed=5)
    result = receive(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        tracking_config(),
        rate_hz=5.0,
        rinex=nav,
        vector=vector_config(solution_rate_hz=5.0),
        assist=assistance(approximate_position(), WEEK, fix.TOW0),
    )
    solution = result.vector
    assert LOW_PRN in solution.prns and len(solution.prns) == 6
    used = np.asarray(solution.used)
    assert used.shape[0] > 50
    assert not used[:, LOW_PRN - 1].any()
    assert used[:, [int(s[1:]) - 1 for s in LOW_SET[1:]]].all()
    assert np.all(result.positions.columns["n_sats"] == 5)
