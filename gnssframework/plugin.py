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

import inspect
import math
import re
import types
import typing
from typing import Any, ClassVar
from collections.abc import Sequence

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from .errors import ConfigError
from .suggest import did_you_mean

__all__ = ["Plugin", "PluginParams", "validation_message", "field_path", "refuse_quiet_conversions"]


def _scalar_type(annotation: Any) -> type | None:
    """``int``, ``float`` or ``bool`` behind ``Optional[...]``/``Annotated[...]``, else ``None``."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _scalar_type(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return _scalar_type(args[0]) if len(args) == 1 else None
    return annotation if annotation in (int, float, bool) else None


def _element_type(annotation: Any) -> type | None:
    """``int``, ``float`` or ``bool`` of ``list[...]``/``tuple[...]`` elements (behind
    ``Optional``/``Annotated``; a tuple's elements all of one type), else ``None``."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _element_type(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return _element_type(args[0]) if len(args) == 1 else None
    if origin in (list, tuple):
        kinds = {_scalar_type(a) for a in typing.get_args(annotation) if a is not Ellipsis}
        return kinds.pop() if len(kinds) == 1 else None
    return None


#: Largest magnitude of a number parameter: beyond it a covariance's products and squares
#: overflow double precision (1e100 cubed is 1e300) and a filter returns finite nonsense
#: (``q0 = 1e300`` gave an error RMS of 1e136) instead of failing.
MAX_PARAMETER_MAGNITUDE = 1e100


def _number_problem(value: Any, kind: type | None) -> str | None:
    """Why ``value`` is no number of ``kind`` (int or float), or ``None``."""
    if kind not in (int, float):
        return None
    if isinstance(value, (bool, str)):
        return f"must be a number, not a {type(value).__name__} (got {value!r})"
    if isinstance(value, float) and not math.isfinite(value):
        return f"must be a finite number (got {value!r})"
    if isinstance(value, (int, float)) and abs(value) > MAX_PARAMETER_MAGNITUDE:
        return (
            f"{value:g} is beyond +-{MAX_PARAMETER_MAGNITUDE:g}, where a filter's squares and products "
            "overflow double precision"
        )
    return None


def refuse_quiet_conversions(model: type[BaseModel], data: Any) -> Any:
    """Refuse, naming the field, the inputs pydantic would quietly convert: a string or a
    boolean for a number (``runs = "2"``, ``alpha = true``, also as a list's element:
    ``q0 = [true, 0.1, 0.01]``), a string or a number for a boolean; and a number that is
    not finite or beyond `MAX_PARAMETER_MAGNITUDE` (``dt_s = inf``, ``q0 = [1e300, ...]``).
    Integers stay valid numbers (TOML's ``alpha = 1``)."""
    if not isinstance(data, dict):
        return data
    fields = config_fields(model)
    for name, value in data.items():
        field = fields.get(name) if isinstance(name, str) else None
        kind = _scalar_type(field.annotation) if field is not None else None
        problem = _number_problem(value, kind)
        if problem:
            raise NestedFieldError(name, problem)
        if kind is bool and isinstance(value, (str, int, float)) and not isinstance(value, bool):
            raise NestedFieldError(name, f"must be true or false (got {value!r})")
        element = _element_type(field.annotation) if field is not None and kind is None else None
        if element is not None and isinstance(value, (list, tuple)):
            for i, item in enumerate(value):
                problem = _number_problem(item, element)
                if problem:
                    raise NestedFieldError(f"{name}[{i}]", problem)
    return data


def config_fields(model: type[BaseModel]) -> dict[str, Any]:
    """A model's fields by every name a config or a call may give them: the field's name
    and, for a field with an alias, the alias (``lambda`` in TOML for the Python ``lam``)."""
    out = dict(model.model_fields)
    out.update({info.alias: info for info in model.model_fields.values() if info.alias})
    return out


def config_names(model: type[BaseModel]) -> list[str]:
    """The parameter names a config writes: each field's alias where it has one."""
    return [info.alias or name for name, info in model.model_fields.items()]


class PluginParams(BaseModel):
    """Base of every plugin's parameter model: unknown parameters are an error, defaults
    are validated like given values (a nested plugin's default name is resolved), and a
    string or boolean for a number is refused rather than converted.

    A parameter whose config name is no Python identifier (``lambda``) is a field with an
    alias, ``lam: float = Field(1.0, alias="lambda")``: a config writes ``lambda``, Python
    passes either (``UKF(lam=...)`` or ``**{"lambda": ...}``), and errors, ``--describe``
    and the schema all name it ``lambda``."""

    model_config = ConfigDict(
        extra="forbid", frozen=True, validate_default=True, validate_by_name=True, validate_by_alias=True
    )

    #: For a plugin without parameters: why it needs none (shown in its parameter table).
    no_parameters: ClassVar[str] = ""

    @model_validator(mode="before")
    @classmethod
    def _no_quiet_conversions(cls, data: Any) -> Any:
        return refuse_quiet_conversions(cls, data)


def field_path(loc: Sequence[Any], prefix: str = "") -> str:
    """Write a pydantic location the one way the library writes field paths.

    >>> field_path(("candidates", 0, "estimator", "alpha"))
    'candidates[0].estimator.alpha'
    >>> field_path(("alpha",), prefix="cases[1]")
    'cases[1].alpha'
    """
    out = prefix
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def _submodel(annotation: Any) -> type[BaseModel] | None:
    """The pydantic model inside ``annotation`` (through Optional, list, dict values)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _submodel(arg)
        if found is not None:
            return found
    return None


def _model_at(model: type[BaseModel] | None, loc: Sequence[Any]) -> type[BaseModel] | None:
    """The model that owns the last element of ``loc`` (indices skipped)."""
    for part in loc[:-1]:
        if model is None:
            return None
        if isinstance(part, int):
            continue
        field = config_fields(model).get(str(part))
        model = _submodel(field.annotation) if field is not None else None
    return model


def _config_loc(model: type[BaseModel] | None, loc: Sequence[Any]) -> tuple[Any, ...]:
    """``loc`` with a field given by its Python name written as a config writes it (its
    alias: ``lam`` -> ``lambda``), so an error names a parameter one way."""
    owner = _model_at(model, loc) if loc and isinstance(loc[-1], str) else None
    info = owner.model_fields.get(loc[-1]) if owner is not None else None
    return (*loc[:-1], info.alias) if info is not None and info.alias else tuple(loc)


class NestedFieldError(ValueError):
    """A nested plugin's invalid field, raised inside a validator so that pydantic carries
    it to `validation_message`, which appends ``field`` to the outer path (one dotted path
    from the config's root to the offending nested parameter)."""

    def __init__(self, field: str, detail: str) -> None:
        super().__init__(f"{field}: {detail}")
        self.field = field
        self.detail = detail


def validation_message(exc: ValidationError, prefix: str = "", model: type[BaseModel] | None = None) -> ConfigError:
    """Turn a pydantic ``ValidationError`` into one ``ConfigError``.

    The message names every offending field (a path like ``candidates[0].estimator``,
    with ``prefix``), what it got and what it allows, on one line (the first field
    leads). Given the validated ``model``, an unknown parameter lists the valid ones, and
    a parameter written beside a plugin's ``name`` instead of under ``params`` gets a hint.
    """
    items = []
    for err in exc.errors():
        field = field_path(_config_loc(model, err["loc"]), prefix)
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown parameter"
            owner = _model_at(model, err["loc"])
            if owner is not None:
                fields = sorted(config_names(owner))
                msg += f"; valid: {', '.join(fields) or '(none)'}{did_you_mean(err['loc'][-1], fields)}"
                if set(fields) == {"name", "params"}:
                    msg += (
                        f"; plugin parameters go under `params`: "
                        f"{{ name = ..., params = {{ {err['loc'][-1]} = ... }} }}"
                    )
        elif err["type"] == "value_error" and "error" in err.get("ctx", {}):
            error = err["ctx"]["error"]
            if isinstance(error, NestedFieldError):  # a nested plugin's field: extend the path
                field, msg = f"{field}.{error.field}" if field else error.field, error.detail
            else:
                msg = str(error)  # our own validators' messages are complete
        elif "input" in err and err["type"] != "missing":
            msg = f"{msg} (got {err['input']!r})"
            if err["type"] in ("literal_error", "enum"):  # e.g. 'OCXO' for 'ocxo'
                msg += did_you_mean(err["input"], re.findall(r"'([^']*)'", str(err.get("ctx", {}).get("expected"))))
        items.append((field, msg))
    if len(items) == 1:
        return ConfigError(*items[0])
    # One line, the first field leading: a CLI error is one line, and ConfigError.field names it.
    rest = "; ".join(f"{f}: {m}" for f, m in items[1:])
    return ConfigError(items[0][0], f"{items[0][1]}; also {rest}")


def params_signature(model: type[BaseModel]) -> inspect.Signature:
    """The keyword-only signature ``(*, field: type = default, ...)`` of a parameter model,
    for a plugin class whose ``__init__`` takes its ``Params`` as keywords."""
    parameters = []
    for name, info in model.model_fields.items():
        default = inspect.Parameter.empty if info.is_required() else info.get_default(call_default_factory=True)
        try:
            parameters.append(
                inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=info.annotation)
            )
        except ValueError:  # a field named like a Python keyword cannot be a keyword argument
            continue
    return inspect.Signature(parameters)


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

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.__init__ is Plugin.__init__:  # its parameters are its Params' fields: say so to help() and IDEs
            # inspect.signature reads __signature__ off the class; `type` declares no such attribute
            cls.__signature__ = params_signature(cls.Params)  # type: ignore[attr-defined]

    def __init__(self, **params: Any) -> None:
        try:
            self.params = self.Params(**params)
        except ValidationError as exc:
            raise validation_message(exc, prefix=f"{self.kind or 'plugin'} {self.name!r}", model=self.Params) from None

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.model_dump().items())
        return f"{type(self).__name__}({args})"
