"""The tutorial's 'Subclass a built-in' example runs as written and does what it says."""

from __future__ import annotations

import re
import types
from pathlib import Path

import numpy as np

import gnssframework as gf
from gnssframework.signal.correlators import Correlators

PAGE = Path(__file__).resolve().parents[2] / "docs" / "tutorial" / "from-plugin-to-comparison.md"


def test_a_subclassed_built_in_registers_clips_and_keeps_its_noise_variance(scratch_registry):
    (block,) = [b for b in re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S) if "class ClippedEml" in b]
    namespace: dict = {"__name__": "tutorial_clipped"}
    exec(compile(block, str(PAGE), "exec"), namespace)  # noqa: S102 - the page's own code
    scratch_registry.register_module(
        types.SimpleNamespace(register_discriminator=namespace["register_discriminator"]), "tutorial-clipped"
    )
    d = gf.registry.create("discriminator", "eml-clipped", max_chips=0.2, coherent_time_s=0.02)
    builtin = gf.registry.create("discriminator", "eml-envelope", coherent_time_s=0.02)
    far = Correlators(early=np.array([1.0 + 0j]), prompt=np.array([2.0 + 0j]), late=np.array([3.0 + 0j]))
    near = Correlators(early=np.array([1.9 + 0j]), prompt=np.array([2.0 + 0j]), late=np.array([2.0 + 0j]))
    assert builtin(far)[0] > 0.2 and d(far)[0] == 0.2  # clipped
    assert d(near)[0] == builtin(near)[0]  # unchanged inside the clip
    assert d.noise_variance(45.0) == builtin.noise_variance(45.0)
