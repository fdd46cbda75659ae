"""mkdocs hook: serve MathJax with the site, so its math renders without a network.

The pages load MathJax 3 (``tex-mml-chtml.js``, the build a CDN would serve) from
``javascripts/mathjax/`` of the site itself: this hook adds the files of MathJax's es5
build, as the installed ``django-static-mathjax`` package ships them (MathJax 3.2.2 and
nothing else: it has no dependencies), to the files mkdocs copies. What the combined
script loads on demand (TeX extensions, fonts, the accessibility and speech components)
comes along; the other combined builds do not.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from mkdocs.structure.files import File, Files

#: Where the site serves MathJax (mkdocs.yml's extra_javascript names the script there).
SITE_DIR = "javascripts/mathjax"
#: The script the pages load and the folders it loads from.
PARTS = ("tex-mml-chtml.js", "a11y", "input", "output", "sre", "ui")


def mathjax_es5() -> Path:
    """The installed MathJax es5 build (``django-static-mathjax``, in the ``docs`` extra)."""
    try:
        root = Path(str(resources.files("mathjax"))) / "static" / "mathjax" / "es5"
    except ModuleNotFoundError:
        root = None
    if root is None or not (root / PARTS[0]).is_file():
        raise SystemExit('offline math: MathJax is not installed; pip install -e ".[docs]" (django-static-mathjax)')
    return root


def on_files(files: Files, config) -> Files:
    root = mathjax_es5()
    for part in PARTS:
        top = root / part
        for path in [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file()):
            uri = f"{SITE_DIR}/{path.relative_to(root).as_posix()}"
            files.append(File.generated(config, uri, abs_src_path=str(path)))
    return files
