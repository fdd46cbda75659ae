"""Small comparisons of the threshold tests (`tracking-threshold`, built in the test's
process): ``tiny_threshold`` runs in seconds (two scalar PLLs, 8 runs, one C/N0 sweep);
``constructed`` is for stores filled by hand (runs are never made)."""

from __future__ import annotations

from typing import Any


def tiny_threshold(threshold: dict[str, Any], **sweep: Any) -> dict[str, Any]:
    """An 18 Hz and a 5 Hz scalar PLL (``wide``, the reference, and ``narrow``), 8 runs of a
    2 s static case, and sweep ``cn0`` over 15, 30 and 45 dB-Hz with ``threshold`` and the
    further sweep keys ``sweep``."""
    return {
        "name": "tiny-threshold",
        "runs": 8,
        "batch_size": 8,
        "seed": 3,
        "reference": "wide",
        "scenario": {"kind": "tracking-threshold", "duration_s": 2.0, "settle_s": 0.5},
        "cases": [{"name": "static", "cn0_dbhz": 30.0}],
        "candidates": [
            {"name": "wide", "channel_filter": {"name": "scalar", "params": {"pll_bandwidth_hz": 18.0}}},
            {"name": "narrow", "channel_filter": {"name": "scalar", "params": {"pll_bandwidth_hz": 5.0}}},
        ],
        "sweeps": [
            {"name": "cn0", "path": "cases.cn0_dbhz", "values": [15.0, 30.0, 45.0], "threshold": threshold, **sweep}
        ],
    }


def constructed(
    *, threshold: dict[str, Any] | None, cases: list[dict[str, Any]] | None = None, claims=(), **sweep: Any
) -> dict[str, Any]:
    """Candidates ``a`` (scalar, the reference) and ``b`` (the Kalman carrier loop), 40 runs,
    ``cases`` (default one, ``c``), and sweep ``cn0`` over 20-35 dB-Hz with ``threshold``
    (None: none) and the further sweep keys ``sweep``."""
    spec = {"name": "cn0", "path": "cases.cn0_dbhz", "values": [20.0, 25.0, 30.0, 35.0], **sweep}
    if threshold is not None:
        spec["threshold"] = threshold
    return {
        "name": "t",
        "runs": 40,
        "batch_size": 40,
        "seed": 4,
        "reference": "a",
        "scenario": {"kind": "tracking-threshold", "duration_s": 3.0},
        "cases": cases or [{"name": "c", "cn0_dbhz": 30.0}],
        "candidates": [
            {"name": "a", "channel_filter": "scalar"},
            {"name": "b", "channel_filter": "kf-carrier-loop"},
        ],
        "sweeps": [spec],
        "claims": list(claims),
    }


class OutcomeStore:
    """A result store holding given per-run outcomes, what `threshold_rows` and the claims
    read: ``outcomes[candidate][value]`` ``(runs,)`` for sweep 0 of ``config``, the same in
    every case; `CaseOutcomeStore` by case."""

    def __init__(self, config, outcomes):
        self.by_key = {point.identity(): value for value, point in config.sweep_points(0)}
        self.outcomes = outcomes

    def run_values(self, key, case, candidate, metric, runs):
        v = self._outcomes(case)[candidate][self.by_key[key]]
        return {r: float(v[r]) for r in range(runs)}

    def _outcomes(self, case):
        return self.outcomes


class CaseOutcomeStore(OutcomeStore):
    """`OutcomeStore` with ``outcomes[case][candidate][value]``."""

    def _outcomes(self, case):
        return self.outcomes[case]
