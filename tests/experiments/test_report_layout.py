"""The comparison report's layout: sections apart, tuning plots readable (issue 37)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

from gnssframework.experiments.report import join_sections, parameter_axis_label, tuning_figure  # noqa: E402


def test_a_heading_after_a_table_gets_a_blank_line():
    text = join_sections(
        ["| a |\n| --- |\n| 1 |\n", "\n".join(["## Claims", "", "| b |", "| --- |", "| 2 |", ""]), "", "## Tuning\n"]
    )
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("#") and i > 0:
            assert lines[i - 1] == "", (i, lines[i - 1])
    assert text.endswith("| 2 |\n\n## Tuning\n") and "\n\n\n" not in text


def test_tuning_axes_carry_units():
    assert parameter_axis_label("channel_filter.pll_bandwidth_hz") == "channel_filter.pll_bandwidth_hz (Hz)"
    assert parameter_axis_label("scenario.settle_s") == "scenario.settle_s (s)"
    assert parameter_axis_label("nav_filter.accel_psd") == "nav_filter.accel_psd (the config's unit)"
    assert parameter_axis_label("channel_filter.q[1]").endswith("(the config's unit)")


def test_the_tuning_plot_labels_lie_inside_the_figure():
    trials = [{"values": [v, w], "objective": 0.1 * v + w} for v, w in ((1.0, 0.2), (5.0, 0.1), (20.0, 0.3))]
    res = {
        "labels": ["channel_filter.pll_bandwidth_hz", "channel_filter.q[1]"],
        "trials": trials,
        "best": {"channel_filter.pll_bandwidth_hz": 5.0, "channel_filter.q[1]": 0.1},
        "best_objective": 0.6,
        "metric": "carrier_freq_error_rmse_long_name",
        "combine": "mean",
    }
    fig = tuning_figure("ackf", res, "Hz")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    for ax in fig.axes:
        assert "(Hz)" in ax.get_ylabel() and "(" in ax.get_xlabel()
        for label in (ax.yaxis.label, ax.xaxis.label):
            ext = label.get_window_extent(renderer)
            assert ext.x0 >= box.x0 - 0.5 and ext.x1 <= box.x1 + 0.5, (label.get_text(), ext, box)
            assert ext.y0 >= box.y0 - 0.5 and ext.y1 <= box.y1 + 0.5, (label.get_text(), ext, box)
    matplotlib.pyplot.close(fig)
