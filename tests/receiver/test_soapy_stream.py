"""A SoapySDR device as live input (`frontend.soapy_io`), with a loopback device.

No SoapySDR device (nor its Python module, which is not on PyPI) is on the test machine: a
stand-in ``SoapySDR`` module implements the calls the reader makes, with SoapySDR's
signatures, constants and error codes (SoapySDR/Errors.h, Constants.h: timeout -1, overflow
-4, ``SOAPY_SDR_HAS_TIME`` bit 2), and its device plays a recording's samples back in
``CS16``, paced at the recording's sample rate, with time stamps, and can lose samples as a
driver whose buffer overran does. Checks: the samples read are the file's at the same
indices; a device's lost samples are zero-filled and marked as a gap with the time base
whole (stamped) or reported as breaking it (unstamped); the settings reach the device;
``receive soapy://...`` gives the file's fixes; no module is refused in one line.
"""

from __future__ import annotations

import sys
import time
import types
from dataclasses import dataclass

import numpy as np
import pytest

from gnssframework.cli import main
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend import open_recording, write_recording
from gnssframework.receiver.frontend.stream import open_stream
from lnav_recordings import NAV
from test_receiver_fix import DURATION_S, recording  # noqa: F401 - the module's fixture

FS = 2.046e6


@dataclass
class StreamResult:
    ret: int
    flags: int = 0
    timeNs: int = 0


class LoopbackDevice:
    """Plays ``samples`` (interleaved int16 I/Q) at ``speed`` times the rate (0: unpaced);
    loses ``lose[1]`` samples at sample ``lose[0]`` (one overflow report); stamps its reads
    when ``stamped``."""

    samples: np.ndarray = np.zeros(0, np.int16)
    speed = 1.0
    lose: tuple[int, int] | None = None
    stamped = True
    made: list[LoopbackDevice] = []

    def __init__(self, args):
        self.args, self.calls, self.pos, self.rate = dict(args), [], 0, 0.0
        LoopbackDevice.made.append(self)

    def setSampleRate(self, direction, channel, rate):
        self.calls.append(("rate", direction, channel, rate))
        self.rate = rate

    def getSampleRate(self, direction, channel):
        return self.rate

    def setFrequency(self, direction, channel, freq):
        self.calls.append(("freq", direction, channel, freq))

    def setGainMode(self, direction, channel, automatic):
        self.calls.append(("gain mode", direction, channel, automatic))

    def setGain(self, direction, channel, gain):
        self.calls.append(("gain", direction, channel, gain))

    def setupStream(self, direction, fmt, channels):
        self.calls.append(("stream", direction, fmt, list(channels)))
        return "rx0"

    def activateStream(self, stream):
        self.started = time.monotonic()

    def deactivateStream(self, stream):
        self.calls.append(("deactivated", stream))

    def closeStream(self, stream):
        self.calls.append(("closed", stream))

    def readStream(self, stream, buffs, n, flags=0, timeoutUs=100000):
        total = self.samples.size // 2
        if self.lose is not None and self.pos == self.lose[0]:
            self.pos += self.lose[1]  # the driver's buffer overran: these never reach the host
            self.lose = None
            return StreamResult(-4)
        if self.speed:
            ready = int((time.monotonic() - self.started) * self.rate * self.speed)
        else:
            ready = total
        end = min(total, ready, self.pos + n)
        if self.lose is not None and self.pos < self.lose[0]:
            end = min(end, self.lose[0])
        if end <= self.pos:
            time.sleep(min(timeoutUs * 1e-6, 0.002))
            return StreamResult(-1)  # timeout
        k = end - self.pos
        buffs[0][: 2 * k] = self.samples[2 * self.pos : 2 * end]
        stamp = round(self.pos / self.rate * 1e9)
        self.pos = end
        return StreamResult(k, 4 if self.stamped else 0, stamp if self.stamped else 0)


def _soapy_module():
    module = types.ModuleType("SoapySDR")
    module.SOAPY_SDR_RX, module.SOAPY_SDR_CS16 = 1, "CS16"
    module.SOAPY_SDR_TIMEOUT, module.SOAPY_SDR_OVERFLOW, module.SOAPY_SDR_HAS_TIME = -1, -4, 1 << 2
    module.Device = LoopbackDevice
    module.errToStr = lambda code: {-2: "STREAM_ERROR"}.get(code, "UNKNOWN")
    return module


@pytest.fixture
def soapy(monkeypatch):
    monkeypatch.setitem(sys.modules, "SoapySDR", _soapy_module())
    monkeypatch.setattr(LoopbackDevice, "made", [])
    return LoopbackDevice


def _file(tmp_path, n=40_000):
    rng = np.random.default_rng(3)
    x = np.round((rng.normal(size=n) + 1j * rng.normal(size=n)) * 300)
    path = write_recording(tmp_path / "r.sigmf-data", x, "ci16_le", FS, 0.0)
    return path, open_recording(path)


def test_a_device_paced_at_the_rate_gives_the_files_samples_at_the_same_indices(tmp_path, soapy, monkeypatch):
    path, rec = _file(tmp_path)
    monkeypatch.setattr(soapy, "samples", np.fromfile(path, np.int16))
    live = open_stream("soapy://driver=loopback,serial=7", "ci16_le", FS, block_s=0.001, buffer_s=0.01)
    for start, count in [(0, 100), (37, 3001), (5000, 4000), (30_000, 8000)]:  # a device never ends
        np.testing.assert_array_equal(live.read(start, count), rec.read(start, count))
    assert time.monotonic() - soapy.made[0].started >= 38_000 / FS  # paced: never ahead of the device's rate
    live.close()
    device = soapy.made[0]
    assert device.args == {"driver": "loopback", "serial": "7"}
    assert ("stream", 1, "CS16", [0]) in device.calls and ("rate", 1, 0, FS) in device.calls
    assert ("gain mode", 1, 0, True) in device.calls and ("closed", "rx0") in device.calls
    assert live.overruns() == (0, 0) and live.overrun_summary() == "overruns: 0 blocks (0.000 s of signal) dropped"


def test_samples_a_device_lost_are_zero_filled_as_a_gap_with_the_time_base_whole(tmp_path, soapy, monkeypatch):
    path, rec = _file(tmp_path)
    monkeypatch.setattr(soapy, "samples", np.fromfile(path, np.int16))
    monkeypatch.setattr(soapy, "speed", 0.0)
    monkeypatch.setattr(soapy, "lose", (12_000, 2_046))  # 1 ms lost in the driver
    live = open_stream("soapy://driver=loopback", "ci16_le", FS, block_s=0.001, buffer_s=0.01)
    np.testing.assert_array_equal(live.read(0, 12_000), rec.read(0, 12_000))
    np.testing.assert_array_equal(live.read(12_000, 2_046), np.zeros(2_046, np.complex64))
    np.testing.assert_array_equal(live.read(14_046, 20_000), rec.read(14_046, 20_000))  # at their own indices
    assert live.dropped_between(0, 40_000) == (12_000, 14_046)
    assert live.overrun_summary().endswith("; device overflows: 1 (0.001 s zero-filled)")
    assert live.device_lost
    live.close()


def test_an_unstamped_device_overflow_is_reported_as_breaking_the_time_base(tmp_path, soapy, monkeypatch):
    path, rec = _file(tmp_path)
    monkeypatch.setattr(soapy, "samples", np.fromfile(path, np.int16))
    monkeypatch.setattr(soapy, "speed", 0.0)
    monkeypatch.setattr(soapy, "stamped", False)
    monkeypatch.setattr(soapy, "lose", (12_000, 2_046))
    live = open_stream("soapy://driver=loopback", "ci16_le", FS, block_s=0.001, buffer_s=0.01)
    np.testing.assert_array_equal(live.read(12_000, 100), rec.read(14_046, 100))  # shifted: nothing to tell by
    assert live.dropped_between(0, 40_000) is None
    assert "without time stamps: samples lost uncounted, the time base broken" in live.overrun_summary()
    live.close()


@pytest.mark.slow
def test_receive_from_a_device_gives_the_files_fixes(recording, tmp_path, soapy, monkeypatch, capsys):  # noqa: F811
    path, _ = recording
    monkeypatch.setattr(soapy, "samples", np.fromfile(path, np.int16))
    monkeypatch.setattr(soapy, "speed", 0.0)  # the loopback as fast as the receiver takes it
    common = ["--ephemeris", str(NAV), "--rate", "5", "--week", "1316", "--quiet", "--duration", str(DURATION_S - 0.1)]
    assert main(["receive", str(path), "--out", str(tmp_path / "file"), *common]) == 0
    argv = ["receive", "soapy://driver=loopback", "--fs", str(FS), "--center-freq", "1575420000", "--gain", "30"]
    code = main([*argv, "--out", str(tmp_path / "live"), *common])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert (tmp_path / "live" / "positions.csv").read_bytes() == (tmp_path / "file" / "positions.csv").read_bytes()
    calls = soapy.made[0].calls
    assert (
        ("freq", 1, 0, 1575420000.0) in calls and ("gain mode", 1, 0, False) in calls and ("gain", 1, 0, 30.0) in calls
    )


def test_no_soapysdr_module_or_a_bad_address_is_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "SoapySDR", None)  # import fails
    with pytest.raises(ConfigError, match=r"^recording: soapy://driver=x: needs the SoapySDR Python module"):
        open_stream("soapy://driver=x", "ci16_le", FS)
    with pytest.raises(ConfigError, match=r"expected soapy://KEY=VALUE"):
        open_stream("soapy://driver", "ci16_le", FS)
    with pytest.raises(ConfigError, match=r"^format: .* read as ci16_le \(CS16\), not cu8"):
        open_stream("soapy://driver=x", "cu8", FS)


def test_a_rate_the_device_cannot_run_at_is_refused_naming_both(soapy, monkeypatch):
    monkeypatch.setattr(soapy, "getSampleRate", lambda self, direction, channel: 2.4e6)
    with pytest.raises(ConfigError, match=r"^sample_rate_hz: .* runs at 2400000 Hz, not the 2046000 Hz asked"):
        open_stream("soapy://driver=loopback", "ci16_le", FS)
    assert ("closed", "rx0") in soapy.made[0].calls


def test_an_overflow_before_the_first_sample_loses_nothing_of_the_run(tmp_path, soapy, monkeypatch):
    path, rec = _file(tmp_path)
    monkeypatch.setattr(soapy, "samples", np.fromfile(path, np.int16))
    monkeypatch.setattr(soapy, "speed", 0.0)
    monkeypatch.setattr(soapy, "lose", (0, 2_046))  # the driver overran before the first read
    live = open_stream("soapy://driver=loopback", "ci16_le", FS, block_s=0.001, buffer_s=0.01)
    np.testing.assert_array_equal(live.read(0, 100), rec.read(2_046, 100))  # the run starts later
    assert not live.device_lost and live.dropped_between(0, 30_000) is None
    live.close()
