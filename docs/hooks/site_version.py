"""mkdocs hook: the package's version in every page's header (``gnssframework 0.1.0``),
read from the installed package, whose version comes from pyproject.toml alone."""

from __future__ import annotations

from gnssframework import __version__


def on_config(config):
    config["site_name"] = f"{config['site_name']} {__version__}"
    return config
