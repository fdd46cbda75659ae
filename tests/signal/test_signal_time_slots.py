"""Generic additions for time-multiplexed signals and long codes (GPS L2C's CM and CL): a
component's time slot and own code length in `SignalSpec`, and the pcps search holding a
bounded grid (PRNs in groups), checked on a toy description and on GPS L1 C/A."""

from __future__ import annotations

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend import SatelliteSignal, synthesize_samples
from gnssframework.signal.spec import Component, SignalSpec, Subcarrier


def _code(length):
    return lambda prn: (1 - 2 * np.random.default_rng(prn).integers(0, 2, length)).astype(np.int8)


def test_time_slots_cut_each_chip_and_long_components_keep_their_length():
    """Two components alternating chip by chip, one with a code 3 times longer; three slots
    under a sub-carrier of one piece a chip make three pieces (the lcm)."""
    spec = SignalSpec(
        "toy-tm",
        "X",
        "2X",
        1227.6e6,
        511.5e3,
        100,
        (1,),
        (
            Component("a", _code(100), time_slot=(0, 2)),
            Component("b", _code(300), time_slot=(1, 2), code_length_chips=300),
        ),
    )
    assert spec.subchips_per_chip == 2 and not spec.is_bpsk
    np.testing.assert_array_equal(spec.chip_pulse(0), [1, 0])
    np.testing.assert_array_equal(spec.chip_pulse(1), [0, 1])
    assert spec.component_code_length(1) == 300 and spec.spreading_table(1, 1).shape == (600,)
    np.testing.assert_array_equal(spec.spreading_table(1, 1)[1::2], spec.code(1, 1))
    three = SignalSpec(
        "toy-tm3",
        "X",
        "2X",
        1227.6e6,
        511.5e3,
        100,
        (1,),
        (Component("a", _code(100), time_slot=(2, 3)),),
        Subcarrier("boc", 0.25, 0.5),
    )
    assert three.subchips_per_chip == 3  # lcm(1, 3)
    np.testing.assert_array_equal(three.chip_pulse(0), [0, 0, 1])
    # Autocorrelation of a pulse 1/3 chip long: a triangle 1/3 chip wide.
    np.testing.assert_allclose(three.autocorrelation(np.array([0, 1 / 6, 1 / 3, 0.5])), [1, 0.5, 0, 0], atol=1e-12)


def test_a_bad_time_slot_is_refused_naming_the_field():
    from gnssframework.signal.spec import Component, SignalSpec

    with pytest.raises(ConfigError, match="time_slot"):
        SignalSpec("x", "G", "2S", 1227.6e6, 511.5e3, 10230, (1,), (Component("CM", lambda p: None, time_slot=(2, 2)),))


def test_searching_the_prns_in_groups_gives_the_search_of_all_at_once(monkeypatch):
    """The pcps search holds at most ``_GRID_ELEMENTS`` of grid at once (a 20 ms code's grid
    is 400 times a 1 ms code's): PRN by PRN it must give what one grid of all PRNs gives."""
    import gnssframework_plugins.acquisition as pcps_module

    fs = 2.6e6
    x = synthesize_samples(
        [SatelliteSignal(7, 45.0, 1200.0, 100.0), SatelliteSignal(21, 42.0, -800.0, 700.0)],
        0.004,
        fs,
        0.0,
        np.random.default_rng(2),
    )
    acq = registry.create("acquisition", "pcps", noncoherent=4, doppler_max_hz=2000.0)
    whole = acq.acquire(x, fs, 0.0, (3, 7, 21))
    calls = []
    search_grid = pcps_module.search_grid
    monkeypatch.setattr(pcps_module, "search_grid", lambda *a, **k: calls.append(a[3]) or search_grid(*a, **k))
    monkeypatch.setattr(pcps_module, "_GRID_ELEMENTS", 1)
    assert acq.acquire(x, fs, 0.0, (3, 7, 21)) == whole
    assert calls == [(3,), (7,), (21,)]  # one grid a PRN
    assert [r.prn for r in whole if r.detected] == [7, 21]
