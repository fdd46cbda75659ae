"""Read every recorded file of a data folder and say in one line what was read, or why not.

Run: python examples/read_recordings.py [DIR ...]
(default: ``../shared/data/rinex``, ``nmea`` and ``phone`` beside the repository). Each
file gives one line: its summary, or ``REFUSED <file>:<line>: <reason>``. Reading the 24 h
multi-GNSS CEBR file takes georinex several minutes; ``--select G`` reads GPS only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gnssframework.errors import DataFileError
from gnssframework.io.recordings import describe_recording

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = [ROOT.parent / "shared" / "data" / d for d in ("rinex", "nmea", "phone")]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="*", type=Path, default=DEFAULT)
    parser.add_argument("--select", default="all", help="satellites or systems of RINEX observation files")
    args = parser.parse_args(argv)
    for folder in args.folders:
        for path in sorted(p for p in folder.iterdir() if p.is_file() and p.name != "README.md"):
            try:
                print(describe_recording(path, args.select), flush=True)
            except DataFileError as exc:
                print(f"REFUSED {exc}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
