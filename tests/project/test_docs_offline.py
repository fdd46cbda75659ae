"""The docs work offline: the site config loads no script, stylesheet or font from another
host, MathJax is served with the site, and the checker CI runs on the built site finds
what would need a network."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


check = _load("check_offline", ROOT / "docs" / "check_offline.py")


def test_site_config_names_no_remote_script_and_serves_mathjax():
    text = (ROOT / "mkdocs.yml").read_text()
    assert not re.search(r"^\s*-\s*['\"]?https?://", text, re.M)  # no CDN in extra_javascript / extra_css
    assert re.search(r"^\s*font:\s*false", text, re.M)  # no font host
    assert f"- {check.MATHJAX}" in text
    assert "- docs/hooks/offline_math.py" in text


def test_remote_references_are_found_and_local_ones_are_not():
    html = (
        '<script src="https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-mml-chtml.js"></script>'
        '<link rel="stylesheet" href="//fonts.googleapis.com/css?family=Roboto">'
        "<style>@font-face { src: url('https://fonts.gstatic.com/x.woff2') }</style>"
        '<script src="javascripts/mathjax/tex-mml-chtml.js"></script>'
        '<a href="https://doi.org/10.1000/x">a citation link is no fetch</a>'
    )
    found = check.remote_references(html)
    assert len(found) == 3 and "cdn.jsdelivr" in found[0] and "googleapis" in found[1] and "gstatic" in found[2]


def test_problems_of_a_site(tmp_path):
    (tmp_path / "javascripts" / "mathjax").mkdir(parents=True)
    page = tmp_path / "index.html"
    page.write_text('<span class="arithmatex">\\(x\\)</span><script src="javascripts/mathjax/tex-mml-chtml.js">')
    assert check.problems(tmp_path) == [f"{tmp_path / check.MATHJAX}: MathJax is not served with the site"]
    (tmp_path / check.MATHJAX).write_text("// MathJax")
    assert check.problems(tmp_path) == []
    page.write_text('<span class="arithmatex">\\(x\\)</span><script src="https://cdn.x/tex-mml-chtml.js">')
    assert check.problems(tmp_path) == ['index.html: <script src="https://cdn.x/tex-mml-chtml.js']
    assert check.main([str(tmp_path)]) == 1


def test_a_passing_site_gets_a_one_line_summary_and_a_failing_one_none(tmp_path, capsys):
    (tmp_path / "javascripts" / "mathjax").mkdir(parents=True)
    (tmp_path / check.MATHJAX).write_text("// MathJax")
    (tmp_path / "index.html").write_text("<p>a</p>")
    (tmp_path / "about.html").write_text("<p>b</p>")
    (tmp_path / "site.css").write_text("p { color: red }")
    assert check.main([str(tmp_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 1 and out[0].startswith("offline: 2 pages and 1 stylesheets load nothing from another host")
    (tmp_path / "about.html").write_text('<script src="https://cdn.x/a.js"></script>')
    assert check.main([str(tmp_path)]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and "about.html" in captured.err


def test_source_listings_stay_out_of_the_search_index_and_scripts_out_of_the_site():
    hook = _load("search_index", ROOT / "docs" / "hooks" / "search_index.py")
    html = (
        '<details class="mkdocstrings-source"><summary>Source code in <code>a.py</code></summary>'
        '<p>prose</p><details class="quote"><summary>Source code in'
    )
    marked = hook.exclude_source(html)
    assert marked.count("data-search-exclude") == 2 and "<p>prose</p>" in marked
    assert hook.exclude_source(marked) == marked  # once only
    assert hook.exclude_source('<details class="note">') == '<details class="note">'
    text = (ROOT / "mkdocs.yml").read_text()
    assert "- docs/hooks/search_index.py" in text
    exclude = text[text.index("exclude_docs: |") : text.index("plugins:")]
    assert re.search(r"^\s+\*\.py$", exclude, re.M)  # check_offline.py, the table scripts...
