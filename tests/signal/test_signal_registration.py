"""The ``signal`` plugin kind: the built-in GPS L1 C/A and a third party's signal register
and are found by name like any plugin."""

from __future__ import annotations

import types
from dataclasses import replace

import pytest

import gnssframework as gf
from gnssframework import registry
from gnssframework.errors import ConfigError, PluginError
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
    with pytest.raises(PluginError, match="differs from its spec's name 'gps-l1ca'"):

        class Wrong(Signal):  # noqa: F841
            name = "not-gps"
            spec = GPS_L1CA


@pytest.fixture()
def installed_package(tmp_path):
    """A third party's package 'installed' beside the project: a module and a .dist-info
    whose entry_points.txt points the gnssframework group at it (what pip would write)."""
    import sys
    import textwrap

    pkg = tmp_path / "thirdsig_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(
        "from gnssframework.registry import plugin_hooks, submodules\n\n"
        "globals().update(plugin_hooks(*submodules(__name__, __path__)))\n"
    )
    (pkg / "toy.py").write_text(
        textwrap.dedent("""
        import numpy as np

        from gnssframework.signal.registered import Signal
        from gnssframework.signal.spec import Component, SignalSpec, Subcarrier


        def toy_code(prn):
            return (1 - 2 * np.random.default_rng(prn).integers(0, 2, 4092)).astype(np.int8)


        TOY_E1 = SignalSpec("thirdsig-boc", "E", "1C", 1575.42e6, 1.023e6, 4092, tuple(range(1, 37)),
                            (Component("pilot", toy_code),), Subcarrier("boc", 1.0, 1.0))


        class ToyE1(Signal):
            name = "thirdsig-boc"
            spec = TOY_E1
            description = "a third party's BOC(1,1) pilot"
        """)
    )
    dist = tmp_path / "thirdsig-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: thirdsig\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[gnssframework]\nthirdsig = thirdsig_pkg\n")
    sys.path.insert(0, str(tmp_path))
    yield tmp_path
    sys.path.remove(str(tmp_path))
    for name in [m for m in sys.modules if m.startswith("thirdsig_pkg")]:
        del sys.modules[name]


def test_a_third_party_signal_installed_through_the_entry_point_group(scratch_registry, installed_package):
    registry.reload()  # rediscover the entry points, as after `pip install`
    info = {i.name: i for i in registry.describe() if i.kind == "signal"}
    assert info["thirdsig-boc"].distribution == "thirdsig" and info["thirdsig-boc"].version == "0.1"
    spec = registry.signal_spec("thirdsig-boc")
    assert spec.subchips_per_chip == 2 and spec.code(36).shape == (4092,)
    assert "gps-l1ca" in info and not registry.failures()
