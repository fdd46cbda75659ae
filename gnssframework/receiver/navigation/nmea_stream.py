"""NMEA sentences sent as fixes come: to standard output or to every client of a TCP port.

`open_nmea_sink` takes ``-`` (standard output) or ``tcp://[HOST]:PORT`` (a small server:
each sentence goes to every client connected at that moment; gpsd reads such a source,
``gpsd -N tcp://localhost:PORT``). Sentences end in CR LF (NMEA 0183).
"""

from __future__ import annotations

import abc
import socket
import sys
import threading
from typing import TextIO

from ...errors import ConfigError
from ..frontend.stream_io import parse_host_port

__all__ = ["NmeaSink", "NmeaWriter", "NmeaServer", "open_nmea_sink"]


class NmeaSink(abc.ABC):
    """Where NMEA sentences go (`send`), closed at the end (`close`)."""

    description = "nmea"

    @abc.abstractmethod
    def send(self, sentences: list[str]) -> None:
        """Send one batch of sentences (without their CR LF)."""

    def close(self) -> None:  # noqa: B027  (deliberately empty: a sink with nothing to release keeps it)
        """Nothing to release by default."""


class NmeaWriter(NmeaSink):
    """Sentences written (and flushed) to a text stream, standard output by default."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream if stream is not None else sys.stdout
        self.description = "standard output"

    def send(self, sentences: list[str]) -> None:
        if sentences:
            self.stream.write("".join(s + "\r\n" for s in sentences))
            self.stream.flush()


class NmeaServer(NmeaSink):
    """A TCP server on ``(host, port)`` (port 0: any free one, `port` says which) sending
    each batch of sentences to every connected client; a client that fails is dropped."""

    def __init__(self, host: str = "", port: int = 0) -> None:
        try:
            self._listener = socket.create_server((host, port), reuse_port=False)
        except OSError as exc:
            raise ConfigError("nmea_out", f"cannot listen on {host or '*'}:{port} ({exc.strerror or exc})") from None
        self.port = self._listener.getsockname()[1]
        self.description = f"tcp://{host or '*'}:{self.port}"
        self._clients: list[socket.socket] = []
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._accept, name="gnssframework-nmea-server", daemon=True)
        self._thread.start()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:  # closed
                return
            with self._lock:
                self._clients.append(client)

    @property
    def n_clients(self) -> int:
        with self._lock:
            return len(self._clients)

    def send(self, sentences: list[str]) -> None:
        if not sentences:
            return
        data = "".join(s + "\r\n" for s in sentences).encode("ascii")
        with self._lock:
            keep = []
            for client in self._clients:
                try:
                    client.sendall(data)
                    keep.append(client)
                except OSError:
                    client.close()
            self._clients = keep

    def close(self) -> None:
        self._listener.close()
        with self._lock:
            for client in self._clients:
                try:
                    client.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass
                client.close()
            self._clients = []


def open_nmea_sink(spec: str) -> NmeaSink:
    """``-``: standard output; ``tcp://[HOST]:PORT``: an `NmeaServer` (all interfaces
    without HOST).

    Raises
    ------
    ConfigError
        Another spelling, a bad port, a port that cannot be listened on.
    """
    if spec == "-":
        return NmeaWriter()
    if spec.startswith("tcp://"):
        host, port = parse_host_port(spec, "tcp", "nmea_out", lowest_port=0)
        return NmeaServer(host, port)
    raise ConfigError("nmea_out", f"{spec!r}: give - (standard output) or tcp://[HOST]:PORT")
