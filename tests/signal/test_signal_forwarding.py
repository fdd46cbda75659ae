"""A function that holds a signal hands it on (issue 36's generic receiver).

Many library functions take ``signal: SignalSpec = GPS_L1CA``: the default keeps a GPS
caller short. Inside a function that has a signal of its own (a parameter or a local named
``signal``, ``spec`` or ``sp``), a call that leaves such a default in place silently
makes that step GPS L1 C/A's: a QZSS satellite looked up as ``G193``, a Galileo run timed
with C/A's periods. This test reads the library and the built-in plugins with `ast` and
fails on every such call, named by file and line.

Functions are matched by name (the library has few names defined twice with a ``signal``
default, and a false alarm costs an explicit ``signal=`` at one call). Only parameters
named ``signal`` count: ``default=GPS_L1CA`` fallbacks (`nmea_talker`, `_signal_of`) are
what they say.
"""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]
SOURCES = sorted([*(ROOT / "gnssframework").rglob("*.py"), *(ROOT / "plugins").glob("*.py")])
#: Names under which a function holds the signal it works on.
SIGNAL_NAMES = frozenset({"signal", "spec", "sp"})


def _defaults_gps(tree: ast.AST) -> dict[str, int | None]:
    """Functions whose ``signal`` parameter defaults to ``GPS_L1CA``: name -> its positional
    index (methods: after ``self``/``cls``), or None when keyword-only."""
    out: dict[str, int | None] = {}
    for node in ast.walk(tree):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        a = node.args
        positional = [x.arg for x in a.posonlyargs + a.args]
        defaults = dict(zip(positional[len(positional) - len(a.defaults) :], a.defaults))
        defaults.update({x.arg: v for x, v in zip(a.kwonlyargs, a.kw_defaults) if v is not None})
        value = defaults.get("signal")
        if isinstance(value, ast.Name) and value.id == "GPS_L1CA":
            skip = 1 if positional and positional[0] in ("self", "cls") else 0
            out[node.name] = positional.index("signal") - skip if "signal" in positional else None
    return out


def _unforwarded(path: pathlib.Path, takes_signal: dict[str, int | None], root: pathlib.Path = ROOT) -> list[str]:
    tree = ast.parse(path.read_text())
    found = []
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        params = {x.arg for x in fn.args.posonlyargs + fn.args.args + fn.args.kwonlyargs}
        assigned = {
            t.id for n in ast.walk(fn) if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)
        }
        held = (params | assigned) & SIGNAL_NAMES
        if not held:
            continue
        for call in ast.walk(fn):
            if not isinstance(call, ast.Call):
                continue
            f = call.func
            name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None
            if name not in takes_signal or name in ("__init__", "start"):  # generic names: classes, threads
                continue
            keywords = {k.arg for k in call.keywords}
            if "signal" in keywords or None in keywords:  # passed, or **kwargs
                continue
            index = takes_signal[name]
            if index is not None and (len(call.args) > index or any(isinstance(x, ast.Starred) for x in call.args)):
                continue
            found.append(
                f"{path.relative_to(root)}:{call.lineno}: {fn.name}() holds {'/'.join(sorted(held))} "
                f"but calls {name}() with its GPS L1 C/A default"
            )
    return found


def test_every_function_that_holds_a_signal_hands_it_on():
    takes_signal: dict[str, int | None] = {}
    for path in SOURCES:
        takes_signal.update(_defaults_gps(ast.parse(path.read_text())))
    assert len(takes_signal) > 50  # the rule reads what it should (81 functions on 5 Dec 2026)
    found = [line for path in SOURCES for line in _unforwarded(path, takes_signal)]
    assert not found, "\n".join(found)


def test_the_check_finds_a_call_that_drops_the_signal(tmp_path):
    # The rule itself: a held signal not handed on is found; handed on (by keyword or by
    # position) it is not.
    src = tmp_path / "m.py"
    src.write_text(
        "def timing(record, causal=True, signal=GPS_L1CA):\n    pass\n\n"
        "def dropped(record, signal):\n    return timing(record)\n\n"
        "def handed(record, signal):\n    return timing(record, signal=signal), timing(record, True, signal)\n"
    )
    takes = _defaults_gps(ast.parse(src.read_text()))
    assert takes == {"timing": 2}
    found = _unforwarded(src, takes, root=tmp_path)
    assert len(found) == 1 and "dropped() holds signal but calls timing()" in found[0]
