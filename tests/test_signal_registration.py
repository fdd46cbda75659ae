"""The ``signal`` plugin kind: the built-in GPS L1 C/A and a third party's signal register
and are found by name like any plugin."""

from __future__ import annotations

import types
from dataclasses import replace

import pytest

import gnssframework as gf
from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.signal.gps_l1ca import GPS_L1CA
from gnssframework.signal.registered import Signal


def test_the_built_in_gps_l1ca_is_the_description_the_constants_are_read_from():
    spec = registry.signal_spec("gps-l1ca")
    assert spec is GPS_L1CA
    # IS-GPS-200 3.3.1.1 / 3.2.1.3: 154 x 10.23 MHz carrier, 10.23 MHz / 10 chip rate.
    assert spec.carrier_freq_hz == 154 * 10.23e6 and spec.chip_rate_hz == 10.23e6 / 10


def test_an_unknown_signal_names_the_known_ones():
    with pytest.raises(ConfigError, match="unknown signal 'gps-l1c'; known: .*gps-l1ca"):
        registry.signal_spec("gps-l1c")


def test_a_third_party_signal_registers_through_the_hook(scratch_registry):
    other = replace(GPS_L1CA, name="test-l1ca-copy", system="J")

    class OtherSignal(Signal):
        name = "test-l1ca-copy"
        spec = other
        description = "a copy of L1 C/A under another name"

    module = types.SimpleNamespace(register_signal=gf.hookimpl(lambda register: register(OtherSignal)))
    registry.register_module(module, name="test-signal", distribution="someone-elses-package")
    assert registry.signal_spec("test-l1ca-copy") is other
    assert "test-l1ca-copy" in registry.names("signal")


def test_a_signal_class_whose_name_differs_from_its_spec_is_refused():
    with pytest.raises(TypeError, match="differs from its spec's name 'gps-l1ca'"):
        class Wrong(Signal):  # noqa: F841
            name = "not-gps"
            spec = GPS_L1CA
