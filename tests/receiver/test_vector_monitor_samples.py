"""The channel fault monitor in vector tracking on samples (`VectorNavigator`).

The five satellites of `test_receiver_fix` on the project's generator at 45 dB-Hz; from
10.5 s (after the LNAV hand-over at the first fix, 8.6 s in) one satellite's code, not its
carrier, arrives 100 m late: a code fault the navigation model lacks. With
``monitor_false_alarm`` the navigator leaves that channel out of the update within half a
second of the fault (an event says so; not before it), and the position error after the
fault is below that of the same loop without the monitor. (The monitor also flags short
bursts of another channel of this recording, whose code errors reach ~140 m for a few
intervals every ~0.38 s: left out while they last, as it should be.)
"""

from __future__ import annotations

import numpy as np
import pytest

import test_receiver_fix as fix
from gnssframework import registry
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend import open_recording
from gnssframework.receiver.navigation.receive import receive
from gnssframework.receiver.navigation.vector_tracking import vector_config
from lnav_recordings import write_lnav_recording

DURATION_S, FAULT_S, DELAY_M = 13.0, 10.5, 100.0


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    sats = fix._strongest(read_rinex_nav(fix.NAV), fix.TOW0, 5)
    path = write_lnav_recording(
        tmp_path_factory.mktemp("vfault") / "fault.sigmf-data",
        sats,
        fix.TOW0,
        DURATION_S,
        seed=7,
        code_delay=(0, FAULT_S, DELAY_M),
    )
    out = {}
    for name, extra in (("monitor", {"monitor_false_alarm": 1e-3}), ("none", {})):
        out[name] = receive(
            open_recording(path),
            registry.create("acquisition", "pcps"),
            tracking_config(),
            rate_hz=5.0,
            rinex=read_rinex_nav(fix.NAV),
            vector=vector_config(solution_rate_hz=5.0, **extra),
        )
    return int(sats.sv[0][1:]), out


def _errors(result):
    sol = result.vector
    t = np.asarray(sol.sample_time_s)
    return t, np.linalg.norm(np.asarray(sol.state)[:, :3] - fix.STATION, axis=1)


@pytest.mark.slow
def test_the_monitor_leaves_the_faulty_channel_out_and_keeps_the_position(runs):
    bad, out = runs
    sol = out["monitor"].vector
    assert sol.handover_s is not None and sol.handover_s < FAULT_S
    left = [(t, text) for t, text in sol.events if "left out of the navigation update by the channel monitor" in text]
    # The faulty channel is the first one left out after the fault, within half a second.
    first = [(t, text) for t, text in left if t >= FAULT_S][0]
    assert first[1].startswith(f"PRN {bad}:") and first[0] < FAULT_S + 0.5, sol.events
    assert not any(text.startswith(f"PRN {bad}:") for t, text in left if t < FAULT_S)
    t, err = _errors(out["monitor"])
    t0, err0 = _errors(out["none"])
    # Left out, the fault no longer pulls the solution as it does the same loop's without the
    # monitor (this short recording's vector solution is tens of metres off already before
    # the fault: the comparison, not an absolute bound).
    assert np.sqrt(np.mean(err[t > FAULT_S + 1.0] ** 2)) < 0.8 * np.sqrt(np.mean(err0[t0 > FAULT_S + 1.0] ** 2))


@pytest.mark.slow
def test_the_vector_rows_carry_protection_levels_and_the_monitors_verdict(runs):
    bad, out = runs
    sol = out["monitor"].vector
    table = sol.table(5.0, integrity_risk=1e-7)  # what receive --tracking vector --raim writes
    t = table.sample_time_s
    rows = np.asarray(sol.monitor_excluded)[np.searchsorted(sol.sample_time_s, t)]  # (rows, slots)
    bad_out = rows[:, sol.slot_prns.index(bad)]
    # The faulty channel is out at rows after the fault (it is readmitted now and then while
    # its innovations pass), never before; each row's status is the monitor's verdict.
    assert np.any(bad_out[t > FAULT_S]) and not np.any(bad_out[t < FAULT_S])
    np.testing.assert_array_equal(table.columns["raim"] == "excluded", rows.any(axis=1))
    lowest = [min((p for p, o in zip(sol.slot_prns, r) if o), default=0) for r in rows]
    np.testing.assert_array_equal(table.excluded_prn, lowest)
    assert np.all(np.isfinite(table.columns["hpl_m"])) and np.all(table.columns["vpl_m"] > 0)
    assert "raim" not in out["none"].vector.table(5.0).columns
