"""Reading a whole input file safely: configs, logs, trajectories and almanacs.

The readers hold a file in memory, so they refuse what is not a regular file (a device
such as ``/dev/zero``, a FIFO, a directory: endless or not a file) and a file larger than
`MAX_INPUT_FILE_BYTES`, and say so naming the file, instead of reading without limit.
"""

from __future__ import annotations

import re
import stat
import tomllib
from pathlib import Path

from ..errors import DataFileError

__all__ = ["MAX_INPUT_FILE_BYTES", "check_input_file", "read_input_text", "read_toml"]

#: Largest input file a reader holds in memory (1 GiB: a day of 1 Hz RINEX is about 50 MB).
MAX_INPUT_FILE_BYTES = 2**30


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a pipe"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def check_input_file(path: str | Path) -> Path:
    """Return ``path`` if it is a regular file of at most `MAX_INPUT_FILE_BYTES`.

    Raises
    ------
    DataFileError
        Naming the file: missing, unreadable, not a regular file, or too large.
    """
    path = Path(path)
    try:
        info = path.stat()  # follows symbolic links: a link to /dev/zero is a device
    except FileNotFoundError:
        raise DataFileError(str(path), None, "no such file") from None
    except OSError as exc:
        raise DataFileError(str(path), None, f"cannot read: {exc.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        raise DataFileError(str(path), None, f"is {_kind(info.st_mode)}, not a regular file; give a file")
    if info.st_size > MAX_INPUT_FILE_BYTES:
        raise DataFileError(
            str(path),
            None,
            f"is {info.st_size} bytes, more than the {MAX_INPUT_FILE_BYTES} bytes a reader holds in memory",
        )
    return path


def read_input_text(path: str | Path, errors: str = "strict", encoding: str = "utf-8") -> str:
    """The text of input file ``path``, after `check_input_file`.

    Parameters
    ----------
    encoding
        The file's encoding (``"utf-8"``; NMEA logs are ``"ascii"``).
    errors
        How undecodable bytes are handled (``"strict"``: refused naming the line;
        ``"replace"``: kept as U+FFFD for the reader's own line checks).

    Raises
    ------
    DataFileError
        Naming the file (and the line of undecodable bytes).
    """
    path = check_input_file(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataFileError(str(path), None, f"cannot read: {exc.strerror}") from None
    try:
        return data.decode(encoding, errors=errors)
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise DataFileError(str(path), line, f"not {encoding.upper()} text (byte 0x{data[exc.start]:02x})") from None


def read_toml(path: str | Path) -> dict:
    """A TOML file's table, read as `read_input_text` reads text.

    Raises
    ------
    DataFileError
        If the file is missing or not TOML, with the line of the first error.
    """
    try:
        # A UTF-8 byte-order mark (many Windows editors write one) is no TOML: dropped.
        return tomllib.loads(read_input_text(path).removeprefix("\ufeff"))
    except tomllib.TOMLDecodeError as exc:
        # Python 3.11's TOMLDecodeError carries the position only in its message.
        found = re.search(r"\(at line (\d+), column \d+\)", str(exc))
        line = getattr(exc, "lineno", None) or (int(found.group(1)) if found else None)
        raise DataFileError(str(path), line, f"invalid TOML: {exc}") from None
