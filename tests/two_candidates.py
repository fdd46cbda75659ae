"""The smallest comparison of the statistics and claims tests: the multipath scenario, one
case (``only``), candidates ``a`` (kf) and ``b`` (ckf) of ``position-ca``, 4 runs in batches
of 2, in this process. Tests fill its store by hand, so every number they assert is theirs."""

from __future__ import annotations

import json


def two_candidate_config(name: str, *, top: str = "", case_fields: str = "", sweeps: str = "", claims: str = "") -> str:
    """The TOML text; ``top`` goes with the top-level keys, ``case_fields`` into the case,
    ``sweeps`` before the candidates and ``claims`` after them."""
    return f"""name = "{name}"
runs = 4
batch_size = 2
{top}
[executor]
workers = 1
[scenario]
kind = "multipath"
epochs = 40
[[cases]]
name = "only"
{case_fields}
{sweeps}
[[candidates]]
name = "a"
nav_filter = {{ name = "position-ca" }}
estimator = {{ name = "kf" }}
[[candidates]]
name = "b"
nav_filter = {{ name = "position-ca" }}
estimator = {{ name = "ckf" }}
{claims}
"""


def claim_toml(**fields) -> str:
    """One ``[[claims]]`` table of ``fields`` (values as JSON, which TOML reads alike)."""
    return "[[claims]]\n" + "\n".join(f"{k} = {json.dumps(v)}" for k, v in fields.items()) + "\n"


def evaluate_stored(tmp_path, claims: str, a, b, top: str = ""):
    """``(rows, config, store)``: the ``claims`` of `two_candidate_config` evaluated on a store
    holding the per-run values ``a`` of candidate a and ``b`` of b for every metric."""
    from gnssframework.experiments import load_config
    from gnssframework.experiments.claims import evaluate_claims
    from gnssframework.experiments.store import ResultStore

    path = tmp_path / "c.toml"
    path.write_text(two_candidate_config("claims", claims=claims, top=top))
    config = load_config(path)
    store = ResultStore(tmp_path / "results.sqlite")
    key = config.identity()
    store.register(key, config.batch_size)
    for name, values in (("a", a), ("b", b)):
        for first in (0, 2):
            store.add_batch(key, "only", name, first, {m: values[first : first + 2] for m in config.metric_names})
    return evaluate_claims(config, store), config, store


def compare_check(path, out, timeout: float | None = None):
    """``gnssframework compare PATH --out OUT --quiet --check`` in a fresh interpreter (as a
    user runs it); the finished process (``returncode``, ``stdout``, ``stderr``)."""
    import subprocess
    import sys

    command = [sys.executable, "-m", "gnssframework", "compare", str(path), "--out", str(out), "--quiet", "--check"]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)
