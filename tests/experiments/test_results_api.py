"""The comparison from Python: frames and datasets equal to the files (issue 27)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import gnssframework as gf
from gnssframework.experiments.store import ResultStore

CONFIG = """
name = "api"
runs = 3
batch_size = 2
seed = 5
reference = "kf"
[executor]
workers = 1
[scenario]
kind = "multipath"
epochs = 50
[[cases]]
name = "psi-0.5"
psi = 0.5
[[cases]]
name = "psi-0.9"
psi = 0.9
[[candidates]]
name = "kf"
nav_filter = { name = "position-ca" }
estimator = { name = "kf" }
[[candidates]]
name = "ar1"
nav_filter = { name = "position-ca" }
estimator = { name = "kf" }
augmentation = { name = "colored-ar1" }
[[claims]]
candidate = "ar1"
reference = "kf"
metric = "horizontal_error_rmse"
direction = "lower"
"""


@pytest.fixture(scope="module")
def on_disk(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("api")
    (tmp / "c.toml").write_text(CONFIG)
    return tmp, gf.compare(tmp / "c.toml", out=tmp / "out")


@pytest.mark.slow
def test_frames_equal_the_summary(on_disk):
    tmp, res = on_disk
    summary = json.loads((tmp / "out" / "summary.json").read_text())
    assert res.rows.to_dict("records") == summary["rows"]
    assert res.paired.to_dict("records")[0]["diff"] == summary["paired"][0]["diff"]
    assert list(res.claims["outcome"]) == [c["outcome"] for c in summary["claims"]]
    assert set(res.rows.columns) >= {"case", "candidate", "metric", "mean", "std", "runs", "unit"}


@pytest.mark.slow
def test_runs_dataset_holds_the_store_values_with_units(on_disk):
    tmp, res = on_disk
    ds = res.runs
    assert dict(ds.sizes) == {"case": 2, "candidate": 2, "run": 3}
    store = ResultStore(tmp / "out" / "results.sqlite")
    config = gf.experiments.load_config(tmp / "c.toml")
    v = store.values(config.identity(), "psi-0.9", "ar1", "lat_error_rmse", 3)
    np.testing.assert_array_equal(ds["lat_error_rmse"].sel(case="psi-0.9", candidate="ar1").values, v)
    assert ds["lat_error_rmse"].attrs["units"] == "m"
    # the frame's mean is the dataset's mean over runs
    row = res.rows.query("case == 'psi-0.9' and candidate == 'ar1' and metric == 'lat_error_rmse'").iloc[0]
    assert row["mean"] == pytest.approx(float(ds["lat_error_rmse"].sel(case="psi-0.9", candidate="ar1").mean()))


@pytest.mark.slow
def test_series_dataset_has_named_dimensions_and_time(on_disk):
    tmp, res = on_disk
    s = res.series
    assert {"case", "candidate", "epoch", "run"} <= set(s.dims) and "time_s" in s.coords
    assert s.sizes["run"] == 3 and s.sizes["epoch"] == 50
    assert np.all(np.isfinite(s["lat_error_m"].sel(candidate="kf").values))
    # colored-ar1 decorrelates by differencing: its filter has one epoch fewer, NaN on the union axis.
    with np.load(next((tmp / "out" / "raw" / "psi-0.5" / "ar1").glob("run*.npz"))) as npz:
        own = npz["time_s"]
    ar1 = s["lat_error_m"].sel(candidate="ar1", case="psi-0.5")
    assert own.size == 49 and int(np.isfinite(ar1.isel(run=0)).sum()) == own.size
    np.testing.assert_array_equal(s["time_s"].values[np.isfinite(ar1.isel(run=0).values)], own)


@pytest.mark.slow
def test_in_memory_gives_the_same_numbers_and_leaves_no_folder(on_disk, tmp_path):
    _, res = on_disk
    mem = gf.compare(gf.experiments.load_config(on_disk[0] / "c.toml"))
    assert mem.out is None and "in memory" in repr(mem)
    assert mem.rows.equals(res.rows)
    assert "## Claims" in mem.report()
    with pytest.raises(TypeError, match="a TOML path, a ComparisonConfig or a dict"):
        gf.compare(42)


def test_the_notebook_view_is_an_html_table_of_mean_and_se_per_case():
    from gnssframework.experiments.results import ComparisonResult

    rows = [
        {"case": case, "candidate": cand, "metric": "err", "unit": "m", "mean": mean, "std": std, "runs": 4}
        for case, cand, mean, std in (
            ("c1", "kf", 2.5, 5**0.5 / 3**0.5),
            ("c1", "a<b", 1.0, 0.0),
            ("c2", "kf", 3.0, 0.2),
            ("c2", "a<b", None, None),
        )
    ]
    rows[-1]["undefined"] = "static cases only"
    summary = {
        "name": "demo",
        "runs": 4,
        "rows": rows,
        "claims": [{"outcome": "holds", "statement": "a<b: err lower than kf's"}],
    }
    html = ComparisonResult(summary, None, None, "", None)._repr_html_()
    assert html.count("<table>") == 3 and "<caption style='text-align:left'>c1</caption>" in html
    # std sqrt(5/3) over 4 runs: SE 0.645 (not the std 1.29); a run-less spread prints the mean alone
    assert "<td>2.50 ± 0.65</td>" in html and "<td>1</td>" in html and "1.29" not in html
    assert "<td>3.00 ± 0.10</td>" in html and "<td>static cases only</td>" in html
    assert "a&lt;b" in html and "a<b" not in html  # names escaped
    assert "<td>holds</td>" in html and "mean ± SE" in html
