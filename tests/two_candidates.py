"""The smallest comparison of the statistics and claims tests: the multipath scenario, one
case (``only``), candidates ``a`` (kf) and ``b`` (ckf) of ``position-ca``, 4 runs in batches
of 2, in this process. Tests fill its store by hand, so every number they assert is theirs."""

from __future__ import annotations


def two_candidate_config(name: str, *, top: str = "", case_fields: str = "", sweeps: str = "",
                         claims: str = "") -> str:
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
