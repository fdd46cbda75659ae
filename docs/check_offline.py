"""Check that a built site works without a network: no page loads a script, a stylesheet
or a font from another host, and MathJax is served with the site.

Usage: ``python docs/check_offline.py SITE_DIR`` (after ``mkdocs build``); exits 1 naming
every page and address otherwise, and prints a one-line summary when the site passes.
CI runs it on the strict build.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

#: A <script src>, <link href> (stylesheet, font, preconnect) or CSS url() to another host.
REMOTE = re.compile(
    r"""<script[^>]*\ssrc=["'](https?:)?//[^"']+|<link[^>]*\shref=["'](https?:)?//[^"']+"""
    r"""|@import\s+url\(["']?(https?:)?//[^)"']+|url\(["']?(https?:)?//[^)"']+""",
    re.I,
)
#: The MathJax script the pages load, relative to the site.
MATHJAX = "javascripts/mathjax/tex-mml-chtml.js"


def remote_references(html: str) -> list[str]:
    """Every script, stylesheet, font or CSS ``url()`` of ``html`` fetched from another host.

    Examples
    --------
    >>> remote_references('<script src="https://cdn.x/mathjax.js"></script><script src="js/a.js"></script>')
    ['<script src="https://cdn.x/mathjax.js']
    """
    return [m.group(0) for m in REMOTE.finditer(html)]


def problems(site: Path) -> list[str]:
    """What keeps the site at ``site`` from working offline (empty: nothing)."""
    out = []
    if not (site / MATHJAX).is_file():
        out.append(f"{site / MATHJAX}: MathJax is not served with the site")
    pages = sorted(site.rglob("*.html")) + sorted(p for p in site.rglob("*.css") if "mathjax" not in p.parts)
    if not pages:
        out.append(f"{site}: no page")
    for page in pages:
        text = page.read_text(encoding="utf-8", errors="replace")
        out += [f"{page.relative_to(site)}: {ref}" for ref in remote_references(text)]
        if page.suffix == ".html" and "arithmatex" in text and MATHJAX.rsplit("/", 1)[-1] not in text:
            out.append(f"{page.relative_to(site)}: math without the MathJax script")
    return out


def summary(site: Path) -> str:
    """The one line printed when ``site`` passes: what was checked."""
    pages = len(list(site.rglob("*.html")))
    sheets = len([p for p in site.rglob("*.css") if "mathjax" not in p.parts])
    return (
        f"offline: {pages} pages and {sheets} stylesheets load nothing from another host; "
        f"MathJax is served with the site ({MATHJAX})"
    )


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    site = Path(argv[0])
    found = problems(site)
    for line in found:
        print(f"offline: {line}", file=sys.stderr)
    if not found:
        print(summary(site))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
