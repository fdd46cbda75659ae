"""A live sample stream read as a recording: a reader thread, a bounded queue, a sliding buffer.

`StreamRecording` is a `Recording` whose bytes come from a stream (`stream_io.connect`:
standard input, a FIFO, TCP, rtl_tcp) instead of a file, so acquisition and tracking read
it exactly as they read a file (same decoding: the format's ``sample_source`` plugin):

- a reader thread reads the stream in blocks of ``block_s`` and puts them on a queue of
  ``queue_blocks`` blocks (memory bounded: the queue plus the held window);
- the receiver pulls blocks when it reads beyond what it holds, and keeps the last
  ``retain_s`` of signal before the furthest read (acquisition's window, a re-acquisition
  at its clock's tick, just behind the channels' lead): a read further back is refused
  (`ConfigError`), never answered with other samples;
- when the receiver lags: by default the reader waits (backpressure: the pipe or socket
  fills and the producer waits); with ``realtime`` it drops the whole block it could not
  queue and counts it (`overruns`). Dropped samples keep their place in the sample count
  (every later sample keeps its true time); `dropped_between` tells the tracker, which
  marks the channels whose interval crosses a gap lost and re-acquires them after it; the
  gap's bytes read as zeros.

The stream's length is unknown until its end: `n_samples` is a bound larger than any
stream until then, the samples received after it.
"""

from __future__ import annotations

import queue
import sys
import threading
from pathlib import Path
from typing import BinaryIO
from collections.abc import Callable

import numpy as np

from ... import registry
from ...errors import ConfigError
from .recording import Recording, RecordingInfo, check_recording_info
from .soapy_io import SOAPY_FORMAT, SOAPY_SCHEME, SoapySettings, open_soapy
from .stream_io import RtlTcpSettings, connect

__all__ = ["StreamRecording", "open_stream", "OPEN_ENDED_SAMPLES"]

#: `StreamRecording.n_samples` until the stream ends (2^62: no stream reaches it).
OPEN_ENDED_SAMPLES = 1 << 62
_END = object()


class StreamRecording(Recording):
    """A `Recording` read from a binary stream (module text).

    Parameters
    ----------
    stream
        A binary file object (``read`` returns ``b""`` at the end).
    info
        Format, sample rate, IF, Q sign.
    block_s
        Signal per block read from the stream (whole chunks of the format).
    queue_blocks
        Blocks the queue holds between the reader and the receiver.
    retain_s
        Signal kept before the furthest read (re-reads within it are served).
    realtime
        Drop (and count) a block the queue cannot take instead of waiting.
    description
        Where the stream comes from, for messages.
    on_overrun
        Called with ``(first_sample, samples)`` from the reader thread at each dropped block.
    """

    is_live = True

    def __init__(
        self,
        stream: BinaryIO,
        info: RecordingInfo,
        *,
        block_s: float = 0.01,
        queue_blocks: int = 100,
        retain_s: float = 2.0,
        realtime: bool = False,
        description: str = "stream",
        on_overrun: Callable[[int, int], None] | None = None,
    ) -> None:
        self.path = Path(description)
        self.description = description
        self.info = info
        self.source = registry.create("sample_source", info.format)
        self.nonfinite_zeroed = 0
        self.trailing_bytes = 0
        self._floating = "f" in self.source.sigmf_datatype
        bpc, spc = self.source.bytes_per_chunk, self.source.samples_per_chunk
        if queue_blocks < 1:
            raise ConfigError("queue_blocks", f"must be >= 1, got {queue_blocks}")
        self.block_bytes = max(1, round(block_s * info.sample_rate_hz / spc)) * bpc
        self.retain_bytes = int(retain_s * info.sample_rate_hz / spc) * bpc
        self.realtime = realtime
        self.on_overrun = on_overrun
        self._stream = stream
        self._queue: queue.Queue = queue.Queue(maxsize=queue_blocks)
        self._blocks: list[tuple[int, np.ndarray]] = []  # (first byte, bytes) held, in order
        self._received = 0  # bytes pulled from the queue (including the dropped ones' places)
        self._low = 0  # bytes before this are no longer held
        self._ended = False
        self._error: BaseException | None = None
        #: Runs of dropped bytes ``(first byte, end byte)`` in order (reader thread appends).
        self.gaps: list[tuple[int, int]] = []
        self.overrun_blocks = 0
        #: Bytes read from the stream so far by the reader thread (queued, dropped or in a partial block).
        self.stream_bytes = 0
        self.device_gaps = 0  # runs of samples a device lost, zero-filled by its reader (`soapy_io`)
        if hasattr(stream, "on_lost"):
            stream.on_lost = self._device_lost
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._reader, name="gnssframework-stream-reader", daemon=True)
        self._thread.start()

    # -- reader thread ----------------------------------------------------------------
    def _reader(self) -> None:
        bpc = self.source.bytes_per_chunk
        offset = 0
        try:
            while not self._stop.is_set():
                data = bytearray()
                while len(data) < self.block_bytes:
                    more = self._stream.read(self.block_bytes - len(data))
                    if not more:
                        break
                    data += more
                    self.stream_bytes += len(more)
                whole = len(data) - len(data) % bpc
                if whole:
                    block = np.frombuffer(bytes(data[:whole]), np.uint8)
                    if self.realtime:
                        try:
                            self._queue.put_nowait((offset, block))
                        except queue.Full:
                            self._drop(offset, whole)
                    else:
                        self._put((offset, block))
                    offset += whole
                if len(data) < self.block_bytes:  # the stream ended
                    self.trailing_bytes = len(data) - whole
                    break
        except BaseException as exc:  # noqa: BLE001 - handed to the receiver's thread
            self._error = exc
        self._put((_END, offset))  # the end, after any dropped block

    def _put(self, item) -> None:
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.2)
                return
            except queue.Full:
                continue

    def _drop(self, offset: int, count: int) -> None:
        spc, bpc = self.source.samples_per_chunk, self.source.bytes_per_chunk
        if self.gaps and self.gaps[-1][1] == offset:
            self.gaps[-1] = (self.gaps[-1][0], offset + count)
        else:
            self.gaps.append((offset, offset + count))
        self.overrun_blocks += 1
        if self.on_overrun is not None:
            self.on_overrun(offset // bpc * spc, count // bpc * spc)

    def _device_lost(self, offset: int, count: int) -> None:
        # Zero samples the device's reader put in for samples it lost (``offset`` is the
        # stream's byte count, as the reader thread's): a gap like a dropped block's.
        # Counted and said in `overrun_summary` (not ``on_overrun``: the receiver did not lag).
        self.gaps.append((offset, offset + count))
        self.device_gaps += 1

    # -- receiver side ----------------------------------------------------------------
    def _pull(self, until_byte: int) -> None:
        """Take blocks off the queue until ``until_byte`` is held or the stream ended."""
        while not self._ended and self._received < until_byte:
            item = self._queue.get()
            if item[0] is _END:
                self._ended = True
                self._received = max(self._received, item[1])
                if self._error is not None:
                    raise ConfigError(
                        "recording", f"{self.description}: reading the stream failed: {self._error}"
                    ) from None
                break
            first, block = item
            self._blocks.append((first, block))
            self._received = first + block.size

    def _raw(self, offset_bytes: int, count_bytes: int) -> np.ndarray:
        with self._lock:  # the tracker's read-ahead thread reads too
            return self._held(offset_bytes, count_bytes)

    def _held(self, offset_bytes: int, count_bytes: int) -> np.ndarray:
        if offset_bytes < self._low:
            raise ConfigError(
                "recording",
                f"{self.description}: sample {self._sample(offset_bytes)} is no longer "
                f"held (a stream keeps the last {self._sample(self.retain_bytes)} samples "
                "before its furthest read)",
            )
        stop = offset_bytes + count_bytes
        self._pull(stop)
        stop = min(stop, self._received)
        out = np.zeros(max(0, stop - offset_bytes), np.uint8)  # a gap's bytes stay 0
        for first, block in self._blocks:
            lo, hi = max(first, offset_bytes), min(first + block.size, stop)
            if lo < hi:
                out[lo - offset_bytes : hi - offset_bytes] = block[lo - first : hi - first]
        low = max(self._low, offset_bytes - self.retain_bytes)
        if low > self._low:
            self._low = low
            self._blocks = [(f, b) for f, b in self._blocks if f + b.size > low]
        return out

    def _sample(self, byte: int) -> int:
        return byte // self.source.bytes_per_chunk * self.source.samples_per_chunk

    @property
    def n_samples(self) -> int:
        """`OPEN_ENDED_SAMPLES` until the stream ends, then the samples it held."""
        return self._sample(self._received) if self._ended else OPEN_ENDED_SAMPLES

    @property
    def ended(self) -> bool:
        """The stream has ended and every block has been taken off the queue."""
        return self._ended

    @property
    def received_samples(self) -> int:
        """Samples taken off the queue so far (their places: dropped ones count)."""
        return self._sample(self._received)

    @property
    def queued_blocks(self) -> tuple[int, int]:
        """``(blocks on the queue now, blocks it holds)``."""
        return self._queue.qsize(), self._queue.maxsize

    def overruns(self) -> tuple[int, int]:
        """``(blocks, samples)`` dropped so far (``realtime`` only), with a device's lost
        samples (zero-filled runs, `soapy_io`) counted among the samples."""
        return self.overrun_blocks, sum(self._sample(b) - self._sample(a) for a, b in list(self.gaps))

    def overrun_summary(self) -> str:
        """``"overruns: N blocks (X s of signal) dropped"``, and what the device lost where
        its reader counts that (``"; device overflows: ..."``)."""
        blocks, samples = self.overruns()
        samples -= getattr(self._stream, "lost_samples", 0)  # the device's, said apart
        device = getattr(self._stream, "summary", lambda: "")()
        return f"overruns: {blocks} blocks ({samples / self.info.sample_rate_hz:.3f} s of signal) dropped" + (
            f"; {device}" if device else ""
        )

    @property
    def device_lost(self) -> bool:
        """Whether the device reported lost samples (overflows), whatever ``realtime``."""
        return bool(getattr(self._stream, "overflows", 0))

    def dropped_between(self, first: int, stop: int) -> tuple[int, int] | None:
        for a, b in list(self.gaps):
            lo, hi = self._sample(a), self._sample(b)
            if lo < stop and first < hi:
                return lo, hi
        return None

    def close(self) -> None:
        """Stop the reader thread and close the stream."""
        self._stop.set()
        try:
            while True:
                self._queue.get_nowait()
        except queue.Empty:
            pass
        for closing in (getattr(self._stream, "_gnss_socket", None), self._stream):
            if closing is not None and closing is not sys.stdin.buffer:
                try:
                    closing.close()
                except OSError:
                    pass


def open_stream(
    address: str | BinaryIO,
    format: str,
    sample_rate_hz: float,
    if_hz: float = 0.0,
    q_sign: int = 1,
    *,
    realtime: bool = False,
    block_s: float = 0.01,
    buffer_s: float = 1.0,
    retain_s: float = 2.0,
    rtl_tcp: RtlTcpSettings | None = None,
    soapy: SoapySettings | None = None,
    on_overrun: Callable[[int, int], None] | None = None,
) -> StreamRecording:
    """A `StreamRecording` of ``address`` (`stream_io.connect`'s, or an open binary file
    object); the format, rate, IF and Q sign are checked as `open_recording` checks them.
    ``buffer_s`` of signal is queued between the reader and the receiver (``buffer_s /
    block_s`` blocks)."""
    info = check_recording_info(format, sample_rate_hz, if_hz, q_sign)
    if not block_s > 0 or not buffer_s >= block_s:
        raise ConfigError("buffer_s", f"need 0 < block_s <= buffer_s, got block_s {block_s:g}, buffer_s {buffer_s:g}")
    if isinstance(address, str) and address.startswith(SOAPY_SCHEME):
        if info.format != SOAPY_FORMAT:
            raise ConfigError(
                "format", f"{address}: a SoapySDR device is read as {SOAPY_FORMAT} (CS16), not {info.format}"
            )
        stream, description = open_soapy(address, soapy or SoapySettings(sample_rate_hz))
    elif isinstance(address, str):
        stream, description = connect(address, rtl_tcp)
    else:
        stream, description = address, getattr(address, "name", "stream")
    return StreamRecording(
        stream,
        info,
        block_s=block_s,
        queue_blocks=max(1, round(buffer_s / block_s)),
        retain_s=retain_s,
        realtime=realtime,
        description=str(description),
        on_overrun=on_overrun,
    )
