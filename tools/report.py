# SPDX-License-Identifier: GPL-3.0-or-later
"""The verification report: PNG images, inline SVG polar plots of the lobes,
``report.html`` and ``report.json``.

PNGs are written with OpenImageIO (Blender's bundled copy is on ``sys.path``
once ``tools.bpy_env.prepare()`` ran); linear radiance is sRGB-encoded for
display.  The polar plots are computed here from ``addon.reference`` and
drawn as SVG: no matplotlib.
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np

from test_scenes import common

DEG = math.pi / 180.0


# --------------------------------------------------------------------------
# images

# One PNG writer for the project, beside read_exr in test_scenes.common.
srgb_encode = common.srgb_encode
write_png = common.write_png


def display_pair(rendered, expected, mask=None):
    """Render and reference scaled by the same exposure (the reference's
    99.5th percentile maps to 1) for display."""
    e = np.asarray(expected, dtype=np.float64)
    vals = e[mask] if mask is not None and np.any(mask) else e.reshape(-1, 3)
    peak = float(np.percentile(vals, 99.5)) if vals.size else 1.0
    scale = 1.0 / peak if peak > 0 else 1.0
    return np.asarray(rendered) * scale, e * scale


_HEAT = np.array([  # log10 error -7 .. 0: dark blue, blue, cyan, green, yellow, orange, red, white
    [0.05, 0.05, 0.25], [0.1, 0.2, 0.7], [0.0, 0.6, 0.8], [0.1, 0.75, 0.3],
    [0.9, 0.85, 0.1], [0.95, 0.5, 0.05], [0.85, 0.05, 0.05], [1.0, 1.0, 1.0]])
HEAT_RANGE = (-7.0, 0.0)


def heat_map(rel_error, mask):
    """Display-ready RGB of log10 relative error over HEAT_RANGE; pixels
    outside ``mask`` are mid grey."""
    lo, hi = HEAT_RANGE
    t = (np.log10(np.maximum(rel_error, 1e-30)) - lo) / (hi - lo)
    t = np.clip(t, 0.0, 1.0) * (len(_HEAT) - 1)
    i = np.minimum(t.astype(int), len(_HEAT) - 2)
    f = (t - i)[..., None]
    rgb = _HEAT[i] * (1 - f) + _HEAT[i + 1] * f
    return np.where(np.asarray(mask)[..., None], rgb, 0.35)


def heat_legend_svg(width=300, height=14):
    lo, hi = HEAT_RANGE
    stops = "".join(
        f'<stop offset="{k / (len(_HEAT) - 1):.3f}" stop-color="rgb({int(c[0] * 255)},'
        f'{int(c[1] * 255)},{int(c[2] * 255)})"/>' for k, c in enumerate(_HEAT))
    ticks = "".join(
        f'<text x="{(e - lo) / (hi - lo) * width:.1f}" y="{height + 12}" font-size="10" '
        f'text-anchor="middle">1e{e:d}</text>' for e in range(int(lo), int(hi) + 1))
    return (f'<svg width="{width + 20}" height="{height + 16}" viewBox="-10 0 {width + 20} '
            f'{height + 16}"><defs><linearGradient id="heat">{stops}</linearGradient></defs>'
            f'<rect width="{width}" height="{height}" fill="url(#heat)"/>{ticks}</svg>')


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


_CURVE_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd")


def polar_svg(model, params, title, incidence_deg=(30.0, 60.0), size=220):
    """An inline SVG: each curve is the lobe (mean of RGB) scaled to its own
    maximum; the dashed line is the light's direction."""
    r0 = size * 0.42
    cx, cy = size / 2.0, size * 0.55
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size * 0.68:.0f}" '
             f'viewBox="0 0 {size} {size * 0.68:.0f}" font-family="sans-serif">']
    for frac in (0.5, 1.0):
        r = r0 * frac
        parts.append(f'<path d="M {cx - r:.1f} {cy:.1f} A {r:.1f} {r:.1f} 0 0 1 {cx + r:.1f} '
                     f'{cy:.1f}" fill="none" stroke="#ccc"/>')
    parts.append(f'<line x1="{cx - r0:.1f}" y1="{cy:.1f}" x2="{cx + r0:.1f}" y2="{cy:.1f}" '
                 f'stroke="#888"/>')
    parts.append(f'<line x1="{cx:.1f}" y1="{cy:.1f}" x2="{cx:.1f}" y2="{cy - r0:.1f}" '
                 f'stroke="#ccc"/>')
    for k, (ti, th, v) in enumerate(lobe_curves(model, params, incidence_deg)):
        col = _CURVE_COLOURS[k % len(_CURVE_COLOURS)]
        g = v.mean(axis=-1)
        peak = float(g.max())
        if peak <= 0:
            continue
        rr = g / peak * r0
        pts = " ".join(f"{cx + r * math.sin(t):.1f},{cy - r * math.cos(t):.1f}"
                       for r, t in zip(rr, th))
        parts.append(f'<polyline points="{pts}" fill="none" stroke="{col}" stroke-width="1.6"/>')
        a = -ti * DEG
        parts.append(f'<line x1="{cx:.1f}" y1="{cy:.1f}" x2="{cx + r0 * math.sin(a):.1f}" '
                     f'y2="{cy - r0 * math.cos(a):.1f}" stroke="{col}" stroke-dasharray="4 3"/>')
        parts.append(f'<text x="4" y="{14 + 13 * k}" font-size="11" fill="{col}">'
                     f'θi = {ti:g}°</text>')
    parts.append(f'<text x="{size - 4}" y="14" font-size="11" text-anchor="end">'
                 f'{html.escape(title)}</text>')
    parts.append("</svg>")
    return "".join(parts)


# --------------------------------------------------------------------------
# tables, JSON and HTML

def fmt(x, spec=".2e"):
    if x is None:
        return "—"
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    return format(x, spec)


def verdict(p):
    return {True: "pass", False: "FAIL", None: "measured"}[p]


def summary_table(entries):
    """A plain-text table of report entries (dicts without images)."""
    lines = [f"{'model':18s} {'variant':52s} {'mode':11s} {'status':7s} {'max rel':>9s} "
             f"{'rms rel':>9s} {'|d|/peak':>9s} {'tol':>8s}  result"]
    for e in entries:
        if e["mode"] == "furnace":
            err, rms = f"A={e['max_albedo']:.3f}", ""
        else:
            err, rms = fmt(e["max_rel_error"]), fmt(e["rms_rel_error"])
        peak = fmt(e["max_abs_over_peak"]) if "max_abs_over_peak" in e else ""
        lines.append(f"{e['model']:18.18s} {e['variant']:52.52s} {e['mode']:11s} "
                     f"{e.get('status', ''):7s} {err:>9s} {rms:>9s} {peak:>9s} "
                     f"{fmt(e['tolerance'], '.0e') if e['mode'] != 'furnace' else fmt(e['tolerance'], '.3f'):>8s}"
                     f"  {verdict(e['pass'])}")
    return "\n".join(lines)


def write_json(path, entries):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(entries, indent=1, allow_nan=True) + "\n")
    return path


_CSS = """
body{font-family:sans-serif;max-width:1200px;margin:1em auto;color:#222}
table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #ddd;padding:2px 6px}
th{background:#f4f4f4}.pass{color:#080}.FAIL{color:#c00;font-weight:bold}.measured{color:#666}
img.px{image-rendering:pixelated;width:192px;border:1px solid #ccc}
.case{display:inline-block;vertical-align:top;margin:6px;padding:6px;border:1px solid #eee}
.case h4{margin:2px 0;font-size:13px}.small{font-size:12px;color:#555}
"""


def write_html(path, *, entries, case_images, gallery_png, gallery_labels, polar_plots, meta):
    """``case_images``: list of (entry, [(render_png, reference_png, heat_png,
    light_dir, max_rel)]) relative paths; ``polar_plots``: list of SVG
    strings."""
    h = ["<!doctype html><html><head><meta charset='utf-8'>",
         "<title>Reflection Models: verification report</title>",
         f"<style>{_CSS}</style></head><body>",
         "<h1>Reflection Models: verification report</h1>",
         f"<p class='small'>{html.escape(meta)}</p>"]
    if gallery_png:
        h.append("<h2>Gallery (path-traced BSDF outputs)</h2>")
        h.append(f"<img src='{gallery_png}' style='max-width:100%'>")
        h.append("<p class='small'>Left to right: " + ", ".join(map(html.escape, gallery_labels))
                 + "</p>")
    h.append("<h2>Summary</h2><table><tr><th>model</th><th>variant</th><th>mode</th>"
             "<th>path-traced status</th><th>max rel error</th><th>rms rel error</th>"
             "<th>max |Δ| / peak</th><th>tolerance</th><th>result</th></tr>")
    for e in entries:
        if e["mode"] == "furnace":
            err = f"max albedo {e['max_albedo']:.4f}"
            rms = f"margin {e['margin']:.1e}"
            tol = f"≤ {e['tolerance']:.4f}"
        else:
            err, rms, tol = fmt(e["max_rel_error"]), fmt(e["rms_rel_error"]), fmt(e["tolerance"], ".0e")
        v = verdict(e["pass"])
        peak = fmt(e["max_abs_over_peak"]) if "max_abs_over_peak" in e else ""
        h.append(f"<tr><td>{html.escape(e['model'])}</td><td>{html.escape(e['variant'])}</td>"
                 f"<td>{e['mode']}</td><td>{e.get('status', '')}</td><td>{err}</td><td>{rms}</td>"
                 f"<td>{peak}</td><td>{tol}</td><td class='{v}'>{v}</td></tr>")
    h.append("</table>")
    h.append("<h2>Lobes in the plane of incidence (addon.reference)</h2>")
    h.append("<p class='small'>Radiance f·cos θi toward θo, each curve scaled to its maximum; "
             "dashed: the light.</p>")
    h.extend(polar_plots)
    h.append("<h2>Renders, references and error maps</h2>")
    h.append("<p class='small'>Each cell: render | reference (same exposure) | relative error "
             "(log scale below; grey: not measured — off the tiles, edges, shadows).</p>")
    h.append(heat_legend_svg())
    for entry, imgs in case_images:
        v = verdict(entry["pass"])
        h.append(f"<div class='case'><h4>{html.escape(entry['model'])} "
                 f"[{html.escape(entry['variant'])}] — {entry['mode']} "
                 f"<span class='{v}'>{v}</span></h4>")
        for render_png, ref_png, heat_png, ld, mx in imgs:
            h.append(f"<div class='small'>light ({ld[0]:.2f}, {ld[1]:.2f}, {ld[2]:.2f}): "
                     f"max rel {mx:.2e}</div>")
            h.append(f"<img class='px' src='{render_png}'><img class='px' src='{ref_png}'>"
                     f"<img class='px' src='{heat_png}'><br>")
        h.append("</div>")
    h.append("</body></html>")
    path = Path(path)
    path.write_text("\n".join(h))
    return path
