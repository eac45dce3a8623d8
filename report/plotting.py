# SPDX-License-Identifier: GPL-3.0-or-later
"""matplotlib for the report: a non-interactive backend, one house style,
figures to inline SVG.  A development dependency: it never ships in the
extension zip."""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf",
          "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22")

plt.rcParams.update({
    "font.family": "sans-serif", "font.size": 9, "axes.titlesize": 10,
    "axes.grid": True, "grid.color": "#e4e4e4", "grid.linewidth": 0.6,
    "axes.spines.top": False, "axes.spines.right": False, "legend.fontsize": 8,
    "legend.frameon": False, "svg.fonttype": "none", "figure.dpi": 100,
    "svg.hashsalt": "reflection-models",  # stable element ids: the same figure, the same text
})


def figure(width=5.2, height=3.3, **kwargs):
    """A new figure and axes (inches)."""
    return plt.subplots(figsize=(width, height), **kwargs)


def to_svg(fig) -> str:
    """The figure as an inline SVG string (closes it)."""
    buf = io.StringIO()
    fig.tight_layout()
    fig.savefig(buf, format="svg", metadata={"Date": None, "Creator": None})
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]


def to_png(fig, path, dpi=110):
    """Write the figure as a PNG file (closes it); returns the path."""
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=dpi)
    plt.close(fig)
    return path


def thin(x, *ys, max_points=800):
    """Every k-th sample so a curve has at most ``max_points`` (keeps SVGs small)."""
    k = max(1, len(x) // max_points)
    return (x[::k],) + tuple(y[::k] for y in ys)
