"""The tracking and receive plots: a channel that never locked (its C/N0 estimate is noise,
e.g. -97 dB-Hz) is left out of the C/N0 plots and named, so the locked channels keep their
scale; the prompt I/Q plot says which PRN is which."""

from __future__ import annotations

import matplotlib.figure
import numpy as np
import pytest

from gnssframework.receiver.channels import RECORD_FIELDS, ChannelRecord, TrackingResult
from gnssframework.receiver.channels import report as track_report
from gnssframework.receiver.navigation import report as receive_report
from gnssframework.receiver.navigation.receive import ReceiveResult

LOCKED, NEVER = 3, 7


def _record(prn: int, cn0: float, lock: int) -> ChannelRecord:
    rows = []
    for k in range(50):
        row = dict(
            time_s=k * 0.01,
            cn0_dbhz=cn0 + 0.1 * np.sin(k),
            pli=0.9 * lock,
            doppler_hz=1000.0,
            code_phase_chips=0.0,
            carrier_phase_cycles=10.0 * k,
            lock=lock,
            stage=1,
            prompt_i=100.0 * (-1) ** (k // 20),
            prompt_q=3.0,
            coherent_ms=1,
        )
        rows.append(tuple(row[f] for f in RECORD_FIELDS))
    return ChannelRecord(prn, rows)


@pytest.fixture
def tracking():
    return TrackingResult({LOCKED: _record(LOCKED, 45.0, 1), NEVER: _record(NEVER, -97.0, 0)}, [], 0.5, "scalar")


@pytest.fixture
def figures(monkeypatch):
    """Every figure saved, by file name."""
    saved = {}
    original = matplotlib.figure.Figure.savefig

    def keep(fig, path, *args, **kwargs):
        saved[str(path).rsplit("/", 1)[-1]] = fig
        return original(fig, path, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    return saved


def _assert_only_the_locked_channel(ax):
    lines = ax.get_lines()
    assert len(lines) == 1 and np.min(lines[0].get_ydata()) > 40
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [f"PRN {LOCKED}"]
    assert f"PRN {NEVER}" in ax.get_title()


def test_track_plots_leave_out_a_never_locked_channel_and_label_the_prompts(tracking, figures, tmp_path):
    track_report._plots(tmp_path, tracking)
    _assert_only_the_locked_channel(figures["cn0_lock_doppler.png"].axes[0])
    legend = figures["prompt_iq.png"].axes[0].get_legend()
    assert legend is not None and [t.get_text() for t in legend.get_texts()] == [f"PRN {LOCKED}"]


def test_receive_cn0_plot_leaves_out_a_never_locked_channel(tracking, figures, tmp_path):
    receive_report._cn0_figure(tmp_path / "cn0_lock.png", ReceiveResult(tracking, None, None))
    _assert_only_the_locked_channel(figures["cn0_lock.png"].axes[0])
