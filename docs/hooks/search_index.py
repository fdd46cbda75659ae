"""mkdocs hook: the API pages' source listings stay out of the search index.

mkdocstrings shows each object's source (``show_source``) in a ``<details
class="mkdocstrings-source">`` block (``class="quote"`` in older versions): most of an API
page's text, and most of the search index, which a browser must load and index before the
first search. Marking the blocks ``data-search-exclude`` (honoured by mkdocs-material's
search plugin) leaves the docstrings, signatures and prose searchable.
"""

from __future__ import annotations

import re

#: The opening tag of a source listing.
SOURCE_BLOCK = re.compile(r'<details class="(?:mkdocstrings-source|quote)"(?![^>]*data-search-exclude)')


def exclude_source(html: str) -> str:
    """``html`` with every source listing marked ``data-search-exclude``.

    >>> exclude_source('<details class="mkdocstrings-source"><summary>Source code in')
    '<details class="mkdocstrings-source" data-search-exclude><summary>Source code in'
    """
    return SOURCE_BLOCK.sub(lambda m: m.group(0) + " data-search-exclude", html)


def on_page_content(html, page, config, files):
    return exclude_source(html)
