"""docs/make_plots.py draws the S-curve and the noise figure of every built-in
discriminator, each on the taps and signal it reads: a discriminator with extra taps
(the BOC side-peak detectors' very-early and very-late) or a BOC main peak must not stop
the figure script (CI regenerates every figure; a missing tap stopped it once)."""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest
from conftest import builtin_names

import gnssframework as gf

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "docs" / "make_plots.py"


@pytest.fixture(scope="module")
def make_plots():
    spec = importlib.util.spec_from_file_location("make_plots", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", builtin_names("discriminator"))
def test_every_discriminator_has_its_figures(make_plots, name, tmp_path, monkeypatch):
    monkeypatch.setattr(make_plots, "OUT", tmp_path)
    make_plots.s_curve(name)
    make_plots.noise_curve(name, np.random.default_rng(1), draws=50)
    for figure in (f"scurve-{name}.png", f"noise-{name}.png"):
        assert (tmp_path / figure).stat().st_size > 1000, figure


@pytest.mark.parametrize("name", ["boc-eml", "boc-vemlp", "bump-jumping"])
def test_boc_figures_read_a_boc_main_peak(make_plots, name):
    """The BOC discriminators' noise-free taps: unit slope on BOC(1,1)'s main peak (R = 1 - 3|tau|),
    which the C/A triangle would not give (there the output is a third of the error)."""
    d = gf.registry.create("discriminator", name, coherent_time_s=make_plots.T)
    e = np.array([-0.05, 0.05])
    np.testing.assert_allclose(d(make_plots._noise_free(d, code=e)), e, atol=1e-9)


@pytest.mark.parametrize(
    "name", [n for n in builtin_names("discriminator") if gf.registry.get("discriminator", n).unit == "chips"]
)
def test_a_code_discriminator_has_unit_slope_on_the_modulation_it_declares(make_plots, name):
    """`Discriminator.modulation` picks the figures' signal: on its declared modulation's
    noise-free correlators every code discriminator reads a small error as itself (unit slope
    in the linear region); on the other modulation the BOC ones read 3x, the BPSK ones 1/3x
    (a wrong declaration fails here)."""
    d = gf.registry.create("discriminator", name, coherent_time_s=make_plots.T)
    assert d.modulation in make_plots.SIGNAL_OF_MODULATION
    e = np.array([-0.02, 0.02])
    np.testing.assert_allclose(d(make_plots._noise_free(d, code=e)), e, rtol=0.05, atol=1e-6)
