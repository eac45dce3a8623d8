# SPDX-License-Identifier: GPL-3.0-or-later
"""The verification report: ``report.html`` and ``report.json``.

Only draws and writes.  The checks (:class:`verification.harness.checks.Check`)
come from the suites; the images are written through the one image module
(:mod:`verification.harness.images`, OpenImageIO), the plots drawn with
matplotlib (:mod:`.plotting`), the page filled from a jinja2 template.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from verification import harness

from . import plotting as P
from .templates import render

DEG = math.pi / 180.0


# --------------------------------------------------------------------------
# images

def display_pair(rendered, expected, mask=None):
    """Render and reference scaled by the same exposure (the reference's
    99.5th percentile maps to 1) for display."""
    e = np.asarray(expected, dtype=np.float64)
    vals = e[mask] if mask is not None and np.any(mask) else e.reshape(-1, 3)
    peak = float(np.percentile(vals, 99.5)) if vals.size else 1.0
    scale = 1.0 / peak if peak > 0 else 1.0
    return np.asarray(rendered) * scale, e * scale


HEAT_RANGE = (-7.0, 0.0)  # log10 of the relative error


def heat_map(rel_error, mask):
    """Display-ready RGB of log10 relative error over HEAT_RANGE through
    matplotlib's ``inferno`` colour map; pixels outside ``mask`` are mid grey."""
    from matplotlib import colormaps

    lo, hi = HEAT_RANGE
    t = np.clip((np.log10(np.maximum(rel_error, 1e-30)) - lo) / (hi - lo), 0.0, 1.0)
    rgb = colormaps["inferno"](t)[..., :3]
    return np.where(np.asarray(mask)[..., None], rgb, 0.35)


def heat_legend_svg():
    fig, ax = P.figure(3.6, 0.55)
    ax.imshow(np.linspace(0, 1, 256)[None, :], aspect="auto", cmap="inferno",
              extent=(HEAT_RANGE[0], HEAT_RANGE[1], 0, 1))
    ax.set_yticks([])
    ax.set_xticks(range(int(HEAT_RANGE[0]), int(HEAT_RANGE[1]) + 1))
    ax.set_xticklabels([f"1e{e}" for e in range(int(HEAT_RANGE[0]), int(HEAT_RANGE[1]) + 1)])
    ax.grid(False)
    ax.set_title("relative error", fontsize=8)
    return P.to_svg(fig)


def _slug(text):
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_")


def write_case_images(check, img_dir, rel_to):
    """PNGs of a gonio or oracle check (render, reference, error map per
    light); returns rows ``(render, reference, error, light_dir, max_rel)``
    of paths relative to ``rel_to``."""
    rows = []
    base = _slug(check.name)
    for j, p in enumerate(check.images.get("lights", [])):
        if "expected" not in p:
            continue
        shown, ref = display_pair(p["rendered"], p["expected"], p["mask"])
        names = [img_dir / f"{base}_{j}_{kind}.png" for kind in ("render", "reference", "error")]
        harness.write_png(names[0], shown)
        harness.write_png(names[1], ref)
        harness.write_png(names[2], heat_map(p["rel_error"], p["mask"]), srgb=False)
        rows.append((*(str(n.relative_to(rel_to)) for n in names), p["light_dir"],
                     p["max_rel_error"]))
    return rows


# --------------------------------------------------------------------------
# polar plots of the lobes in the plane of incidence

def lobe_curves(model, params, incidence_deg=(30.0, 60.0), n=181):
    """For each incidence angle, the reflected radiance ``shade(wi, wo)`` for
    ``wo`` sweeping the plane of incidence (x-z, tangent along x) from -90 to
    90 degrees; returns ``[(theta_i, theta_o array, values (n, 3))]``."""
    from addon import reference

    th = np.linspace(-89.5, 89.5, n) * DEG
    wo = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    out = []
    for ti in incidence_deg:
        a = -ti * DEG  # the light on the negative-x side: the mirror lobe at +theta
        wi = np.array([math.sin(a), 0.0, math.cos(a)])
        v = reference.shade(model, np.broadcast_to(wi, wo.shape), wo, normal=(0, 0, 1),
                            tangent=(1, 0, 0), **params)
        out.append((ti, th, np.asarray(v)))
    return out


def polar_svg(model, params, title, incidence_deg=(30.0, 60.0)):
    """The lobe (mean of RGB, each curve scaled to its own maximum) on a polar
    half-plane; dashed: the light's direction."""
    fig = P.plt.figure(figsize=(2.7, 1.75))
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.set_thetamin(-90)
    ax.set_thetamax(90)
    ax.set_rticks([0.5, 1.0])
    ax.set_yticklabels([])
    ax.set_xticks(np.radians([-90, -45, 0, 45, 90]))
    ax.tick_params(labelsize=6)
    for k, (ti, th, v) in enumerate(lobe_curves(model, params, incidence_deg)):
        g = v.mean(axis=-1)
        peak = float(g.max())
        if peak <= 0:
            continue
        ax.plot(th, g / peak, color=P.COLORS[k], lw=1.3, label=f"θi = {ti:g}°")
        ax.plot([-ti * DEG, -ti * DEG], [0, 1], color=P.COLORS[k], ls="--", lw=0.8)
    ax.set_title(title, fontsize=8)
    ax.legend(loc="lower left", fontsize=6, bbox_to_anchor=(-0.1, -0.12))
    return P.to_svg(fig)


# --------------------------------------------------------------------------
# tables, JSON and HTML

def fmt(x, spec=".2e"):
    """``x`` formatted (``spec``; "tol": a tolerance, at most two significant
    digits, so 0.025 is not shown as 3e-02)."""
    if x is None:
        return "—"
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    if spec == "tol":
        m, e = f"{x:.1e}".split("e")
        return f"{m.rstrip('0').rstrip('.')}e{e}"
    return format(x, spec)


def summary_table(checks):
    """A plain-text table of the gonio, oracle and furnace checks."""
    lines = [f"{'model':18s} {'variant':46s} {'backend':7s} {'mode':11s} {'status':7s} "
             f"{'max rel':>9s} {'rms rel':>9s} {'|d|/peak':>9s} {'tol':>8s}  result"]
    for c in checks:
        v = c.values
        if v["mode"] == "furnace":
            err, rms, tol = f"A={v['max_albedo']:.3f}", "", fmt(v["tolerance"], ".3f")
        else:
            err, rms, tol = fmt(v["max_rel_error"]), fmt(v["rms_rel_error"]), \
                fmt(v["tolerance"], "tol")
        peak = fmt(v["max_abs_over_peak"]) if "max_abs_over_peak" in v else ""
        lines.append(f"{v['model']:18.18s} {v['variant']:46.46s} {v.get('backend', 'osl'):7s} "
                     f"{v['mode']:11s} "
                     f"{v.get('status', ''):7s} {err:>9s} {rms:>9s} {peak:>9s} {tol:>8s}  "
                     f"{c.verdict}")
    return "\n".join(lines)


def checks_table_html(checks):
    """A plain HTML table of checks: name, measured, expected, result."""
    from html import escape
    rows = ["<table><tr><th>check</th><th>measured</th><th>expected</th><th>result</th></tr>"]
    for c in checks:
        rows.append(f"<tr><td>{escape(c.name)}</td><td>{escape(c.measured)}</td>"
                    f"<td>{escape(c.expected)}</td><td class=\"{c.verdict}\">{c.verdict}</td></tr>")
    rows.append("</table>")
    return "\n".join(rows)


def fits_table_html():
    """The fitted mixtures as the fitter measured them (from the data), and
    where each is fitted width by width."""
    from html import escape

    from .docs import _dense

    from addon.core.formulas import mixtures, models
    rows = ["<table><tr><th>fit</th><th>members</th><th>max |Δ|/peak, views and lights "
            "≤ 70°</th><th>≤ 85°</th><th>albedo Δ, views ≤ 70°</th><th>≤ 85°</th>"
            "<th>beyond α 1</th><th>status</th></tr>"]
    for key, d in mixtures.FITS.items():
        m = d["measured"]
        status = models.fit_status(key)
        beyond = f"{m['beyond_70']:.3f}" if m["beyond_70"] else "—"
        members = mixtures.members_text(key)
        rows.append(f"<tr><td>{escape(key)}</td><td>{escape(members)}</td>"
                    f"<td class=\"num\">{mixtures.worst_text(key)}{escape(_dense(key))}</td>"
                    f"<td class=\"num\">{m['max_abs_over_peak_85']:.3f}</td>"
                    f"<td class=\"num\">{m['albedo_difference_70']:.3f}</td>"
                    f"<td class=\"num\">{m['albedo_difference_85']:.3f}</td>"
                    f"<td class=\"num\">{beyond}</td><td>{status}</td></tr>")
    words = mixtures.toon_band_words()
    band_words = words and f"; {words}"
    t = mixtures.toon_measured()
    rows.append("<tr><td>phong, native nodes in Cycles (EEVEE: the row above)</td>"
                f"<td>glossy_toon, glossy_toon, glossy_toon, diffuse (fitting/toon.py"
                f"{band_words})</td>"
                f"<td class=\"num\">{t['max_abs_over_peak_70']:.3f}</td>"
                f"<td class=\"num\">{t['max_abs_over_peak_85']:.3f}</td>"
                f"<td class=\"num\">{t['albedo_difference_70']:.3f}</td>"
                f"<td class=\"num\">{t['albedo_difference_85']:.3f}</td>"
                "<td class=\"num\">—</td><td>approx</td></tr>")
    rows.append("</table>")
    return "\n".join(rows) + "\n" + fitted_widths_html()


def fitted_widths_html():
    """Where each microfacet mixture is fitted, width by width, without and
    with Fresnel (addon/core/fits/bounds.py), as the README's second table."""
    from html import escape

    from addon.core.fits import bounds
    from addon.core.formulas import mixtures, models

    from .docs import FRESNEL_WIDE_END
    lo, hi = bounds.DIELECTRIC_RANGE
    rows = ["<p>Width by width, without and with the model's Fresnel: the widths where the "
            "interval of width nodes around them measured within "
            f"{models.FIT_BOUND:g} of the peak (<code>fitting/bounds.py</code>: both nodes and "
            f"every eighth between, views every {bounds.VIEW_STEP_DEG:g}°, lights up to 70° and "
            "on that edge; the Fresnel columns with the worst index of a grid over the class, "
            "per colour channel). "
            "There the BSDF output is fitted, elsewhere approx.  "
            f"With Fresnel, {FRESNEL_WIDE_END}.</p>",
            "<table><tr><th>variant</th><th>without Fresnel</th>"
            f"<th>dielectric, n from {lo:g} to {hi:g}</th>"
            f"<th>conductor, k ≥ {bounds.CONDUCTOR_K_MIN:g}</th></tr>"]
    for key, cells in mixtures.fitted_widths_rows()[0]:
        rows.append(f"<tr><td>{escape(key)}</td>"
                    + "".join(f"<td>{escape(c)}</td>" for c in cells) + "</tr>")
    rows.append("</table>")
    return "\n".join(rows)


def write_json(path, checks):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps([c.summary() for c in checks], indent=1, allow_nan=True) + "\n")
    return path


def write_html(path, *, checks, case_images, gallery, polar_plots, anisotropy, meta,
               sections=()):
    """``checks``: the gonio, oracle and furnace checks (the summary table);
    ``case_images``: ``[(check, rows)]`` from :func:`write_case_images`;
    ``gallery``: ``(png, labels)`` or None; ``polar_plots``: SVG strings;
    ``anisotropy``: ``[(check, [png paths])]`` relative to the page;
    ``sections``: further ``(id, title, html)`` blocks (measured tables)."""
    page = render("report.html", checks=checks, case_images=case_images, gallery=gallery,
                  polar_plots=polar_plots, anisotropy=anisotropy, meta=meta,
                  heat_legend=heat_legend_svg(), sections=sections, fmt=fmt)
    path = Path(path)
    path.write_text(page, encoding="utf-8")
    return path
