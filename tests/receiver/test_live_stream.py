"""Live sample streams (`frontend.stream`, `frontend.stream_io`): the samples a stream gives
are the file's at the same indices (same decoding), a realtime overrun drops whole blocks
that keep their place in the sample count, backpressure drops nothing, rtl_tcp's header and
commands, the cu8 format, and the NMEA server (`navigation.nmea_stream`)."""

from __future__ import annotations

import io
import os
import socket
import struct
import threading
import time

import numpy as np
import pytest

from gnssframework import registry
from gnssframework.errors import ConfigError
from gnssframework.receiver.frontend import open_recording, write_recording
from gnssframework.receiver.frontend.stream import OPEN_ENDED_SAMPLES, open_stream
from gnssframework.receiver.frontend.stream_io import RtlTcpSettings, is_stream_address
from gnssframework.receiver.navigation.nmea_stream import NmeaServer, open_nmea_sink

FS = 2.046e6


class SlowStream(io.RawIOBase):
    """A stream of ``data`` that hands out its bytes only as ``allow`` lets it (a producer
    the test paces)."""

    def __init__(self, data: bytes) -> None:
        self.data, self.pos = data, 0
        self.allowed = threading.Semaphore(0)

    def readable(self) -> bool:
        return True

    def read(self, n: int = -1) -> bytes:
        self.allowed.acquire()
        chunk = self.data[self.pos : self.pos + n]
        self.pos += len(chunk)
        return chunk


@pytest.mark.parametrize("fmt", ["ci16_le", "ci8", "cf32_le", "ci2", "cu8"])
def test_a_stream_reads_the_files_samples_at_the_same_indices(tmp_path, fmt):
    rng = np.random.default_rng(1)
    x = (rng.normal(size=20_000) + 1j * rng.normal(size=20_000)) * 20
    path = write_recording(tmp_path / "r.sigmf-data", x, fmt, FS, 0.0)
    rec = open_recording(path)
    with open(path, "rb") as f:
        live = open_stream(f, fmt, FS, block_s=0.0007, buffer_s=0.002, retain_s=0.005)
        for start, count in [(0, 100), (37, 3001), (3000, 5), (5000, 4000), (9001, 2999), (15_000, 50)]:
            np.testing.assert_array_equal(live.read(start, count), rec.read(start, count))
            np.testing.assert_array_equal(live.read_components(start, count), rec.read_components(start, count))
        assert live.n_samples == OPEN_ENDED_SAMPLES  # the end not reached yet
        assert live.read(19_000, 10_000).shape[0] == rec.n_samples - 19_000
        assert live.n_samples == rec.n_samples and live.overruns() == (0, 0)
        live.close()


def test_a_read_before_the_held_window_is_refused(tmp_path):
    path = write_recording(tmp_path / "r.sigmf-data", np.ones(40_000, complex), "ci8", FS, 0.0)
    with open(path, "rb") as f:
        live = open_stream(f, "ci8", FS, block_s=0.001, buffer_s=0.002, retain_s=0.002)
        live.read(30_000, 10)
        with pytest.raises(ConfigError, match="no longer held"):
            live.read(1000, 10)
        live.close()


def test_realtime_drops_whole_blocks_that_keep_their_place_and_counts_them():
    block = 2046  # samples per block (1 ms)
    x = (np.arange(40 * block) % 251 - 125).astype(np.int8)
    source = registry.create("sample_source", "ci8")
    data = source.encode(x[::2] + 1j * x[1::2])  # 20 blocks of complex samples
    stream = SlowStream(data)
    seen = []
    live = open_stream(
        stream,
        "ci8",
        FS,
        realtime=True,
        block_s=0.001,
        buffer_s=0.002,
        on_overrun=lambda first, n: seen.append((first, n)),
    )
    expected = x[::2] + 1j * x[1::2]
    stream.allowed.release()  # the producer sends block 0
    np.testing.assert_array_equal(live.read(0, 10), expected[:10])
    for _ in range(6):  # blocks 1-6 while the consumer stalls: 1, 2 fill the queue, 3-6 are dropped
        stream.allowed.release()
    deadline = time.monotonic() + 10
    while live.overrun_blocks < 4 and time.monotonic() < deadline:
        time.sleep(0.01)
    for _ in range(40):  # the rest (and the end) while the consumer reads
        stream.allowed.release()
    got = live.read(0, 20 * block)
    assert live.ended and got.shape[0] == 20 * block  # the dropped blocks keep their place
    blocks, samples = live.overruns()
    assert seen[:4] == [(k * block, block) for k in (3, 4, 5, 6)]  # (the consumer may lag again later)
    assert blocks == len(seen) >= 4 and samples == blocks * block
    dropped = np.zeros(20 * block, bool)
    for first, count in seen:
        assert first % block == 0 and count == block  # whole blocks
        dropped[first : first + count] = True
    np.testing.assert_array_equal(got[~dropped], expected[~dropped])  # every other sample at its own index
    assert np.all(got[dropped] == 0)
    run_start = int(np.argmax(dropped))
    run_end = run_start + int(np.argmin(dropped[run_start:])) if not dropped[run_start:].all() else dropped.size
    assert live.dropped_between(0, 20 * block) == (run_start, run_end)  # the first run of dropped samples
    assert live.dropped_between(0, seen[0][0]) is None
    assert f"overruns: {blocks} blocks ({samples / FS:.3f} s of signal) dropped" == live.overrun_summary()
    live.close()


def test_backpressure_waits_and_drops_nothing():
    x = np.arange(30_000) % 100 - 50
    data = registry.create("sample_source", "ci8").encode(x + 0j)
    live = open_stream(io.BytesIO(data), "ci8", FS, block_s=0.0005, buffer_s=0.001)
    time.sleep(0.2)  # the reader is far ahead of a consumer that has read nothing: it waits
    got = live.read(0, 40_000)
    assert got.shape[0] == 30_000 and live.overruns() == (0, 0)
    np.testing.assert_array_equal(got.real, x)
    live.close()


def _rtl_tcp_server(payload: bytes, commands: list[bytes], header: bytes = b"RTL0" + struct.pack(">II", 5, 29)):
    server = socket.create_server(("127.0.0.1", 0))

    def serve():
        conn, _ = server.accept()
        conn.sendall(header)
        conn.settimeout(2.0)
        got = b""
        try:
            while len(got) < 20:
                more = conn.recv(64)
                if not more:
                    break
                got += more
        except OSError:
            pass
        commands.append(got)
        conn.sendall(payload)
        conn.close()
        server.close()

    threading.Thread(target=serve, daemon=True).start()
    return server.getsockname()[1]


def test_rtl_tcp_reads_the_header_sends_the_commands_and_decodes_cu8():
    payload = bytes(range(256)) * 40  # offset-binary I/Q
    commands: list[bytes] = []
    port = _rtl_tcp_server(payload, commands)
    live = open_stream(
        f"rtl_tcp://127.0.0.1:{port}",
        "cu8",
        2.048e6,
        rtl_tcp=RtlTcpSettings(center_freq_hz=1_575_420_000, sample_rate_hz=2.048e6, gain_tenth_db=496),
    )
    got = live.read(0, 10_000)
    live.close()
    assert "tuner type 5, 29 gain steps" in live.description
    raw = np.frombuffer(payload, np.uint8).astype(float) - 127.5
    np.testing.assert_array_equal(got, raw[0::2] + 1j * raw[1::2])
    sent = [struct.unpack(">BI", commands[0][k : k + 5]) for k in range(0, len(commands[0]), 5)]
    assert sent == [(2, 2_048_000), (1, 1_575_420_000), (3, 1), (4, 496)]


def test_rtl_tcp_refuses_a_server_that_is_not_rtl_tcp():
    port = _rtl_tcp_server(b"", [], header=b"HTTP/1.1 200")
    with pytest.raises(ConfigError, match="not an rtl_tcp server"):
        open_stream(f"rtl_tcp://127.0.0.1:{port}", "cu8", 2.048e6)


@pytest.mark.parametrize(
    "address, message",
    [("tcp://localhost", "HOST:PORT"), ("tcp://:99999", "HOST:PORT"), ("/no/such/fifo", "no such file")],
)
def test_a_bad_stream_address_is_one_line_naming_it(address, message):
    with pytest.raises(ConfigError, match=message):
        open_stream(address, "ci8", FS)


def test_stream_addresses(tmp_path):
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    assert is_stream_address("-") and is_stream_address("tcp://:1") and is_stream_address(str(fifo))
    assert not is_stream_address(str(tmp_path)) and not is_stream_address(str(tmp_path / "none"))


def test_the_nmea_server_sends_every_sentence_to_every_client():
    server = open_nmea_sink("tcp://127.0.0.1:0")
    assert isinstance(server, NmeaServer)
    clients = [socket.create_connection(("127.0.0.1", server.port)) for _ in range(2)]
    deadline = time.monotonic() + 5
    while server.n_clients < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    server.send(["$GPGGA,1*00", "$GPRMC,2*00"])
    for c in clients:
        c.settimeout(5)
        got = b""
        while got.count(b"\r\n") < 2:
            got += c.recv(100)
        assert got == b"$GPGGA,1*00\r\n$GPRMC,2*00\r\n"
        c.close()
    server.close()
    with pytest.raises(ConfigError, match="tcp://"):
        open_nmea_sink("udp://x:1")


@pytest.mark.parametrize(
    "extra, message",
    [
        ([], "--format"),
        (["--format", "ci8"], "--fs"),
        (
            ["--format", "ci8", "--fs", "4e6", "--center-freq", "1575420000"],
            "rtl_tcp:// server or a soapy:// device only",
        ),
        (["--format", "ci8", "--fs", "4e6", "--tracking", "vector"], "live input runs scalar tracking"),
        (["--format", "ci8", "--fs", "4e6", "--nmea-out", "udp://x:1"], "tcp://"),
    ],
)
def test_receive_refuses_a_stream_without_what_it_needs_in_one_line(tmp_path, capsys, extra, message):
    from gnssframework.cli import main

    fifo = tmp_path / "iq"
    os.mkfifo(fifo)
    writer = threading.Thread(target=lambda: open(fifo, "wb").close(), daemon=True)  # (a FIFO opens with a writer)
    writer.start()
    assert main(["receive", str(fifo), "--out", str(tmp_path / "o"), "--quiet", *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err


def test_receive_reads_standard_input_to_its_end(tmp_path, capsys, monkeypatch):
    from gnssframework.cli import main

    rng = np.random.default_rng(3)  # 0.2 s of noise: read to the end, nothing found, no position
    noise = registry.create("sample_source", "ci8").encode(
        (rng.normal(size=409_200) + 1j * rng.normal(size=409_200)) * 20
    )

    class Stdin:
        buffer = io.BytesIO(noise)

    monkeypatch.setattr("sys.stdin", Stdin)
    code = main(
        [
            "receive",
            "-",
            "--format",
            "ci8",
            "--fs",
            str(FS),
            "--out",
            str(tmp_path / "o"),
            "--quiet",
            "--prns",
            "1",
            "2",
        ]
    )
    out = capsys.readouterr()
    assert code == 1 and "nothing found" in out.out, out.out + out.err
    assert "overruns" not in out.err
