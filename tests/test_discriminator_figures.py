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

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / "docs" / "make_plots.py"


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
