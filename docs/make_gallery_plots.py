"""Regenerate the gallery page's figure by running the page's own code.

    python docs/make_gallery_plots.py      # writes docs/img/gallery-frames.png

The page (docs/gallery.md) is the script: its Python blocks run in order in docs/img/, so
the figure is what a reader running the page gets.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

DOCS = Path(__file__).resolve().parent


def main() -> None:
    blocks = re.findall(r"```python\n(.*?)```", (DOCS / "gallery.md").read_text(), re.S)
    os.chdir(DOCS / "img")
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(DOCS / "gallery.md"), "exec"), namespace)  # noqa: S102 - the page's own code
    print(f"wrote {DOCS / 'img' / 'gallery-frames.png'}")


if __name__ == "__main__":
    main()
