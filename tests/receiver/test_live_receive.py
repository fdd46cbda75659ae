"""`receive` on a live stream, fed by a loopback producer with the project's own generated
recording (`test_receiver_fix`'s: five satellites of real broadcast records seen from a
known station, with LNAV):

- the same bytes through a TCP socket give the same fixes as the file, byte for byte
  (the stream reader hands the tracker the very samples a file read gives, in the same
  blocks: nothing in the receiver depends on where they came from), and the NMEA
  sentences sent as fixes come to a TCP client are those fixes';
- with ``realtime``, a consumer that stalls makes the reader drop whole blocks: the
  overruns are counted and reported, the channels crossing the gap are marked lost
  (never carried across it) and re-acquired, and the fixes after the gap are still at the
  station.
"""

from __future__ import annotations

import csv
import os
import re
import socket
import threading
import time

import numpy as np
import pymap3d
import pynmea2
import pytest

from gnssframework import registry
from gnssframework.cli import main
from gnssframework.navigation.ephemeris import read_rinex_nav
from gnssframework.receiver.channels import tracking_config
from gnssframework.receiver.frontend.stream import open_stream
from gnssframework.receiver.navigation.receive import receive
from lnav_recordings import FS, NAV, STATION
from test_receiver_fix import recording  # noqa: F401 - the module's fixture

WEEK = 1316


def _serve(data: bytes, gate=None, chunk: int = 65536) -> int:
    """A one-client TCP server sending ``data`` (``gate(offset)`` returns when the next chunk
    may go: a producer paced by the test); its port."""
    server = socket.create_server(("127.0.0.1", 0))

    def run():
        conn, _ = server.accept()
        try:
            for k in range(0, len(data), chunk):
                if gate is not None:
                    gate(k)
                conn.sendall(data[k : k + chunk])
        except OSError:
            pass
        finally:
            conn.close()
            server.close()

    threading.Thread(target=run, daemon=True).start()
    return server.getsockname()[1]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def _live_argv(source, out, nmea_out, common):
    """``receive`` of the recording's ``ci16_le`` bytes from ``source``, NMEA to ``nmea_out``."""
    return [
        "receive",
        source,
        "--format",
        "ci16_le",
        "--fs",
        str(FS),
        "--out",
        str(out),
        "--nmea-out",
        nmea_out,
        *common,
    ]


def _assert_sentences_are_the_fixes(lines, rows):
    """A GGA and an RMC per row of ``positions.csv``, GGA at its position (NMEA's 1e-5 arc
    minute is 2 cm) with its satellite count."""
    sentences = [pynmea2.parse(line) for line in lines if line.startswith("$")]
    gga = [s for s in sentences if s.sentence_type == "GGA"]
    assert len(gga) == len(rows) and len([s for s in sentences if s.sentence_type == "RMC"]) == len(rows)
    for s, row in zip(gga, rows):
        assert abs(s.latitude - float(row["lat_deg"])) < 1e-6 and abs(s.longitude - float(row["lon_deg"])) < 1e-6
        assert int(s.num_sats) == int(row["n_sats"])


@pytest.mark.slow
def test_a_tcp_stream_gives_the_files_fixes_and_sends_them_as_nmea(recording, tmp_path, capsys):  # noqa: F811
    path, _ = recording
    common = ["--ephemeris", str(NAV), "--rate", "5", "--week", str(WEEK), "--quiet"]
    assert main(["receive", str(path), "--out", str(tmp_path / "file"), *common]) == 0
    port, nmea_port = _serve(path.read_bytes()), _free_port()
    received = []

    def client():  # a gpsd-like reader of the NMEA server
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                sock = socket.create_connection(("127.0.0.1", nmea_port))
                break
            except OSError:
                time.sleep(0.05)
        else:
            return
        with sock:
            while data := sock.recv(4096):
                received.append(data)

    reader = threading.Thread(target=client, daemon=True)
    reader.start()
    code = main(_live_argv(f"tcp://127.0.0.1:{port}", tmp_path / "live", f"tcp://127.0.0.1:{nmea_port}", common))
    reader.join(10)
    out = capsys.readouterr()
    assert code == 0, out.out + out.err
    assert (tmp_path / "live" / "positions.csv").read_bytes() == (tmp_path / "file" / "positions.csv").read_bytes()
    assert "overruns" not in out.err  # backpressure: nothing dropped
    lines = b"".join(received).decode().split("\r\n")
    # The client connects while the receiver acquires, before the first fix: it gets every one.
    _assert_sentences_are_the_fixes(lines, _rows(tmp_path / "file" / "positions.csv"))


@pytest.mark.slow
def test_a_fifo_gives_the_files_fixes_and_nmea_goes_to_standard_output(recording, tmp_path, capsys):  # noqa: F811
    # The same bytes written into a named pipe by a producer thread (rtl_sdr's way into a
    # FIFO): the file's fixes byte for byte, and with --nmea-out - each fix's GGA and RMC on
    # standard output as it comes.
    path, _ = recording
    common = ["--ephemeris", str(NAV), "--rate", "5", "--week", str(WEEK), "--quiet"]
    assert main(["receive", str(path), "--out", str(tmp_path / "file"), *common]) == 0
    capsys.readouterr()
    fifo = tmp_path / "samples.fifo"
    os.mkfifo(fifo)
    data = path.read_bytes()

    def producer():
        with open(fifo, "wb") as f:  # blocks until the receiver opens the pipe
            for k in range(0, len(data), 65536):
                f.write(data[k : k + 65536])

    writer = threading.Thread(target=producer, daemon=True)
    writer.start()
    code = main(_live_argv(str(fifo), tmp_path / "live", "-", common))
    writer.join(10)
    out = capsys.readouterr()
    assert code == 0, out.err
    assert (tmp_path / "live" / "positions.csv").read_bytes() == (tmp_path / "file" / "positions.csv").read_bytes()
    _assert_sentences_are_the_fixes(out.out.splitlines(), _rows(tmp_path / "file" / "positions.csv"))


@pytest.mark.slow
def test_realtime_from_the_command_line_announces_and_reports_its_overruns(recording, tmp_path, capsys):  # noqa: F811
    # A producer sending the whole recording at once (far faster than its sample rate) into
    # a 0.05 s buffer: with --realtime the receiver drops whole blocks rather than hold the
    # producer back, says so on standard error when the first is dropped, and counts them
    # all at the end (on standard error and in report.md).
    path, _ = recording
    port = _serve(path.read_bytes())
    argv = ["receive", f"tcp://127.0.0.1:{port}", "--format", "ci16_le", "--fs", str(FS), "--realtime"]
    code = main(
        [*argv, "--buffer-s", "0.05", "--out", str(tmp_path / "o"), "--ephemeris", str(NAV), "--week", str(WEEK)]
    )
    err = capsys.readouterr().err
    assert code in (0, 1), err  # 1: too much dropped for a fix, said as such
    assert "overrun: the receiver lags the stream: samples dropped from" in err
    summary = re.search(r"overruns: (\d+) blocks \(", err)
    assert summary and int(summary.group(1)) >= 1, err
    assert f"overruns: {summary.group(1)} blocks (" in (tmp_path / "o" / "report.md").read_text()


@pytest.mark.slow
def test_a_stalled_realtime_consumer_counts_its_overruns_and_still_fixes(recording):  # noqa: F811
    path, _ = recording
    data = path.read_bytes()
    bytes_per_sample = 4  # ci16_le
    lead_s, stall_at_s, min_dropped = 0.05, 0.3, 5
    state = {"stalled": False, "rec": None, "limit": 0}
    stall = threading.Event()

    def gate(offset: int) -> None:
        """The producer sends while the reader's queue has room for what may be in flight
        (a chunk, a partial block), except while the consumer stalls: then it sends on (as
        a front end does) up to ``state["limit"]``, more than the queue holds."""
        while True:
            rec = state["rec"]
            if rec is not None:
                if stall.is_set():
                    if offset / bytes_per_sample <= state["limit"]:
                        return
                elif offset <= rec.stream_bytes + 2 * chunk and rec.queued_blocks[0] <= rec.queued_blocks[1] - 3:
                    return  # the reader has read what was sent and its queue has room for what may follow
            time.sleep(0.001)

    chunk = 65536
    port = _serve(data, gate, chunk)
    rec = open_stream(f"tcp://127.0.0.1:{port}", "ci16_le", FS, realtime=True, block_s=0.01, buffer_s=0.1)
    state["rec"] = rec

    def progress(fraction: float) -> None:  # the artificially slow consumer: one stall at 0.3 s
        if not state["stalled"] and rec.received_samples > stall_at_s * FS:
            state["stalled"] = True
            state["limit"] = rec.received_samples + (lead_s + 0.1 + 0.12) * FS  # the queue holds 0.1 s
            stall.set()
            deadline = time.monotonic() + 60
            while rec.overrun_blocks < min_dropped and time.monotonic() < deadline:
                time.sleep(0.01)
            stall.clear()

    try:
        result = receive(
            rec,
            registry.create("acquisition", "pcps"),
            tracking_config(),
            rate_hz=5.0,
            rinex=read_rinex_nav(NAV),
            progress=progress,
        )
    finally:
        rec.close()
    blocks, samples = rec.overruns()
    assert blocks >= min_dropped and samples == blocks * round(0.01 * FS)
    assert rec.overrun_summary().startswith(f"overruns: {blocks} blocks (")
    gap = rec.dropped_between(0, rec.n_samples)
    assert gap is not None and gap[0] >= stall_at_s * FS
    gaps = [gap]  # a consumer slowed by other load (re-acquiring every channel) may overrun again
    while (later := rec.dropped_between(gaps[-1][1], rec.n_samples)) is not None:
        gaps.append(later)
    # Every channel whose interval crossed a gap is marked lost there, and re-acquired after it.
    for ch in result.tracking.channels.values():
        events = [(t, what) for t, what in ch.events if what.startswith("overrun")]
        assert events and all(any(g[0] / FS - 0.03 < t <= g[0] / FS for g in gaps) for t, _ in events), ch.events
        assert any(gap[0] / FS - 0.03 < t <= gap[0] / FS for t, _ in events), ch.events  # the stall's gap among them
        last = max(g for g in gaps if any(g[0] / FS - 0.03 < t <= g[0] / FS for t, _ in events))
        assert any(what == "re-acquired" and t >= last[1] / FS for t, what in ch.events), ch.events
    table = result.positions
    assert table is not None and len(table) >= 3 and np.all(table.sample_time_s > gap[1] / FS), (
        gap,
        blocks,
        result.tracking.duration_s,
        {p: c.events for p, c in result.tracking.channels.items()},
    )
    err = np.linalg.norm(table.ecef_m - STATION, axis=1)
    # As test_receiver_fix: ~1.7 m of code noise per satellite, PDOP-scaled: a wrong count of
    # samples across the gap (1 sample = 147 m) would be far outside.
    assert np.sqrt(np.mean(err**2)) < 4 * np.max(table.columns["hdop"] + table.columns["vdop"]) * 1.7
    lat, lon, h = pymap3d.ecef2geodetic(*STATION)
    assert np.all(np.abs(table.columns["lat_deg"] - lat) < 1e-3)
