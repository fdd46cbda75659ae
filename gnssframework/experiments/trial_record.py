"""A tuning's trials as a file: written by every tuned comparison, read to skip re-tuning.

A tuned comparison writes ``tuning_trials.json`` into its output folder: the config's
identity and, per tuned candidate, every trial's free-parameter values and objective, in
trial order. Handed back to the same config (``gnssframework compare --trials-from FILE``,
or ``run_comparison(..., trials_from=FILE)``), the record seeds the results store's
``trials`` table before the tuning starts; the tuning then resumes exactly as it would
from its own interrupted store (see `gnssframework.experiments.tuning`): the recorded
trials are not rerun and the best of them selects the same tuned values. So a machine can evaluate a comparison at the
values another machine's full tuning selected, and see that tuning's every trial, without
paying for it again (CI checks the tuned reference examples' claims this way).

The record is refused when it belongs to another config (its identity differs: another
scenario, case, candidate, seed or tuning budget), so a stale record cannot select values
for a changed comparison. A change of arithmetic under an unchanged config is not seen by
the identity: ``tests/experiments/test_trial_records.py`` reruns each committed record's
best trials and compares their objectives.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..errors import ConfigError
from ..io.files import atomic_write_text, dumps_strict, loads_strict

__all__ = ["TRIALS_FILE", "write_trial_record", "seed_trials"]

#: The file a tuned comparison writes into its output folder.
TRIALS_FILE = "tuning_trials.json"


def write_trial_record(path: str | Path, config: Any, tuning: dict[str, dict]) -> None:
    """Write ``tuning``'s trials (the result of `tuning.tune`) for ``config`` to ``path``.

    A failed trial's objective (``inf``) is written as ``null`` (strict JSON) and read
    back as ``inf``.
    """
    head = dumps_strict({"config": config.name, "identity": config.identity()})[:-1]
    blocks = [
        f" {dumps_strict(cand)}: [\n"
        + ",\n".join("  " + dumps_strict({"values": t["values"], "objective": t["objective"]}) for t in res["trials"])
        + "\n ]"
        for cand, res in tuning.items()
    ]
    atomic_write_text(path, head + ', "trials": {\n' + ",\n".join(blocks) + "\n}}\n")  # a trial per line


def seed_trials(path: str | Path, config: Any, store: Any) -> int:
    """Add the trials recorded in ``path`` to ``store`` for ``config``; returns how many.

    Raises
    ------
    ConfigError
        Naming the file, if it is not a trial record, belongs to another config, or names
        a candidate ``config`` does not tune.
    """
    from .tuning import resolve_free

    path = Path(path)
    try:
        record = loads_strict(path.read_text())
        identity, trials = record["identity"], record["trials"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError("trials_from", f"{path}: not a trial record ({exc})") from None
    if identity != config.identity():
        raise ConfigError(
            "trials_from",
            f"{path}: recorded for config {record.get('config')!r} with another "
            f"identity than {config.name!r} (its scenario, cases, candidates, seed or "
            "tuning changed since): rerun the tuning",
        )
    free = resolve_free(config)
    key = config.identity()
    added = 0
    for cand, rows in trials.items():
        if cand not in free:
            raise ConfigError("trials_from", f"{path}: candidate {cand!r} is not tuned by {config.name!r}")
        width = len(free[cand])
        for index, row in enumerate(rows):
            values, objective = row["values"], row["objective"]
            if len(values) != width:
                raise ConfigError(
                    "trials_from",
                    f"{path}: candidate {cand!r}, trial {index}: {len(values)} values for {width} free parameters",
                )
            store.add_trial(key, cand, index, json.dumps(values), math.inf if objective is None else float(objective))
            added += 1
    return added
