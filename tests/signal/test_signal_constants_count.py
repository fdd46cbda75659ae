"""The receiver is generic over signals: count the library files that use GPS L1 C/A's own
constants, and hold that count down (issue 36).

A file *uses C/A constants* when it

- imports one of C/A's names (`CA_NAMES`: the constants of ``signal.constants``, the code
  generator ``ca_code`` and its tap table, navdata's former ``BIT_PERIOD_S``);
- uses ``GPS_L1CA`` other than as a whole default (a function parameter's default, or a
  class attribute's, as ``signal: SignalSpec = GPS_L1CA``): a fallback such as
  ``signal or GPS_L1CA`` counts, and so does any attribute of it, even as a default
  (``wavelength_m: float = GPS_L1CA.wavelength_m`` fixes one signal's number where the
  block should read ``signal.wavelength_m`` of the signal it is handed);
- calls, at module level, one of its own functions whose ``GPS_L1CA`` default is left
  in place (``CODE_TO_CARRIER = code_to_carrier()``: a C/A constant under another name);
- writes one of C/A's own numbers (`CA_LITERALS`: 1.023 MHz, 1575.42 MHz, 1023 chips,
  1540 carrier cycles per chip) outside a signal description (`LITERALS_ALLOWED`), or
  binds one of C/A's generic numbers (1 ms code period, 20 ms bit, 20 periods per bit,
  50 bit/s: `CA_TIMING`) to a name about code periods, bits or bit detection
  (`TIMING_NAME`), as ``BIT_MS = 20``; other 1e-3s and 20s (probabilities, windows,
  unit conversions) are not C/A's and are not counted.

Read with `ast`, not by text search, so a comment or a docstring does not count.

`ALLOWED` files are where C/A lives for good (its description, its code generator, its
registration). `REMAINING` are the files that still use C/A constants (each with what it
uses, measured): the count of used files outside `ALLOWED` may only shrink. A new file fails the test, named in the message;
a file that stops using them should be taken off `REMAINING`.
"""

from __future__ import annotations

import ast
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]

#: C/A's names, by the module that defines them.
CA_NAMES: dict[str, frozenset[str]] = {
    "gnssframework.signal.constants": frozenset(
        {
            "CA_CHIP_RATE_HZ",
            "L1_FREQ_HZ",
            "L1_WAVELENGTH_M",
            "CA_CODE_LENGTH",
            "CA_CODE_PERIOD_S",
            "CA_CHIP_LENGTH_M",
            "NAV_BIT_RATE_HZ",
        }
    ),
    "gnssframework.signal.codes": frozenset({"ca_code", "G2_TAPS", "CA_CODE_LENGTH"}),
    "gnssframework.signal.navdata": frozenset({"BIT_PERIOD_S"}),
}
#: Where GPS L1 C/A is defined, generated and registered (the LNAV decoder,
#: gnssframework/navigation/lnav.py, needs none of these names).
ALLOWED = frozenset(
    {
        "gnssframework/signal/constants.py",  # the names themselves, read off GPS_L1CA
        "gnssframework/signal/gps_l1ca.py",  # the description
        "gnssframework/signal/codes.py",  # the code generator
        "plugins/signals.py",  # the registration
    }
)
#: Other signals' descriptions (and `spec.F0_HZ`, the 1.023 MHz every BOC rate is a multiple
#: of): C/A's numbers are theirs too (QZSS and SBAS L1 are C/A-like, Galileo E1 and BeiDou
#: B1C share its carrier).
LITERALS_ALLOWED = ALLOWED | frozenset(
    {
        "gnssframework/signal/spec.py",
        "gnssframework/signal/qzss_l1ca.py",
        "gnssframework/signal/sbas_l1.py",
        "gnssframework/signal/galileo_e1.py",
        "gnssframework/signal/beidou_b1c.py",
        "gnssframework/signal/gps_l5_codes.py",  # a code table: 1540 is Q5 PRN 114's XB advance
    }
)
#: C/A's own numbers: chip rate, carrier frequency, code length, carrier cycles per chip.
CA_LITERALS: dict[float, str] = {
    1.023e6: "1.023e6 (chip rate)",
    1575.42e6: "1575.42e6 (L1 carrier)",
    1023: "1023 (code length)",
    1540: "1540 (cycles per chip)",
}
#: C/A's timing numbers, counted only when bound to a `TIMING_NAME`.
CA_TIMING = frozenset({1e-3, 0.02, 20, 50})
# "detect" as a bit detection's name (DETECT_MS, FIRST_DETECT_S), not a missed detection's
# probability (missed_detection = 1e-3).
TIMING_NAME = re.compile(r"bit|code_period|^detect|detect_m?s$", re.IGNORECASE)
#: Files that still use C/A constants (measured), with what they use: none (the RINEX
#: reader takes L1's carrier from the signal descriptions, the tracker's detector cadence
#: is one symbol of its signal, the scenarios' T type reads their own signal).
REMAINING: frozenset[str] = frozenset()


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
    base = base[: len(base) - (node.level - 1)]
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
    if any(
        isinstance(n, ast.Name) and n.id == "GPS_L1CA" and isinstance(n.ctx, ast.Load) and id(n) not in defaults
        for n in ast.walk(tree)
    ):
        found.add("GPS_L1CA (not as a default)")
    found |= {
        f"GPS_L1CA.{n.attr}"
        for n in ast.walk(tree)
        if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name) and n.value.id == "GPS_L1CA"
    }
    found |= _module_level_default_calls(tree)
    if not any(module == _module(ROOT / f)[0] for f in LITERALS_ALLOWED):
        found |= _literals(tree)
    return found


def _module_level_default_calls(tree: ast.Module) -> set[str]:
    """Module-level calls of the module's own functions that leave a ``GPS_L1CA`` default in place."""
    signal_param: dict[str, tuple[int, str]] = {}  # function -> (position, name) of its GPS_L1CA parameter
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = [*node.args.posonlyargs, *node.args.args]
            for a, d in zip(args[len(args) - len(node.args.defaults) :], node.args.defaults):
                if isinstance(d, ast.Name) and d.id == "GPS_L1CA":
                    signal_param[node.name] = (args.index(a), a.arg)
    found: set[str] = set()
    for stmt in tree.body:
        if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            continue
        for n in ast.walk(stmt):
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in signal_param:
                pos, name = signal_param[n.func.id]
                if len(n.args) <= pos and name not in {k.arg for k in n.keywords}:
                    found.add(f"{n.func.id}() (its GPS_L1CA default)")
    return found


def _number(node: ast.AST) -> float | None:
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return node.value
    return None


def _literals(tree: ast.AST) -> set[str]:
    """C/A's own numbers anywhere, and its timing numbers bound to a timing name."""
    found = {CA_LITERALS[v] for n in ast.walk(tree) if (v := _number(n)) is not None and v in CA_LITERALS}
    bound: list[tuple[str, ast.AST]] = []  # (name, value) of assignments, defaults and keywords
    for n in ast.walk(tree):
        if isinstance(n, ast.Assign):
            bound += [(t.id, n.value) for t in n.targets if isinstance(t, ast.Name)]
        elif isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name) and n.value is not None:
            value = n.value  # a pydantic Field's default is its first argument
            if isinstance(value, ast.Call) and getattr(value.func, "id", "") == "Field" and value.args:
                value = value.args[0]
            bound.append((n.target.id, value))
        elif isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = [*n.args.posonlyargs, *n.args.args]
            bound += [(a.arg, d) for a, d in zip(args[len(args) - len(n.args.defaults) :], n.args.defaults)]
            bound += [(a.arg, d) for a, d in zip(n.args.kwonlyargs, n.args.kw_defaults) if d is not None]
        elif isinstance(n, ast.Call):
            bound += [(k.arg, k.value) for k in n.keywords if k.arg]
    found |= {
        f"{name} = {v!r}"
        for name, value in bound
        if (v := _number(value)) is not None and v in CA_TIMING and TIMING_NAME.search(name)
    }
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
        "block is handed, with GPS_L1CA only as a default)"
    )


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
        "from ..signal.gps_l1ca import GPS_L1CA\nX = GPS_L1CA.chip_rate_hz\n": {
            "GPS_L1CA (not as a default)",
            "GPS_L1CA.chip_rate_hz",
        },
        "from ..signal.gps_l1ca import GPS_L1CA\ndef f(s=GPS_L1CA):\n    return s\n": set(),
        "# L1_FREQ_HZ in a comment\nfrom ..signal.spec import SPEED_OF_LIGHT_M_S\n": set(),
        # the tightened forms: an attribute of GPS_L1CA even as a default, a fallback, ...
        "from ..signal.gps_l1ca import GPS_L1CA\nclass C:\n    w: float = GPS_L1CA.wavelength_m\n": {
            "GPS_L1CA.wavelength_m"
        },
        "from ..signal.gps_l1ca import GPS_L1CA\ndef f(w=GPS_L1CA.wavelength_m):\n    return w\n": {
            "GPS_L1CA.wavelength_m"
        },
        "from ..signal.gps_l1ca import GPS_L1CA\ndef f(s=None):\n    return s or GPS_L1CA\n": {
            "GPS_L1CA (not as a default)"
        },
        # ... a module constant from a default, C/A's numbers, a timing number named as one
        "from ..signal.gps_l1ca import GPS_L1CA\ndef g(signal=GPS_L1CA):\n    return 1.0\nK = g()\n": {
            "g() (its GPS_L1CA default)"
        },
        "from ..signal.gps_l1ca import GPS_L1CA\ndef g(signal=GPS_L1CA):\n    return 1.0\nK = g(X)\n": set(),
        "F = 1575.42e6\nR = 1.023e6\nN = 1023\n": {
            "1575.42e6 (L1 carrier)",
            "1.023e6 (chip rate)",
            "1023 (code length)",
        },
        "BIT_MS = 20\ndef f(code_period_s=1e-3):\n    return h(bit_period_s=0.02)\n": {
            "BIT_MS = 20",
            "code_period_s = 0.001",
            "bit_period_s = 0.02",
        },
        "class P:\n    first_detect_s: float = Field(0.02, gt=0)\n": {"first_detect_s = 0.02"},
        "window = 20\ndef f(pfa=1e-3, m=20):\n    return x * 1e-3\n": set(),
    }
    for text, want in cases.items():
        assert ca_uses_in(text, "gnssframework.receiver.probe") == want, text
