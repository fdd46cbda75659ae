"""Library errors cross process boundaries: pickling, and failures in worker processes."""

from __future__ import annotations

import pickle
import types

import pytest

import gnssframework as gf
from gnssframework import errors
from gnssframework.experiments import load_config, run_comparison
from gnssframework_plugins.nav_filters import EkfPositionVelocity

ERRORS = [
    errors.GnssFrameworkError("plain message"),
    errors.ConfigError("candidates[0].estimator.alpha", "must be > 0"),
    errors.PluginError("cannot load"),
    errors.DataFileError("obs.rnx", 12, "bad epoch line"),
    errors.DataFileError("obs.rnx", None, "no such file"),
    errors.NumericalError("ckf", [(1, 2), (3, 4)], 5, "detail"),
    errors.NotPositiveDefiniteError("ukf", [(0,)], 7),
    errors.InvalidMeasurementError("kf", [(2,)]),
    errors.WorkerError("case 'a', candidate 'b', batch 0", "TypeError: boom", "Traceback ..."),
]


def test_every_library_error_class_is_covered():
    classes = {obj for obj in vars(errors).values()
               if isinstance(obj, type) and issubclass(obj, errors.GnssFrameworkError)}
    assert classes == {type(e) for e in ERRORS}


@pytest.mark.parametrize("exc", ERRORS, ids=lambda e: type(e).__name__)
def test_error_survives_pickling_with_message_and_attributes(exc):
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is type(exc)
    assert str(back) == str(exc)
    assert vars(back) == vars(exc)


TINY = """
name = "tiny"
runs = 4
batch_size = 2
seed = 7
[executor]
kind = "local"
workers = 2
[scenario]
kind = "vector-tracking"
duration_s = 0.2
channels = 5
settle_s = 0.05
[[cases]]
name = "c45"
cn0_dbhz = 45.0
[[candidates]]
name = "bad"
channel_filter = { name = "discriminator" }
nav_filter = { name = "NAME" }
"""


class _NeedsTwoArgs(Exception):
    """An exception that pickles but cannot be rebuilt from its pickle (two required
    constructor arguments, one stored in args): the case that used to break the pool."""

    def __init__(self, what: str, code: int) -> None:
        super().__init__(f"{what} (code {code})")


def _failing_nav_filter(name: str, exc: Exception) -> type:
    class Failing(EkfPositionVelocity):
        def step(self, inputs):
            raise exc

    Failing.name = name
    module = types.SimpleNamespace(register_nav_filter=gf.hookimpl(lambda register: register(Failing)))
    gf.registry.register_module(module, name=f"test-{name}")
    return Failing


@pytest.mark.parametrize("name, exc, expected_type, message", [
    ("raises-config-error", gf.ConfigError("nav_filter.gain", "gain must be finite in the worker"),
     gf.ConfigError, "nav_filter.gain: gain must be finite in the worker"),
    ("raises-unrebuildable", _NeedsTwoArgs("exploded in step", 3),
     gf.WorkerError, "case 'c45', candidate 'bad', batch 0: _NeedsTwoArgs: exploded in step (code 3)"),
])
def test_failure_in_a_worker_reaches_the_user_with_its_message(tmp_path, name, exc, expected_type, message,
                                                              scratch_registry):
    _failing_nav_filter(name, exc)
    path = tmp_path / "tiny.toml"
    path.write_text(TINY.replace("NAME", name))
    config = load_config(path)
    with pytest.raises(expected_type) as err:
        run_comparison(config, tmp_path / "out", progress=False)
    assert "BrokenProcessPool" not in repr(err.value)
    assert str(err.value).replace("batch 1", "batch 0") == message


def test_a_candidate_that_cannot_be_built_stops_the_config_before_any_run(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY.replace('{ name = "NAME" }', '{ name = "ekf-pv", params = { clock = "atomic" } }'))
    with pytest.raises(gf.ConfigError, match=r"candidates\[0\]\.nav_filter\.params.*clock"):
        load_config(path)
    assert not (tmp_path / "out").exists()
