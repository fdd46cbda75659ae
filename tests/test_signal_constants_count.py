"""The receiver is generic over signals: count the library files that use GPS L1 C/A's own
constants, and hold that count down (issue 36).

A file *uses C/A constants* when it imports one of C/A's names (`CA_NAMES`: the constants
of ``signal.constants``, the code generator ``ca_code`` and its tap table, navdata's
``BIT_PERIOD_S``) or uses ``GPS_L1CA`` other than as a default (a function parameter's
default, or a class attribute's, as ``signal: SignalSpec = GPS_L1CA``). Read with `ast`,
not by text search, so a comment or a docstring does not count.

`ALLOWED` files are where C/A lives for good (its description, its code generator, its
registration). `REMAINING` are the files that still use C/A constants: the count of used
files outside `ALLOWED` may only shrink. A new file fails the test, named in the message;
a file that stops using them should be taken off `REMAINING`.
"""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: C/A's names, by the module that defines them.
CA_NAMES: dict[str, frozenset[str]] = {
    "gnssframework.signal.constants": frozenset({"CA_CHIP_RATE_HZ", "L1_FREQ_HZ", "L1_WAVELENGTH_M", "CA_CODE_LENGTH",
                                                 "CA_CODE_PERIOD_S", "CA_CHIP_LENGTH_M", "NAV_BIT_RATE_HZ"}),
    "gnssframework.signal.codes": frozenset({"ca_code", "G2_TAPS", "CA_CODE_LENGTH"}),
    "gnssframework.signal.navdata": frozenset({"BIT_PERIOD_S"}),
}
#: Where GPS L1 C/A is defined, generated and registered (the LNAV decoder,
#: gnssframework/navigation/lnav.py, needs none of these names).
ALLOWED = frozenset({
    "gnssframework/signal/constants.py",   # the names themselves, read off GPS_L1CA
    "gnssframework/signal/gps_l1ca.py",    # the description
    "gnssframework/signal/codes.py",       # the code generator
    "plugins/signals.py",                  # the registration
})
#: Files that still use C/A constants (measured).
REMAINING: frozenset[str] = frozenset()  # none left: every library block reads a SignalSpec


def _module(path: pathlib.Path) -> tuple[str, bool]:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[0] == "plugins":
        parts[0] = "gnssframework_plugins"
    is_package = parts[-1] == "__init__"
    return ".".join(parts[:-1] if is_package else parts), is_package


def _source(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _default_nodes(tree: ast.AST) -> set[int]:
    """ids of the nodes inside parameter defaults and class-attribute defaults."""
    ids: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            for d in [*node.args.defaults, *(d for d in node.args.kw_defaults if d is not None)]:
                ids |= {id(x) for x in ast.walk(d)}
        elif isinstance(node, ast.ClassDef):
            for stmt in node.body:
                if isinstance(stmt, ast.AnnAssign) and stmt.value is not None:
                    ids |= {id(x) for x in ast.walk(stmt.value)}
    return ids


def ca_uses(path: pathlib.Path) -> set[str]:
    """The C/A names ``path`` uses (see the module text); empty when none."""
    return ca_uses_in(path.read_text(), *_module(path))


def ca_uses_in(text: str, module: str, is_package: bool = False) -> set[str]:
    """The C/A names the source ``text`` of ``module`` uses."""
    tree = ast.parse(text)
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            source = _source(module, is_package, node)
            imported = {a.name for a in node.names}
            found |= imported & CA_NAMES.get(source, frozenset())
            if source == "gnssframework.signal":  # the modules themselves: any use of them
                found |= {f"module {m}" for m in imported if f"gnssframework.signal.{m}" in CA_NAMES}
        elif isinstance(node, ast.Import):
            found |= {f"module {a.name}" for a in node.names if a.name in CA_NAMES}
    defaults = _default_nodes(tree)
    if any(isinstance(n, ast.Name) and n.id == "GPS_L1CA" and isinstance(n.ctx, ast.Load) and id(n) not in defaults
           for n in ast.walk(tree)):
        found.add("GPS_L1CA (not as a default)")
    return found


def library_files() -> list[pathlib.Path]:
    return sorted(p for base in ("gnssframework", "plugins") for p in (ROOT / base).rglob("*.py"))


def test_the_count_of_files_using_ca_constants_does_not_grow():
    used = {str(p.relative_to(ROOT)): sorted(u) for p in library_files() if (u := ca_uses(p))}
    counted = {f: u for f, u in used.items() if f not in ALLOWED}
    new = {f: u for f, u in counted.items() if f not in REMAINING}
    assert len(counted) <= len(REMAINING) and not new, (
        "library files that use GPS L1 C/A constants instead of a SignalSpec: "
        + "; ".join(f"{f} ({', '.join(u)})" for f, u in sorted(new.items()))
        + f" (the count is {len(counted)}, at most {len(REMAINING)}: read the constants off the SignalSpec the "
        "block is handed, with GPS_L1CA only as a default)")


def test_every_listed_file_exists_and_remaining_ones_still_use_ca():
    """The lists stay true: a file taken off the library, or one that no longer uses C/A
    constants, must leave them (so the count goes down for good)."""
    for f in ALLOWED | REMAINING:
        assert (ROOT / f).is_file(), f"{f} is listed but does not exist"
    stale = sorted(f for f in REMAINING if not ca_uses(ROOT / f))
    assert not stale, f"no longer use C/A constants, take them off REMAINING: {', '.join(stale)}"


def test_the_scan_sees_an_import_a_relative_import_and_a_constant_use():
    """The scanner against snippets whose answer is known (as a module of gnssframework.receiver)."""
    cases = {
        "from gnssframework.signal.constants import L1_FREQ_HZ\n": {"L1_FREQ_HZ"},
        "from ..signal.codes import ca_code\n": {"ca_code"},
        "from ..signal import constants\n": {"module constants"},
        "from ..signal.gps_l1ca import GPS_L1CA\nX = GPS_L1CA.chip_rate_hz\n": {"GPS_L1CA (not as a default)"},
        "from ..signal.gps_l1ca import GPS_L1CA\ndef f(s=GPS_L1CA):\n    return s\n": set(),
        "from ..signal.gps_l1ca import GPS_L1CA\nclass C:\n    w: float = GPS_L1CA.wavelength_m\n": set(),
        "# L1_FREQ_HZ in a comment\nfrom ..signal.spec import SPEED_OF_LIGHT_M_S\n": set(),
    }
    for text, want in cases.items():
        assert ca_uses_in(text, "gnssframework.receiver.probe") == want, text
