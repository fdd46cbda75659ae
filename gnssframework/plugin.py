"""The base class every plugin derives from: a name, a description, a parameter model.

A plugin class declares its parameters as a nested pydantic model ``Params``. The
registry validates keyword arguments against it, so a typo or an out-of-range value
is caught with the field's name before any filter runs::

    class MyFilter(Estimator):
        name = "my-filter"
        description = "One line shown by `gnssframework plugins`."

        class Params(PluginParams):
            alpha: float = Field(1e-3, gt=0, le=1)

        def __init__(self, **params):
            super().__init__(**params)
            self.alpha = self.params.alpha
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, ValidationError

from .errors import ConfigError

__all__ = ["Plugin", "PluginParams", "validation_message"]


class PluginParams(BaseModel):
    """Base of every plugin's parameter model: unknown parameters are an error."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def validation_message(exc: ValidationError, prefix: str = "") -> ConfigError:
    """Turn a pydantic ``ValidationError`` into one ``ConfigError``.

    The message names every offending field (dotted, with ``prefix``), what it got and
    what it allows, one per line.
    """
    items = []
    for err in exc.errors():
        loc = ".".join(str(p) for p in err["loc"])
        field = f"{prefix}.{loc}" if prefix and loc else (loc or prefix)
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown parameter"
        elif "input" in err and err["type"] != "missing":
            msg = f"{msg} (got {err['input']!r})"
        items.append((field, msg))
    if len(items) == 1:
        return ConfigError(*items[0])
    return ConfigError(items[0][0], "invalid values:\n  " + "\n  ".join(f"{f}: {m}" for f, m in items))


class Plugin:
    """Base class of all plugins.

    Attributes
    ----------
    name
        Registry name, lower-case with dashes (``"svd-ckf"``).
    description
        One line shown by ``gnssframework plugins``.
    Params
        The pydantic parameter model; ``self.params`` holds the validated instance.
    """

    kind: ClassVar[str] = ""
    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    Params: ClassVar[type[PluginParams]] = PluginParams

    def __init__(self, **params: Any) -> None:
        try:
            self.params = self.Params(**params)
        except ValidationError as exc:
            raise validation_message(exc, prefix=f"{self.kind or 'plugin'} {self.name!r}") from None

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.model_dump().items())
        return f"{type(self).__name__}({args})"
