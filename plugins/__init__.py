"""gnssframework's built-in plugins.

This package is registered through the ``gnssframework`` entry-point group in
``pyproject.toml``, exactly like a third-party plugin: the core never imports it.

Its ``register_<kind>`` hooks register every plugin class its modules define
(`gnssframework.registry.plugin_hooks`): adding a built-in plugin is writing its class
in the module of its kind (or a new module here), with its own ``name``; nothing here
lists it.
"""

from __future__ import annotations

from gnssframework.registry import plugin_hooks, submodules

globals().update(plugin_hooks(*submodules(__name__, __path__)))
