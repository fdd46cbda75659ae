"""The plugin tutorial's recipes run as written and say what the code does (issue 37)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.interfaces import Discriminator

DOCS = Path(__file__).resolve().parents[2] / "docs" / "tutorial"


def _block(page: str, marker: str) -> str:
    (block,) = [b for b in re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(), re.S) if marker in b]
    return block


@pytest.mark.parametrize("name", ["eml-envelope", "dot-product"])
def test_the_broadcasting_recipe_passes_on_a_built_in(name):
    namespace: dict = {"MyDiscriminator": gf.registry.get("discriminator", name)}
    exec(
        compile(_block("writing-a-plugin.md", "def test_my_discriminator_broadcasts"), "recipe", "exec"),  # noqa: S102
        namespace,
    )
    namespace["test_my_discriminator_broadcasts"]()


def test_the_broadcasting_recipe_catches_a_discriminator_that_mixes_batch_elements():
    class Mixing(Discriminator):
        name = "mixing"
        unit = "chips"

        def __call__(self, current, previous=None):
            e, p = np.abs(current.early), np.abs(current.prompt)
            return (e - np.abs(current.late)) / np.mean(p)  # normalised by the whole batch: a bug

        def noise_variance(self, cn0_dbhz):
            return 1.0

    namespace: dict = {"MyDiscriminator": Mixing}
    exec(
        compile(_block("writing-a-plugin.md", "def test_my_discriminator_broadcasts"), "recipe", "exec"),  # noqa: S102
        namespace,
    )
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
        coherent_time_s=0.01, early_late_spacing_chips=0.25
    )
    assert d.params.early_late_spacing_chips == 0.25
    assert "declares its spacing" in (DOCS / "from-plugin-to-comparison.md").read_text()


def test_the_robust_update_recipe_is_a_working_plugin():
    """The tutorial's Tukey update: with a huge c it is the plain update (to rounding); a gross
    outlier beyond c gets (almost) no weight, so the update is the one without that row."""
    from gnssframework import registry
    from gnssframework.estimation import Gaussian, LinearModel

    namespace: dict = {}
    exec(compile(_block("writing-a-plugin.md", "class TukeyUpdate"), "recipe", "exec"), namespace)  # noqa: S102
    tukey = namespace["TukeyUpdate"]
    H = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    model = LinearModel(np.eye(2), H, np.eye(2), np.eye(3))
    prior = Gaussian(np.zeros(2), np.eye(2) * 4.0)
    z = np.array([0.5, -0.3, 50.0])

    class Engine(registry.get("estimator", "kf")):
        name = "kf-tukey-test"

    def run(threshold, rows=slice(None)):
        engine = Engine()
        engine.backend = "numpy"
        engine._iteration_plan = lambda: (1, 0.0, tukey(threshold=threshold, iterations=50, tol=0.0))
        m = LinearModel(np.eye(2), H[rows], np.eye(2), np.eye(3)[rows][:, rows])
        return engine.update(prior, z[rows], m).state

    plain = registry.create("estimator", "kf")
    plain.backend = "numpy"
    wide = run(1e9)
    ref = plain.update(prior, z, model).state
    assert np.allclose(wide.mean, ref.mean, rtol=1e-12) and np.allclose(wide.cov, ref.cov, rtol=1e-12)
    # at the fixed point, the Kalman update with R / w(r) (r the residual there) gives the
    # mean back, and the outlier's weight is the floor: it has no say
    out = run(4.685)
    r = z - H @ out.mean
    w = np.maximum((1 - np.minimum((r / 4.685) ** 2, 1)) ** 2, 1e-12)
    assert w[2] == 1e-12 and (w[:2] > 0.9).all()
    S = H @ prior.cov @ H.T + np.diag(1 / w)
    assert np.allclose(prior.cov @ H.T @ np.linalg.solve(S, z), out.mean, atol=1e-10)
