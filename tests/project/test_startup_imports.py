"""What a run of the CLI imports before it starts work.

Five modules import ``scipy.special`` rather than ``scipy.stats``, and ``scipy.signal``
only inside the functions that need it, because each costs every run of the CLI about
half a second of start-up (docs/benchmarks.md, "Peak memory" and the receiver's
start-up). One plugin importing ``scipy.stats`` at module level undid that for every run
(the plugin registry imports every built-in plugin's module): this test names it.
"""

from __future__ import annotations

import json
import subprocess
import sys

#: Modules the start-up must not import (each costs ~0.5 s or more of every run).
HEAVY = ("scipy.stats", "scipy.signal", "matplotlib", "pandas")

_CODE = """
import json, sys
import gnssframework.cli
from gnssframework import registry
registry.create("acquisition", "pcps")  # loads the plugin registry: every built-in plugin's module
for kind in registry.kinds():
    registry.names(kind)
print(json.dumps(sorted(m for m in sys.modules if m in HEAVY)))
"""


def test_cli_start_up_imports_no_heavy_module():
    code = f"HEAVY = {HEAVY!r}\n" + _CODE
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []
