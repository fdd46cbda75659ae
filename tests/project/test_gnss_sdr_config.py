"""The GNSS-SDR config the benchmarks write (benchmarks/gnss_sdr_config.py): every line a
``Block.key=value`` setting GNSS-SDR reads, each once, with the values asked for."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from gnss_sdr_config import (  # noqa: E402
    ACQUISITION,
    TRACKING,
    WEAK_ACQUISITION,
    WEAK_TRACKING,
    gnss_sdr_config,
    section,
)


def _settings(text: str) -> dict[str, str]:
    lines = text.splitlines()
    assert lines[0] == "[GNSS-SDR]"
    pairs = [line.split("=", 1) for line in lines[1:]]
    assert all(len(p) == 2 and "." in p[0] for p in pairs), "a line that is not Block.key=value"
    keys = [k for k, _ in pairs]
    assert len(keys) == len(set(keys)), "a setting written twice"
    return dict(pairs)


def test_section_writes_each_setting_in_order() -> None:
    assert section("Tracking_1C", {"pll_bw_hz": 30.0, "item_type": "gr_complex"}).splitlines() == [
        "Tracking_1C.pll_bw_hz=30.0",
        "Tracking_1C.item_type=gr_complex",
    ]
    assert section("X", {}) == ""


@pytest.mark.parametrize("item_type,adapter", [("ibyte", "Ibyte_To_Complex"), ("ishort", "Ishort_To_Complex")])
@pytest.mark.parametrize("pvt_models", [False, True])
def test_config_holds_what_was_asked(tmp_path: Path, item_type: str, adapter: str, pvt_models: bool) -> None:
    got = _settings(
        gnss_sdr_config(
            tmp_path / "rec.dat",
            2.6e6,
            tmp_path / "out",
            channels=11,
            item_type=item_type,
            output_rate_ms=1000,
            display_rate_ms=500,
            pvt_models=pvt_models,
        )
    )
    assert got["SignalSource.filename"] == str(tmp_path / "rec.dat")
    assert got["SignalSource.sampling_frequency"] == got["GNSS-SDR.internal_fs_sps"] == "2600000"
    assert got["SignalSource.item_type"] == item_type and got["DataTypeAdapter.implementation"] == adapter
    assert got["Channels_1C.count"] == "11" and got["PVT.output_rate_ms"] == "1000"
    assert got["PVT.output_path"] == str(tmp_path / "out")
    for block, settings in (("Acquisition_1C", ACQUISITION), ("Tracking_1C", TRACKING)):
        assert {k.split(".", 1)[1]: v for k, v in got.items() if k.startswith(block + ".")} == {
            k: str(v) for k, v in settings.items()
        }
    assert ("PVT.trop_model" in got) == pvt_models


def test_unknown_sample_type_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="item_type 'float'"):
        gnss_sdr_config(tmp_path / "rec.dat", 2.6e6, tmp_path, item_type="float")


def test_the_weak_settings_override_the_defaults_and_keep_the_rest(tmp_path: Path) -> None:
    got = _settings(
        gnss_sdr_config(tmp_path / "rec.dat", 2.6e6, tmp_path, acquisition=WEAK_ACQUISITION, tracking=WEAK_TRACKING)
    )
    assert got["Acquisition_1C.coherent_integration_time_ms"] == "10"
    assert got["Acquisition_1C.doppler_max"] == str(ACQUISITION["doppler_max"])  # kept
    assert got["Tracking_1C.pll_bw_hz"] == "15.0" and got["Tracking_1C.extend_correlation_symbols"] == "20"
    assert got["Tracking_1C.implementation"] == TRACKING["implementation"]  # kept
    assert sum(k.startswith("Tracking_1C.") for k in got) == len(TRACKING | WEAK_TRACKING)
