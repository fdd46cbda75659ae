"""The suite passes with a third-party plugin installed beside the project (issue 37): every
test of the built-ins selects the built-in distribution's entries (`conftest.builtin_plugins`),
never the whole registry, so an outside package's ``coherent-eml`` is not a built-in.

The outside package is installed the way pip leaves one, as far as the registry can tell: a
module and a ``*.dist-info`` folder with its ``[gnssframework]`` entry point, on ``sys.path``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from conftest import BUILTIN_DISTRIBUTION, builtin_names
from gnssframework import registry

TESTS = Path(__file__).resolve().parents[1]

#: An outside package with a plugin of the kinds whose built-ins the tests hold to exact sets or
#: to the project's conventions: a code discriminator (the issue's ``coherent-eml``), an estimator
#: whose class name is not in ``gnssframework.estimators``, a channel filter that provides a name
#: outside ``gnssframework.names``, and a sample source.
OUTSIDE_MODULE = '''
import gnssframework as gf
# Imported by name, as the plugin template does (the registry is loading this module).
from gnssframework_plugins.discriminators import EarlyMinusLateEnvelope as EmlEnvelope
from gnssframework_plugins.estimators import KalmanFilter
from gnssframework_plugins.sample_sources import ComplexInt8 as Ci8
from gnssframework_plugins.smoothers import HatchFilter as Hatch


class CoherentEml(EmlEnvelope):
    """Coherent early-minus-late (an outside package's)."""
    name = "coherent-eml"


class OutsideKf(KalmanFilter):
    """A Kalman filter from an outside package, without a word on its parameters."""
    name = "outside-kf"


class QualityHatch(Hatch):
    """A Hatch filter that also provides a quality figure of its own naming."""
    name = "quality-hatch"
    provides = (*Hatch.provides, "outside_quality")


class Ci8Copy(Ci8):
    """An 8-bit complex format under another name."""
    name = "outside-ci8"


@gf.hookimpl
def register_discriminator(register):
    register(CoherentEml)


@gf.hookimpl
def register_estimator(register):
    register(OutsideKf)


@gf.hookimpl
def register_channel_filter(register):
    register(QualityHatch)


@gf.hookimpl
def register_sample_source(register):
    register(Ci8Copy)
'''

OUTSIDE_DISTRIBUTION = "gnssframework-outside"

#: The tests that hold the built-ins to an exact set or to a convention over every built-in.
BUILTIN_TESTS = [
    "signal/test_discriminators.py::test_units_and_registry",
    "core/test_names.py::test_every_builtin_sequential_filter_uses_the_shared_names",
    "estimation/test_library_surface.py::test_typed_classes_are_the_registered_plugins_with_signatures",
    "core/test_cli_usability.py::test_no_rest_markup_in_help_or_the_plugin_listing",
    "core/test_cli_usability.py::test_every_built_in_without_parameters_says_why",
    "receiver/test_frontend.py::test_the_built_in_formats_are_sample_source_plugins",
    "core/test_registry.py::test_kinds_and_builtin_names",
    "core/test_registration.py::test_every_builtin_is_defined_in_one_module_and_named_in_no_other",
    "core/test_registration.py::test_every_builtin_scenario_metric_is_declared_by_one_component_of_its_module",
    "core/test_registration.py::test_scenarios_are_found_in_the_registry_only",
    "project/test_plugin_pages.py::test_every_built_in_plugin_has_a_page_that_gets_its_table",
    "project/test_plugin_pages.py::test_the_tutorial_lists_every_nested_plugin_parameter_of_the_built_ins",
    "project/test_docs.py::test_plugin_parameter_page_is_up_to_date",
]


def install_outside_package(site: Path) -> Path:
    """Write the outside package and its distribution metadata into ``site`` (a folder to put
    on ``sys.path``, as pip's site-packages)."""
    (site / "gnssframework_outside.py").write_text(textwrap.dedent(OUTSIDE_MODULE))
    info = site / "gnssframework_outside-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {OUTSIDE_DISTRIBUTION}\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text("[gnssframework]\noutside = gnssframework_outside\n")
    return site


@pytest.fixture
def outside_site(tmp_path, monkeypatch, scratch_registry):
    """The outside package installed for this process: the registry rediscovers the entry
    points and finds it; afterwards the registry forgets it (scratch_registry)."""
    site = install_outside_package(tmp_path)
    monkeypatch.syspath_prepend(str(site))
    registry.reload()
    yield site
    sys.modules.pop("gnssframework_outside", None)


def test_the_outside_plugin_is_registered_but_is_no_built_in(outside_site):
    info = {(i.kind, i.name): i for i in registry.describe()}
    assert info["discriminator", "coherent-eml"].distribution == OUTSIDE_DISTRIBUTION
    assert registry.failures() == []
    assert "coherent-eml" in registry.names("discriminator")
    assert "coherent-eml" not in builtin_names("discriminator")
    assert builtin_names("discriminator") == sorted(
        n for n in registry.names("discriminator") if info["discriminator", n].distribution == BUILTIN_DISTRIBUTION
    )
    assert {"outside-kf", "quality-hatch", "outside-ci8"}.isdisjoint(
        builtin_names("estimator") + builtin_names("channel_filter") + builtin_names("sample_source")
    )


@pytest.mark.slow
def test_the_built_in_tests_pass_with_the_outside_plugin_installed(tmp_path):
    """The tests of the built-ins, in a fresh process (their parameter lists are built at
    collection) that finds the outside package through its entry point."""
    site = install_outside_package(tmp_path)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))}
    probe = subprocess.run(
        [
            sys.executable,
            "-c",
            "from gnssframework import registry; print(registry.get('discriminator', 'coherent-eml').__module__)",
        ],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    assert probe.stdout.strip() == "gnssframework_outside"  # the run below does see the plugin
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:xdist",
            "-p",
            "no:cacheprovider",
            *(str(TESTS / t) for t in BUILTIN_TESTS),
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=TESTS.parent,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
