"""Library errors cross process boundaries: pickling, and failures in worker processes."""

from __future__ import annotations

import pickle
import subprocess
import sys

import pytest

import gnssframework as gf
from gnssframework import errors
from gnssframework.experiments import load_config

ERRORS = [
    errors.GnssFrameworkError("plain message"),
    errors.ConfigError("candidates[0].estimator.alpha", "must be > 0"),
    errors.PluginError("cannot load"),
    errors.DataFileError("obs.rnx", 12, "bad epoch line"),
    errors.DataFileError("obs.rnx", None, "no such file"),
    errors.NumericalError("ckf", [(1, 2), (3, 4)], 5, "detail"),
    errors.NotPositiveDefiniteError("ukf", [(0,)], 7),
    errors.InvalidMeasurementError("kf", [(2,)]),
    errors.InvalidInitialStateError("ekf", [(3,)], None, "initial mean is NaN or inf"),
    errors.NonFiniteError("ukf", [(0,)], 4, "prediction"),
    errors.InvalidInputError("ckf", "zs", "is a zero-length measurement sequence"),
    errors.InvalidArgumentError("filter_sequence", "estimator", "expected an estimator plugin, got str 'ukf'"),
    errors.WorkerError("case 'a', candidate 'b', batch 0", "TypeError: boom", "Traceback ..."),
    errors.RunFailure("candidate 'b', case 'a', runs 0-1", "ukf: invalid initial state", "InvalidInitialStateError"),
]


def test_every_library_error_class_is_covered():
    classes = {
        obj for obj in vars(errors).values() if isinstance(obj, type) and issubclass(obj, errors.GnssFrameworkError)
    }
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


# Run in a fresh interpreter, as a user would: the worker processes are forked from a
# process that holds nothing but this script.
SCRIPT = """
import sys, threading, types
import gnssframework as gf
from gnssframework.experiments import load_config, run_comparison
from gnssframework_plugins.nav_filters import EkfPositionVelocity

class HoldsALock(Exception):
    # cannot be pickled: without the runner's guard its message is lost in the worker
    def __init__(self, message):
        super().__init__(message)
        self.lock = threading.Lock()

EXC = {"config": gf.ConfigError("nav_filter.gain", "gain must be finite in the worker"),
       "unpicklable": HoldsALock("exploded in step"), "died": None}[sys.argv[1]]

class Failing(EkfPositionVelocity):
    name = "failing"
    def step(self, inputs):
        if EXC is None:
            import os
            os._exit(1)  # the worker dies without raising (as a crash in compiled code would)
        raise EXC

gf.registry.register_module(types.SimpleNamespace(
    register_nav_filter=gf.hookimpl(lambda register: register(Failing))), name="failing")
try:
    run_comparison(load_config(sys.argv[2]), sys.argv[3], progress=False)
except Exception as exc:
    print(type(exc).__name__)
    print(str(exc).replace("runs 2-3", "runs 0-1"))
"""


@pytest.mark.slow
@pytest.mark.parametrize(
    "which, expected_type, message",
    [
        (
            "config",
            "RunFailure",
            "candidate 'bad', case 'c45', runs 0-1: nav_filter.gain: gain must be finite in the worker",
        ),
        ("unpicklable", "WorkerError", "candidate 'bad', case 'c45', runs 0-1: HoldsALock: exploded in step"),
    ],
)
def test_failure_in_a_worker_reaches_the_user_with_its_message(tmp_path, which, expected_type, message):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY.replace("NAME", "failing"))
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT, which, str(path), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.stdout.splitlines() == [expected_type, message], out.stderr[-2000:]


@pytest.mark.slow
def test_a_worker_that_dies_is_reported_with_its_batch_not_as_a_bare_broken_pool(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY.replace("NAME", "failing"))
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT, "died", str(path), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = out.stdout.splitlines()
    assert lines[0] == "RunFailure", out.stderr[-2000:]
    assert lines[1].startswith("candidate 'bad', case 'c45', runs 0-1: a worker process died"), lines
    assert "executor.workers = 1" in lines[1]


def test_a_candidate_that_cannot_be_built_stops_the_config_before_any_run(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY.replace('{ name = "NAME" }', '{ name = "ekf-pv", params = { clock = "atomic" } }'))
    with pytest.raises(gf.ConfigError, match=r"candidates\[0\]\.nav_filter\.params.*clock"):
        load_config(path)
    assert not (tmp_path / "out").exists()
