"""Blocks whose GPS L1 C/A default became a ``signal: SignalSpec = GPS_L1CA`` parameter read
the numbers of the signal they are handed (issue 36). Each expectation is worked by hand
from the signals' ICD numbers, not from the code under test."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gnssframework.receiver.frontend.sigmf_meta import read_sigmf_meta, write_sigmf_meta
from gnssframework.receiver.navigation.bit_stream import bit_ms, bit_runs
from gnssframework.receiver.navigation.vector_solution import VectorSolution
from gnssframework.signal.channel_model import channel_transition
from gnssframework.signal.gps_l2c import GPS_L2C
from gnssframework.signal.navdata import bit_at
from gnssframework.signal.qzss_l1ca import QZSS_L1CA
from gnssframework.signal.sbas_l1 import SBAS_L1


def test_bit_at_takes_the_bit_period_of_the_signal_it_is_handed():
    bits = np.array([1, -1, 1, -1], dtype=np.int8)
    t = np.array([0.0031, 0.0199, 0.0201])
    # SBAS L1: 500 symbols/s, a 2 ms symbol: t = 3.1 ms is in symbol 1, 19.9 ms in the last.
    assert bit_at(t, bits, signal=SBAS_L1).tolist() == [-1, -1, -1]
    # The default (C/A, 20 ms bits): 3.1 and 19.9 ms in bit 0, 20.1 ms in bit 1.
    assert bit_at(t, bits).tolist() == [1, 1, -1]
    assert bit_at(t, bits, bit_period_s=0.002).tolist() == [-1, -1, -1]


def test_the_channel_transition_couples_code_to_carrier_by_the_signals_rates():
    T = 0.01  # F[1, 3]: the code error's (chips) growth per Hz of frequency error over T
    # L2C: each of CM and CL at 511.5 kchip/s (time-multiplexed into 1.023 Mchip/s) over
    # 1227.60 MHz (IS-GPS-200 3.3.1.1, 3.2.1.4); C/A: 1.023 / 1575.42.
    assert channel_transition(T, signal=GPS_L2C)[1, 3] == pytest.approx(0.5115 / 1227.60 * T, rel=1e-12)
    assert channel_transition(T)[1, 3] == pytest.approx(1.023 / 1575.42 * T, rel=1e-12)
    assert channel_transition(T, 0.5)[1, 3] == pytest.approx(0.5 * T)  # an explicit ratio still wins


def test_the_sigmf_rf_frequency_is_the_carrier_of_the_signal_recorded(tmp_path):
    path = tmp_path / "a.sigmf-meta"
    write_sigmf_meta(path, format="ci16", sigmf_datatype="ci16_le", sample_rate_hz=4e6, if_hz=0.1e6, signal=GPS_L2C)
    meta = json.loads(path.read_text())
    assert meta["captures"][0]["core:frequency"] == pytest.approx(1227.60e6 - 0.1e6)
    del meta["global"]["gnssframework:if_hz"]  # the IF from core:frequency and the signal's carrier
    path.write_text(json.dumps(meta))
    assert read_sigmf_meta(path, signal=GPS_L2C).if_hz == pytest.approx(0.1e6)
    assert read_sigmf_meta(path).if_hz == pytest.approx(1575.42e6 - 1227.50e6)  # read as L1


def test_a_vector_solutions_slots_are_its_signals_prns():
    assert VectorSolution().slot_prns == tuple(range(1, 33))  # GPS PRNs 1-32
    assert VectorSolution(signal=QZSS_L1CA).slot_prns == tuple(range(193, 203))  # QZSS L1 C/A 193-202


def test_bit_runs_sum_the_signals_own_bits():
    t = np.arange(8) * 1e-3  # eight 1 ms rows, all bit-aligned
    prompt = np.array([1.0, 1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0])
    ones, aligned = np.ones(8, int), np.ones(8, bool)
    assert (bit_ms(SBAS_L1), bit_ms()) == (2, 20)  # SBAS 500 sps; C/A LNAV 50 bit/s
    (run,) = bit_runs(t, prompt, ones, aligned, signal=SBAS_L1)  # two rows a symbol
    assert run.symbols.tolist() == [2.0, -2.0, 2.0, -2.0]
    assert bit_runs(t, prompt, ones, aligned) == []  # 8 ms is not one whole 20 ms C/A bit
