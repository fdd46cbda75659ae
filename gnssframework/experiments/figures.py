"""Grids of labelled panels for the comparison report's figures.

Every panel gets a title, a unit on both axes and, where its values span more than
:data:`LOG_DECADES` decades, a logarithmic value axis (a consistent filter's NEES of 3
beside an overconfident one's 2000 is otherwise a flat line at 0). A figure carries one
legend, below its panels, holding every curve's label once; each candidate keeps its
colour in every panel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

__all__ = ["Curve", "Panel", "panel_grid", "needs_log_scale", "grid_shape", "LOG_DECADES", "BOUND_STYLE"]

#: A value axis spanning more decades than this is drawn on a log scale.
LOG_DECADES = 2.0
#: How a lower bound (e.g. a posterior Cramér-Rao bound) is drawn.
BOUND_STYLE = {"color": "black", "linestyle": "--", "linewidth": 1.0}


@dataclass
class Curve:
    """One line of a panel: ``y`` against ``x``; ``step`` draws a CDF's staircase."""

    label: str
    x: np.ndarray
    y: np.ndarray
    style: dict[str, Any] = field(default_factory=dict)
    step: bool = False


@dataclass
class Panel:
    """One axes of a grid: its title, axis labels (with units) and curves.

    ``values_on`` names the axis holding the data's values (``"y"`` for a time series,
    ``"x"`` for a CDF): that axis turns logarithmic when the values need it. ``note`` is
    written in the panel when there is no curve (e.g. a metric undefined in every run).
    """

    title: str
    xlabel: str
    ylabel: str
    curves: list[Curve]
    values_on: Literal["x", "y"] = "y"
    note: str = ""


def needs_log_scale(values: np.ndarray, decades: float = LOG_DECADES) -> bool:
    """Whether positive ``values`` span more than ``decades`` decades (never for data with
    a negative value, which a log axis cannot show; zeros are left out of the span).

    Examples
    --------
    >>> needs_log_scale(np.array([3.0, 2000.0])), needs_log_scale(np.array([0.5, 4.0]))
    (True, False)
    >>> needs_log_scale(np.array([-1.0, 1e4]))
    False
    """
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0 or np.any(v < 0):
        return False
    v = v[v > 0]
    return bool(v.size > 1 and math.log10(v.max() / v.min()) > decades)


def grid_shape(panels: int, max_columns: int = 3) -> tuple[int, int]:
    """Rows and columns of a grid of ``panels`` panels, at most ``max_columns`` wide.

    Examples
    --------
    >>> grid_shape(10), grid_shape(2), grid_shape(1)
    ((4, 3), (1, 2), (1, 1))
    """
    columns = max(1, min(panels, max_columns))
    return max(1, math.ceil(panels / columns)), columns


def _draw(ax, panel: Panel) -> None:
    values = []
    for c in panel.curves:
        if c.step:
            ax.step(c.x, c.y, where="post", label=c.label, **c.style)
        else:
            ax.plot(c.x, c.y, label=c.label, **c.style)
        values.append(np.asarray(c.x if panel.values_on == "x" else c.y, dtype=float).ravel())
    if values and needs_log_scale(np.concatenate(values)):
        (ax.set_xscale if panel.values_on == "x" else ax.set_yscale)("log")
    if not panel.curves and panel.note:
        ax.text(0.5, 0.5, panel.note, ha="center", va="center", transform=ax.transAxes, fontsize=7, wrap=True)
    ax.set_title(panel.title, fontsize=8)
    ax.set_xlabel(panel.xlabel, fontsize=7)
    ax.set_ylabel(panel.ylabel, fontsize=7)
    ax.tick_params(labelsize=6)
    ax.grid(alpha=0.3, which="both" if ax.get_yscale() == "log" or ax.get_xscale() == "log" else "major")


def panel_grid(panels: list[Panel], title: str, max_columns: int = 3, panel_size_in: tuple[float, float] = (3.4, 2.5)):
    """A matplotlib figure of ``panels`` in a grid, with one legend for the whole figure.

    Returns
    -------
    matplotlib.figure.Figure
        Unused cells of the last row are removed.
    """
    import matplotlib.pyplot as plt

    rows, columns = grid_shape(len(panels), max_columns)
    fig, axes = plt.subplots(
        rows,
        columns,
        figsize=(panel_size_in[0] * columns, panel_size_in[1] * rows + 0.8),
        squeeze=False,
        layout="constrained",
    )
    for ax, panel in zip(axes.flat, panels):
        _draw(ax, panel)
    for ax in list(axes.flat)[len(panels) :]:
        fig.delaxes(ax)
    handles: dict[str, Any] = {}
    for ax in fig.axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, handle)
    fig.suptitle(title, fontsize=9)
    if handles:
        fig.legend(
            list(handles.values()),
            list(handles),
            loc="outside lower center",
            fontsize=7,
            ncol=min(len(handles), 4),
            frameon=False,
        )
    return fig
