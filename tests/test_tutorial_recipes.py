"""The plugin tutorial's recipes run as written and say what the code does (issue 37)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.interfaces import Discriminator

DOCS = Path(__file__).resolve().parents[1] / "docs" / "tutorial"


def _block(page: str, marker: str) -> str:
    (block,) = [b for b in re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(), re.S) if marker in b]
    return block


@pytest.mark.parametrize("name", ["eml-envelope", "dot-product"])
def test_the_broadcasting_recipe_passes_on_a_built_in(name):
    namespace: dict = {"MyDiscriminator": gf.registry.get("discriminator", name)}
    exec(compile(_block("writing-a-plugin.md", "def test_my_discriminator_broadcasts"), "recipe", "exec"),  # noqa: S102
         namespace)
    namespace["test_my_discriminator_broadcasts"]()


def test_the_broadcasting_recipe_catches_a_discriminator_that_mixes_batch_elements():
    class Mixing(Discriminator):
        name = "mixing"
        unit = "chips"

        def __call__(self, current, previous=None):
            e, p = np.abs(current.early), np.abs(current.prompt)
            return (e - np.abs(current.late)) / np.mean(p)   # normalised by the whole batch: a bug

        def noise_variance(self, cn0_dbhz):
            return 1.0

    namespace: dict = {"MyDiscriminator": Mixing}
    exec(compile(_block("writing-a-plugin.md", "def test_my_discriminator_broadcasts"), "recipe", "exec"),  # noqa: S102
         namespace)
    with pytest.raises(AssertionError):
        namespace["test_my_discriminator_broadcasts"]()


def test_every_built_in_code_discriminator_declares_its_spacing_as_the_tutorial_says():
    # A keyword a plugin's Params does not declare is dropped by the harness's create(), so
    # a code discriminator without the field would silently run at its own spacing.
    code = [n for n in gf.registry.names("discriminator") if gf.registry.get("discriminator", n).unit == "chips"]
    assert code
    for name in code:
        assert "early_late_spacing_chips" in gf.registry.get("discriminator", name).Params.model_fields, name
    d = gf.registry.create("channel_filter", "scalar").params.code_discriminator.create(
        coherent_time_s=0.01, early_late_spacing_chips=0.25)
    assert d.params.early_late_spacing_chips == 0.25
    assert "declares its spacing" in (DOCS / "from-plugin-to-comparison.md").read_text()
