"""Names a config gives that become file or folder names of a results folder."""

from __future__ import annotations

__all__ = ["MAX_NAME_BYTES", "check_file_name"]

#: Longest name of a comparison, case, candidate or sweep (bytes): it becomes a file or
#: folder name, which most file systems cap at 255 bytes.
MAX_NAME_BYTES = 200


def check_file_name(name: str) -> str:
    """``name`` if it can be one file-name component of a results folder (a comparison's
    folder, a case's or candidate's raw-series folder, a sweep's plot), else
    ``ValueError``: empty, ``.`` or ``..``, a path separator, a control character (NUL
    included) or over `MAX_NAME_BYTES` would write elsewhere than ``--out`` or fail."""
    if not name.strip():
        raise ValueError("must not be empty: it names a folder or file of the results")
    if name in (".", ".."):
        raise ValueError(f"{name!r} is not a name but a folder: it would write outside its results folder")
    bad = [c for c in name if c in "/\\" or ord(c) < 32 or ord(c) == 127]
    if bad:
        raise ValueError(f"must be a plain file name, without path separators or control characters (got {name!r})")
    if len(name.encode("utf-8")) > MAX_NAME_BYTES:
        raise ValueError(f"is longer than {MAX_NAME_BYTES} bytes: it names a folder or file of the results")
    return name
