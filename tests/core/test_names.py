"""Requires/provides names come from one module, and harnesses hold plugins to them."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from conftest import builtin_names
from gnssframework import names


def test_every_builtin_sequential_filter_uses_the_shared_names():
    for kind in ("channel_filter", "nav_filter"):
        for name in builtin_names(kind):
            cls = gf.registry.get(kind, name)
            unknown = set(cls.requires) | set(cls.provides)
            unknown -= names.ALL
            assert not unknown, f"{kind} {name!r} uses names outside gnssframework.names: {sorted(unknown)}"


def test_harness_refuses_a_step_that_breaks_the_provides_declaration(scratch_registry):
    hatch_cls = gf.registry.get("channel_filter", "hatch")

    class Forgetful(hatch_cls):
        name = "forgetful-hatch"

        def step(self, inputs):
            out = dict(super().step(inputs))
            out.pop(names.SLIP_DETECTED)
            return out

    f = Forgetful()
    f.reset((), gf.RunContext())
    with pytest.raises(gf.PluginError, match="'forgetful-hatch': step\\(\\) did not return slip_detected"):
        f.checked_step({names.PSEUDORANGE_M: np.array(2.0e7), names.CARRIER_M: np.array(2.0e7)})
    plain = hatch_cls()
    plain.reset((), gf.RunContext())
    out = plain.checked_step({names.PSEUDORANGE_M: np.array(2.0e7), names.CARRIER_M: np.array(2.0e7)})
    assert set(plain.provides) <= set(out)


# -- every name a built-in plugin reads and a harness hands over is in names.ALL --------------

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]
PLUGIN_FILES = ["plugins/channel_filters.py", "plugins/nav_filters.py", "plugins/smoothers.py"]
HARNESS_FILES = [
    "gnssframework/receiver/tracking/vector.py",
    "gnssframework/receiver/engine/closers.py",
    "gnssframework/receiver/engine/deep_closer.py",
    "gnssframework/experiments/scenarios/carrier_smoothing.py",
    "gnssframework/io/smoothing.py",
]  # the smooth command's harness


def _string_keys(path, root=ROOT) -> set[str]:
    """String keys read from or written to ``inputs`` (``inputs["x"]``, ``"x" in inputs``,
    ``inputs.get("x")``) and the literal keys of dicts handed to ``checked_step``."""
    import ast

    keys: set[str] = set()

    def is_inputs(node):
        return isinstance(node, ast.Name) and node.id == "inputs"

    def literal(node):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "names":
            return getattr(names, node.attr, f"names.{node.attr} (not defined)")  # a key spelt through the contract
        return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None

    for node in ast.walk(ast.parse((root / path).read_text())):
        if isinstance(node, ast.Subscript) and is_inputs(node.value) and literal(node.slice):
            keys.add(literal(node.slice))
        elif isinstance(node, ast.Compare) and any(is_inputs(c) for c in node.comparators) and literal(node.left):
            keys.add(literal(node.left))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr == "get" and is_inputs(node.func.value) and node.args and literal(node.args[0]):
                keys.add(literal(node.args[0]))
            if node.func.attr == "checked_step" and node.args and isinstance(node.args[0], ast.Dict):
                keys.update(k for k in map(literal, [k for k in node.args[0].keys if k is not None]) if k)
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "names":
            keys.add(literal(node))  # any name read from the contract module
    return keys


@pytest.mark.parametrize("path", PLUGIN_FILES + HARNESS_FILES)
def test_step_inputs_read_by_plugins_and_given_by_harnesses_are_shared_names(path):
    keys = _string_keys(path)
    assert keys, f"{path}: the scan found no step inputs (did the code move?)"
    assert keys <= names.ALL, f"{path} spells step inputs outside gnssframework.names: {sorted(keys - names.ALL)}"


def test_the_scan_reads_names_spelt_through_the_contract(tmp_path):
    (tmp_path / "p.py").write_text(
        "from gnssframework import names\n"
        "def step(self, inputs):\n    return inputs[names.DATA_BIT], names.NOT_A_NAME\n"
    )
    assert _string_keys("p.py", tmp_path) == {"data_bit", "names.NOT_A_NAME (not defined)"}


def test_the_scan_sees_a_misspelt_input(tmp_path):
    (tmp_path / "p.py").write_text(
        'def step(self, inputs):\n    ch.checked_step({"sat_pos": 1})\n'
        '    return inputs["corelators"], "data_bit" in inputs, inputs.get("nco")\n'
    )
    assert _string_keys("p.py", tmp_path) == {"sat_pos", "corelators", "data_bit", "nco"}


# -- the harnesses themselves hold a plugin to its `provides` -----------------------------------


def _forgetful(kind, name, drop):
    base = gf.registry.get(kind, name)

    class Forgetful(base):
        def step(self, inputs):
            out = dict(super().step(inputs))
            out.pop(drop)
            return out

    Forgetful.name = f"forgetful-{name}"
    return Forgetful()


def test_the_closed_loop_tracking_harness_refuses_a_step_that_breaks_provides():
    from gnssframework.receiver.tracking.scalar import SignalTruth, run_closed_loop

    truth = SignalTruth.from_dynamics(0.01, 0.001, 45.0, doppler_hz=np.full(2, 100.0))
    with pytest.raises(
        gf.PluginError,
        match=r"channel_filter 'forgetful-scalar': step\(\) did not return "
        r"code_freq_hz that it declares in `provides`",
    ):
        run_closed_loop(_forgetful("channel_filter", "scalar", names.CODE_FREQ_HZ), truth, np.random.default_rng(0))


@pytest.mark.parametrize(
    "kind, name, drop",
    [("channel_filter", "discriminator", names.FREQ_ERROR_VAR_HZ2), ("nav_filter", "ekf-pv", names.COV)],
)
def test_the_vector_loop_refuses_a_step_that_breaks_provides(kind, name, drop):
    from gnssframework.experiments import get_scenario
    from gnssframework.receiver.tracking.vector import run_vector_loop

    scen = get_scenario({"kind": "vector-tracking", "duration_s": 0.05, "channels": 5, "settle_s": 0.01})
    rng = np.random.default_rng(1)
    truth, x0, P0 = scen.truth(45.0, 2, rng)
    parts = {
        "channel_filter": gf.registry.create("channel_filter", "discriminator"),
        "nav_filter": gf.registry.create("nav_filter", "ekf-pv"),
        kind: _forgetful(kind, name, drop),
    }
    with pytest.raises(gf.PluginError, match=rf"{kind} 'forgetful-{name}': step\(\) did not return {drop} "):
        run_vector_loop(parts["channel_filter"], parts["nav_filter"], truth, x0, P0, rng)
