"""Where a live stream's bytes come from: standard input, a FIFO, a TCP socket or an rtl_tcp server.

`connect` turns a stream address into a binary file object read by
`stream.StreamRecording`'s reader thread:

``-``
    standard input (``rtl_sdr -f 1575420000 -s 2048000 - | gnssframework receive - ...``);
a path
    a FIFO (``mkfifo``) or any file read as a stream (read once, front to back);
``tcp://HOST:PORT``
    a raw TCP stream of samples (the server sends the samples, nothing else);
``soapy://KEY=VALUE,...``
    a SoapySDR device (`soapy_io`, opened by `stream.open_stream`: it needs the rate);
``rtl_tcp://HOST:PORT``
    an rtl_tcp server (osmocom rtl-sdr's ``rtl_tcp``): on connection it sends a 12-byte
    header, ``"RTL0"``, the tuner type and the number of gain steps (each a big-endian
    ``uint32``), then unsigned 8-bit interleaved I/Q (the ``cu8`` format). The client may
    send 5-byte commands, a command byte and a big-endian ``uint32`` parameter:
    ``0x01`` centre frequency (Hz), ``0x02`` sample rate (Hz), ``0x03`` gain mode (0
    automatic, 1 manual), ``0x04`` gain (tenths of dB), ``0x05`` frequency correction (ppm).
"""

from __future__ import annotations

import os
import socket
import stat
import struct
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, cast

from ...errors import ConfigError

__all__ = [
    "RtlTcpSettings",
    "RTL_TCP_HEADER_BYTES",
    "connect",
    "is_stream_address",
    "rtl_tcp_command",
    "parse_host_port",
]

#: The sample format an rtl_tcp server sends: 8-bit offset-binary I/Q (the `cu8` source).
RTL_TCP_FORMAT = "cu8"

#: The rtl_tcp greeting: ``"RTL0"``, tuner type, gain count (big-endian ``uint32`` each).
RTL_TCP_HEADER_BYTES = 12
#: rtl_tcp command bytes (osmocom rtl-sdr, rtl_tcp.c's command loop).
RTL_TCP_SET_FREQ, RTL_TCP_SET_RATE, RTL_TCP_GAIN_MODE, RTL_TCP_SET_GAIN, RTL_TCP_FREQ_CORR = 1, 2, 3, 4, 5
#: Seconds a TCP connection may take.
CONNECT_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class RtlTcpSettings:
    """What to ask an rtl_tcp server for (None: leave the server's setting).

    Attributes
    ----------
    center_freq_hz, sample_rate_hz
        Tuner centre frequency and sample rate.
    gain_tenth_db
        Manual gain in tenths of dB (None: automatic gain).
    ppm
        Frequency correction (parts per million).
    """

    center_freq_hz: float | None = None
    sample_rate_hz: float | None = None
    gain_tenth_db: int | None = None
    ppm: int | None = None


def rtl_tcp_command(command: int, value: int) -> bytes:
    """The 5-byte rtl_tcp command: the command byte, then ``value`` as a big-endian ``uint32``
    (a negative value, a frequency correction, in two's complement)."""
    return struct.pack(">BI", command, int(value) & 0xFFFFFFFF)


def is_stream_address(address: str) -> bool:
    """True for ``-``, a ``tcp://``, ``rtl_tcp://`` or ``soapy://`` address, or an existing FIFO."""
    if address == "-" or address.startswith(("tcp://", "rtl_tcp://", "soapy://")):
        return True
    try:
        return stat.S_ISFIFO(os.stat(address).st_mode)
    except OSError:
        return False


def parse_host_port(address: str, scheme: str, field: str = "recording", lowest_port: int = 1) -> tuple[str, int]:
    """``(host, port)`` of ``scheme://HOST:PORT`` (host may be empty: all interfaces / localhost;
    a server may take ``lowest_port`` 0: any free port)."""
    rest = address[len(scheme) + 3 :]
    host, sep, port = rest.rpartition(":")
    if not sep or not port.isdigit() or not lowest_port <= int(port) < 65536:
        raise ConfigError(field, f"{address}: expected {scheme}://HOST:PORT with a port {lowest_port}-65535")
    return host.strip("[]"), int(port)


def _open_tcp(address: str, scheme: str) -> socket.socket:
    host, port = parse_host_port(address, scheme)
    try:
        sock = socket.create_connection((host or "localhost", port), timeout=CONNECT_TIMEOUT_S)
    except OSError as exc:
        raise ConfigError("recording", f"{address}: cannot connect ({exc.strerror or exc})") from None
    sock.settimeout(None)
    return sock


def _read_exact(f: BinaryIO, n: int) -> bytes:
    data = b""
    while len(data) < n:
        more = f.read(n - len(data))
        if not more:
            break
        data += more
    return data


def _rtl_tcp(address: str, settings: RtlTcpSettings) -> tuple[BinaryIO, str]:
    sock = _open_tcp(address, "rtl_tcp")
    f = cast(BinaryIO, sock.makefile("rb", buffering=0))  # a SocketIO: raw binary reads
    header = _read_exact(f, RTL_TCP_HEADER_BYTES)
    if len(header) < RTL_TCP_HEADER_BYTES or header[:4] != b"RTL0":
        sock.close()
        raise ConfigError(
            "recording",
            f"{address}: not an rtl_tcp server (its first bytes {header[:4]!r} are not "
            "b'RTL0'); use tcp:// for a raw sample stream",
        )
    tuner, gains = struct.unpack(">II", header[4:])
    commands = b""
    if settings.sample_rate_hz is not None:
        commands += rtl_tcp_command(RTL_TCP_SET_RATE, round(settings.sample_rate_hz))
    if settings.center_freq_hz is not None:
        commands += rtl_tcp_command(RTL_TCP_SET_FREQ, round(settings.center_freq_hz))
    if settings.ppm is not None:
        commands += rtl_tcp_command(RTL_TCP_FREQ_CORR, settings.ppm)
    commands += rtl_tcp_command(RTL_TCP_GAIN_MODE, 0 if settings.gain_tenth_db is None else 1)
    if settings.gain_tenth_db is not None:
        commands += rtl_tcp_command(RTL_TCP_SET_GAIN, settings.gain_tenth_db)
    sock.sendall(commands)
    f._gnss_socket = sock  # type: ignore[attr-defined]  # kept open as long as the file
    return f, f"rtl_tcp {address} (tuner type {tuner}, {gains} gain steps)"


def connect(address: str, rtl_tcp: RtlTcpSettings | None = None) -> tuple[BinaryIO, str]:
    """A binary file object reading the stream at ``address`` (module text) and a line
    describing it.

    Raises
    ------
    ConfigError
        An unreachable server, a server that is not rtl_tcp for ``rtl_tcp://``, a bad
        address, a missing path.
    """
    if address == "-":
        return sys.stdin.buffer, "standard input"
    if address.startswith("rtl_tcp://"):
        return _rtl_tcp(address, rtl_tcp or RtlTcpSettings())
    if address.startswith("tcp://"):
        sock = _open_tcp(address, "tcp")
        f = cast(BinaryIO, sock.makefile("rb", buffering=0))
        f._gnss_socket = sock  # type: ignore[attr-defined]
        return f, f"TCP stream {address}"
    path = Path(address)
    if not path.exists():
        raise ConfigError("recording", f"{address}: no such file or FIFO")
    return open(path, "rb", buffering=0), f"FIFO {address}" if is_stream_address(address) else f"file {address}"
