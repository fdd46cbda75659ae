"""BeiDou B1I from the D1 satellites and from the GEOs in one fix: `beidou-b1i` (NH20, D1)
and `beidou-b1i-geo` (D2 at 500 bit/s) are one observable (one carrier, RINEX C2I, disjoint
PRNs), so a `SignalSet` holds both and one receiver clock serves them.

The recording (`inav_recordings.write_b1i_geo_recording`): the three highest of the
relabelled BeiDou records (`inav_recordings.bds_records`) sending B1I with D1, and two GEOs
(`inav_recordings.geo_records`: VILL's real C05 and a made-up C01 on the same orbit further
west) sending B1I with D2, seen from VILL, 8 s at 4.2 MHz. Three D1 satellites alone give no
fix: every fix here needs both GEOs, their D2 dating and the GEO orbit formula
(BDS-SIS-ICD-B1I 5.2.4.12). Truths: the station; each satellite's SV time at every dated row."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.navigation.ephemeris import Ephemerides
from gnssframework.receiver.channels import signal_tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.multi_receive import KEY_STEP, SignalSet, receive_signals
from gnssframework.receiver.navigation.rinex_nav import NavRecord, write_rinex_nav
from gnssframework.signal.beidou_b1i import BEIDOU_B1I, BEIDOU_B1I_GEO
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.gps_l2c import GPS_L2C
from inav_recordings import (
    GPS_WEEK,
    STATION,
    bds_records,
    geo_records,
    highest,
    satellite_time,
    write_b1i_geo_recording,
)
from light_time import position_dop

pytestmark = pytest.mark.slow  # end to end (the fast lane leaves these out)

#: A D1 frame (subframe 1) starts on BDT 18030 s = GPS 18044 s, about 0.6 s in.
TOW0 = 18_044.0 - 0.6
DURATION_S = 8.0
C = 299_792_458.0
B1I = SignalSet((BEIDOU_B1I, BEIDOU_B1I_GEO))


@pytest.fixture(scope="module")
def geo_meo(tmp_path_factory):
    meo, geo = highest(bds_records(), TOW0, 3), geo_records()
    path = tmp_path_factory.mktemp("geo") / "b1i_geo.sigmf-data"
    write_b1i_geo_recording(path, meo, geo, TOW0, DURATION_S, seed=3)
    records = Ephemerides.concatenate([bds_records(), geo])
    result = receive_signals(
        open_recording(path),
        registry.create("acquisition", "pcps"),
        [signal_tracking_config(s) for s in B1I.signals],
        B1I,
        rate_hz=2.0,
        rinex=records,
        reference_week=GPS_WEEK,
    )
    return path, meo, geo, records, result


def _transmit_errors_m(obs, sats, index):
    """Each dated transmit time of the ``index``-th signal's satellites ``sats`` less their
    SV time (m)."""
    out = []
    for j, key in enumerate(obs.prn):
        name = B1I.rinex_satellite(int(key))
        if int(key) // KEY_STEP != index or name not in list(sats.sv):
            continue
        k = list(sats.sv).index(name)
        ok = np.isfinite(obs.transmit_s[:, j])
        truth = satellite_time(sats.subset(np.array([k])), TOW0 + obs.sample_time_s[ok])
        out.append((obs.transmit_s[ok, j] - truth) * C)
    return np.concatenate(out)


def test_one_set_holds_b1is_two_signals_and_refuses_two_observables_of_a_system():
    assert [s for s, _ in B1I.groups] == [BEIDOU_B1I] and B1I.groups[0][1] == (0, 1)
    assert B1I.wavelength_m == BEIDOU_B1I.wavelength_m  # one carrier
    with pytest.raises(ConfigError, match="gps-l1ca and gps-l2c.*one observable"):
        SignalSet((GPS_L1CA, GPS_L2C))  # two carriers, two observation codes, the same PRNs


def test_every_fix_uses_the_d1_satellites_and_both_geos(geo_meo):
    """Both GEOs dated from their D2 (0.6 s subframes) as the D1 ones from theirs; every
    fix holds all five satellites (three alone give none); each row's transmit time is the
    generator's B1I time within 5 % of a chip for either signal; the fixes are on the
    station within three PDOPs of the larger error."""
    _, meo, geo, _, result = geo_meo
    obs, table = result.observables, result.positions
    assert sorted(B1I.rinex_satellite(int(k)) for k in obs.prn) == sorted([*meo.sv, *geo.sv])
    # D1's Klobuchar coefficients reach the fixes (`Observables.bds_iono`): the generator's
    # subframe 1 sends zeros (and delays nothing: the model's 5 ns at night is left in).
    assert obs.bds_iono is not None and obs.bds_iono.alpha == (0.0,) * 4
    assert table is not None and len(table) >= 2 * (DURATION_S - 2)
    assert all(len(u) == 5 for u in table.used_prns)
    sigma = []
    for index, sats in ((0, meo), (1, geo)):
        err = _transmit_errors_m(obs, sats, index)
        sigma.append(float(np.sqrt(np.mean(err**2))))
        assert sigma[-1] < 0.05 * BEIDOU_B1I.chip_length_m, (index, sigma[-1])
    pdop = position_dop(Ephemerides.concatenate([meo, geo]), TOW0 + 4.0, STATION)
    rms = float(np.sqrt(np.mean(np.linalg.norm(table.ecef_m - STATION, axis=1) ** 2)))
    assert rms < 3 * pdop * max(sigma), (rms, pdop, sigma)


def test_the_command_lists_beidou_once_in_each_output(geo_meo, tmp_path):
    """What a user types: ``--signal beidou-b1i,beidou-b1i-geo`` with a navigation file of the
    records sent. The observation file has one BeiDou line of types (C2I ...) and all five
    satellites; each epoch's NMEA has one GSA for BeiDou (system ID 4) with the five used
    and one GSV group (talker GB) counting them all; each epoch of the observation file is one
    BeiDou MSM7 (1127, signal 2I) dated in BDT."""
    import io

    import georinex
    import pynmea2
    from pyrtcm import RTCMReader, parse_msm

    path, meo, geo, records, _ = geo_meo
    sent = Ephemerides.concatenate([meo, geo])
    navs = [
        NavRecord(
            B1I.key(0 if int(sv[1:]) in BEIDOU_B1I.prns else 1, int(sv[1:])),
            sent.subset(np.array([k])),
            GPS_WEEK,
            18_000.0,
        )
        for k, sv in enumerate(sent.sv)
    ]
    nav = write_rinex_nav(tmp_path / "b1i.rnx", navs, signal=B1I)  # type: ignore[arg-type]
    out = tmp_path / "out"
    args = ["receive", str(path), "--signal", "beidou-b1i,beidou-b1i-geo", "--ephemeris", str(nav), "--rate", "2"]
    assert main([*args, "--outputs", "gsa,gsv,rtcm", "--out", str(out), "--quiet"]) == 0
    header = (out / "observations.rnx").read_text().split("END OF HEADER")[0]
    types = [line for line in header.splitlines() if "SYS / # / OBS TYPES" in line]
    assert len(types) == 1 and types[0].startswith("C    4 C2I L2I D2I S2I")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        obs = georinex.load(out / "observations.rnx")
    assert sorted(obs.sv.values) == sorted(sent.sv)
    sentences = [pynmea2.parse(line) for line in (out / "nmea.txt").read_text().splitlines()]
    gsa = [s for s in sentences if s.sentence_type == "GSA"]
    gsv = [s for s in sentences if s.sentence_type == "GSV"]
    gga = [s for s in sentences if s.sentence_type == "GGA"]
    assert len(gsa) == len(gga) and {s.data[-1] for s in gsa} == {"4"}
    assert all(sorted(int(x) for x in s.data[2:14] if x) == sorted(int(v[1:]) for v in sent.sv) for s in gsa)
    assert {s.talker for s in gsv} == {"GB"} and all(int(s.num_sv_in_view) == 5 for s in gsv)
    assert sum(int(s.msg_num) == 1 for s in gsv) == len(gga)  # one group per fix
    msgs = [
        (m.identity, int(m.DF393), *parse_msm(m))
        for _, m in RTCMReader(io.BytesIO((out / "observations.rtcm3").read_bytes()), validate=1)
    ]
    epochs = [ln.split() for ln in (out / "observations.rnx").read_text().splitlines() if ln.startswith("> ")]
    assert [m[:2] for m in msgs] == [("1127", 0)] * len(epochs)  # one BeiDou MSM7 an epoch
    assert [len(m[3]) for m in msgs] == [int(f[8]) for f in epochs]  # the epoch's satellites
    assert [len(m[3]) for m in msgs][-1] == 5 and all({c["CELLSIG"] for c in m[4]} == {"2I"} for m in msgs)
    # Each MSM's epoch is BDT (DF427): the observation file's epoch (GPS time) less 14 s.
    day_s = [(int(f[4]) * 60 + int(f[5])) * 60 + float(f[6]) for f in epochs]
    sunday = 0  # 2022-02-20, the recording's day, is a Sunday: the time of week is the time of day
    assert [m[2]["epoch"] for m in msgs] == [round((sunday + t - 14.0) * 1e3) for t in day_s]
