"""Requires/provides names come from one module, and harnesses hold plugins to them."""

from __future__ import annotations

import numpy as np
import pytest

import gnssframework as gf
from gnssframework import names


def test_every_builtin_sequential_filter_uses_the_shared_names():
    for kind in ("channel_filter", "nav_filter"):
        for name in gf.registry.names(kind):
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
