"""A comparison config built on another: the ``[base]`` table.

A variant of an example (the same candidates under other error sources, a labelled
control and its realistic twin) states only what differs::

    [base]
    file = "vector_tracking.toml"        # relative to this file
    drop = ["published", "claims"]       # the base's top-level keys not taken
    drop_candidates = ["ackf-literal"]   # the base's candidates left out, by name
    drop_cases = []                      # the base's cases left out, by name
    extend = ["candidates", "tuning.free"]  # arrays this file appends to, not replaces

The base is read (itself resolved first, so bases chain), the dropped keys, candidates and
cases are removed, and this file's keys are laid over it: a table (``scenario``,
``tuning``, ``executor``...) is merged key by key, recursively, this file's values winning;
anything else, arrays of tables included (``candidates``, ``cases``, ``claims``), replaces
the base's whole, except the arrays named in ``extend`` (dotted paths), which this file's
entries follow: a variant adds a candidate and its tuned parameters without copying the
base's. The result is validated as one config: the same model, the same
identity (`ComparisonConfig.identity`) as the file written out in full.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import ConfigError
from ..io.text import read_toml

__all__ = ["read_config_data", "merge_tables"]

#: The keys ``[base]`` takes.
BASE_KEYS = ("file", "drop", "drop_candidates", "drop_cases", "extend")


def merge_tables(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``over`` laid on it: tables merged key by key (recursively), any other
    value of ``over`` replacing the base's."""
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge_tables(out[key], value)
        else:
            out[key] = value
    return out


def _names(value: Any, field: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError(field, f"a list of names, got {value!r}")
    return value


def _drop_named(data: dict[str, Any], kind: str, names: list[str], base_file: Path) -> None:
    items = data.get(kind, [])
    have = [item.get("name") for item in items if isinstance(item, dict)]
    missing = [n for n in names if n not in have]
    if missing:
        raise ConfigError(
            f"base.drop_{kind}",
            f"{base_file.name} has no {kind[:-1]} {', '.join(map(repr, missing))}; it has {', '.join(map(repr, have))}",
        )
    data[kind] = [item for item in items if not (isinstance(item, dict) and item.get("name") in names)]


def read_config_data(path: str | Path, _chain: tuple[Path, ...] = ()) -> dict[str, Any]:
    """The comparison config of the TOML file ``path`` as one table, its ``[base]`` resolved
    (module docstring); a file without ``[base]`` is returned as read.

    Raises
    ------
    ConfigError
        Naming ``base`` or the ``base.*`` field: not a table, an unknown key, a base that
        includes itself, a dropped key, candidate or case the base does not have.
    DataFileError
        If a file is missing or not TOML (with its line).
    """
    path = Path(path)
    data = read_toml(path)
    if "base" not in data:
        return data
    spec = data.pop("base")
    if not isinstance(spec, dict) or not isinstance(spec.get("file"), str):
        raise ConfigError("base", f'in {path.name}: a table with file = "other.toml", got {spec!r}')
    unknown = sorted(set(spec) - set(BASE_KEYS))
    if unknown:
        raise ConfigError(f"base.{unknown[0]}", f"in {path.name}: unknown key; allowed: {', '.join(BASE_KEYS)}")
    base_file = (path.parent / spec["file"]).resolve()
    chain = (*_chain, path.resolve())
    if base_file in chain:
        raise ConfigError("base.file", f"{' -> '.join(p.name for p in (*chain, base_file))} includes itself")
    base = read_config_data(base_file, chain)
    for key in _names(spec.get("drop", []), "base.drop"):
        if key not in base:
            raise ConfigError("base.drop", f"{base_file.name} has no key {key!r} to drop")
        del base[key]
    for kind in ("candidates", "cases"):
        _drop_named(base, kind, _names(spec.get(f"drop_{kind}", []), f"base.drop_{kind}"), base_file)
    for dotted in _names(spec.get("extend", []), "base.extend"):
        _extend(base, data, dotted, base_file, path)
    return merge_tables(base, data)


def _extend(base: dict[str, Any], data: dict[str, Any], dotted: str, base_file: Path, path: Path) -> None:
    """Put the base's array at ``dotted`` before this file's (both must be arrays)."""
    *tables, key = dotted.split(".")
    b, d = base, data
    for name in tables:
        b, d = b.get(name, {}), d.get(name, {})
        if not isinstance(b, dict) or not isinstance(d, dict):
            raise ConfigError("base.extend", f"{dotted!r}: {name!r} is not a table")
    if not isinstance(b.get(key), list):
        raise ConfigError("base.extend", f"{base_file.name} has no array {dotted!r} to extend")
    if not isinstance(d.get(key), list):
        raise ConfigError("base.extend", f"{path.name} has no array {dotted!r} to append")
    d[key] = b[key] + d[key]
