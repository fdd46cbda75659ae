"""The gallery page's code runs as written, in order, and its frames are summary.json's."""

from __future__ import annotations

import pytest
import json
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

import gnssframework as gf  # noqa: E402

PAGE = Path(__file__).resolve().parents[2] / "docs" / "gallery.md"


@pytest.mark.slow
def test_the_gallery_page_runs_and_its_frames_match_the_summary(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)
    assert len(blocks) == 3
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(PAGE), "exec"), namespace)  # noqa: S102 - the page's own code
    plt.close("all")
    res = namespace["res"]
    assert (tmp_path / "gallery-frames.png").stat().st_size > 10_000
    # The frames are the summary's rows, column for column.
    pd.testing.assert_frame_equal(res.rows, pd.DataFrame(res.summary["rows"]))
    table = namespace["table"]
    for row in res.summary["rows"]:
        if row["mean"] is not None:
            assert table.loc[row["metric"], row["candidate"]] == row["mean"]
    # ... and the per-run dataset reduces to them.
    for row in res.summary["rows"]:
        if row["mean"] is not None:
            runs = res.runs[row["metric"]].sel(case=row["case"], candidate=row["candidate"]).values
            assert abs(np.nanmean(runs) - row["mean"]) <= 1e-12 * max(1.0, abs(row["mean"]))
    # Written to a folder, summary.json is the same document.
    out = gf.compare(namespace["config"], out=tmp_path / "folder")
    assert json.loads((tmp_path / "folder" / "summary.json").read_text())["rows"] == res.summary["rows"]
    assert out.rows.equals(res.rows)
