# SPDX-License-Identifier: GPL-3.0-or-later
"""The lecture companion page: each figure of
:mod:`verification.suites.lecture` drawn with matplotlib, its caption, the
slide it reproduces and its check (``out/lecture.html``).

Only draws and writes: the numbers and verdicts come from the suite.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from verification.experiments import lecture as X

from . import plotting as P
from .templates import render

DEG = math.pi / 180.0


def draw_phong(d):
    fig, ax = P.figure(5.2, 3.2)
    a = np.linspace(-90, 90, 181) * DEG
    for r in (0.25, 0.5, 0.75, 1.0):
        ax.plot(r * np.sin(a), r * np.cos(a), color="#ddd", lw=0.8)
    ti = X.PHONG_THETA_I
    ax.plot([-1.05 * math.sin(ti), 0], [1.05 * math.cos(ti), 0], color="#e0a000", lw=1.2,
            label="light L")
    ax.plot([0, 1.05 * math.sin(ti)], [0, 1.05 * math.cos(ti)], color="#888", ls="--", lw=1.2,
            label="mirror R(L)")
    for k, (s, f) in enumerate(d["curves"].items()):
        tr, ff = P.thin(d["theta_r"], f, max_points=2000)
        ax.plot(ff * np.sin(tr), ff * np.cos(tr), color=P.COLORS[k], label=f"s = {s}")
    ax.set_aspect("equal")
    ax.set_xlim(-1.05, 1.05)
    ax.set_ylim(0, 1.08)
    ax.set_title("Phong lobes (E.R(L))^s, θi = 30°")
    ax.legend(loc="upper left")
    return P.to_svg(fig)


def draw_energy(d):
    fig, ax = P.figure(5.2, 3.4)
    s = np.logspace(math.log10(0.5), 3, 200)
    ax.loglog(s, 2 * math.pi / (s + 1), "k--", lw=1, label="bound 2π/(s+1)")
    ax.axhline(1.0, color="k", ls=":", lw=1)
    for k, t in enumerate(d["views_deg"]):
        ax.loglog(d["exponents"], d["rho"][("energy", t)], color=P.COLORS[k],
                  label=f"normalised, θo = {t}°")
        ax.loglog(d["exponents"], d["rho"][("none", t)], color=P.COLORS[k], ls="--", marker=".",
                  lw=1)
    ax.set_xlabel("exponent s")
    ax.set_ylabel("albedo ρ(θo)")
    ax.set_ylim(1e-3, 3)
    ax.set_title("Phong directional albedo (dashed: unnormalised)")
    ax.legend(loc="lower left")
    return P.to_svg(fig)


def draw_distributions(d):
    fig, ax = P.figure(5.2, 3.3)
    for k, (name, r) in enumerate(d["ratios"].items()):
        ax.semilogy(d["alpha"] / DEG, r, color=P.COLORS[k], label=name)
    ax.axhline(0.5, color="#888", lw=0.8)
    ax.axvline(d["beta"] / DEG, color="#888", lw=0.8)
    ax.axvline(3 * d["beta"] / DEG, color="#bbb", lw=0.8)
    ax.set_ylim(1e-6, 1.2)
    ax.set_xlim(0, 60)
    ax.set_xlabel("facet tilt α (°)")
    ax.set_ylabel("D(α)/D(0)")
    ax.set_title(f"D(α)/D(0) at equal β = {d['beta'] / DEG:g}°")
    ax.legend()
    return P.to_svg(fig)


def draw_smith(d):
    fig, ax = P.figure(5.2, 3.3)
    for k, (m, (s, s67)) in enumerate(d["S"].items()):
        ax.plot(d["theta"] / DEG, s, color=P.COLORS[k], label=f"m = {m}")
        ax.plot(d["theta"] / DEG, s67, color=P.COLORS[k], ls="--", lw=1)
    ax.set_xlim(0, 90)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("θ (°)")
    ax.set_ylabel("S(θ)")
    ax.set_title("Smith's S(θ) = G1, Beckmann (dashed: the 1967 bracket form)")
    ax.legend(loc="lower left")
    svg = P.to_svg(fig)
    header = "".join(f"<th>{t}°</th>" for t in d["thetas_deg"])
    rows = "".join(f"<tr><td>{label}</td>" + "".join(f"<td>{r:.5f}</td>" for r in ratios)
                   + "</tr>" for label, ratios in d["table"])
    table = ("<table class='data'><caption>∫ G1(ω) max(0, ω·m) D(m) dm / cos θ (1 = "
             f"self-consistent)</caption><tr><th>case \\ θ</th>{header}</tr>{rows}</table>")
    return svg + table


def draw_torrance_sparrow(d):
    fig, axes = P.figure(9.6, 3.3, ncols=2)
    for ax, name in zip(axes, X.TS_MATERIALS):
        for k, ti in enumerate(X.TS_INCIDENCES_DEG):
            ax.plot(d["theta_r"] / DEG, d["curves"][(name, ti)], color=P.COLORS[k % 10],
                    label=f"{ti}°")
            p = d["peaks_deg"][(name, ti)][1]
            ax.plot([p], [float(np.interp(p * DEG, d["theta_r"], d["curves"][(name, ti)]))], "o",
                    color=P.COLORS[k % 10], ms=3)
        ax.set_xlim(-90, 90)
        ax.set_ylim(0, 2.5)
        ax.set_xlabel("θr (°)")
        ax.set_title(f"{name}: f_r cos θr / its value at the mirror")
    axes[0].legend(ncol=3, loc="upper left")
    svg = P.to_svg(fig)
    mats = list(X.TS_MATERIALS)
    rows = "".join(
        f"<tr><td>{ti}°</td>" + "".join(f"<td>{d['peaks_deg'][(m, ti)][j]:.2f}</td>"
                                        for m in mats for j in (1, 0)) + "</tr>"
        for ti in X.TS_INCIDENCES_DEG)
    table = ("<table class='data'><caption>Peak position θr (°; mirror = θi)</caption><tr>"
             "<th>θi</th><th>Al: f cos</th><th>Al: f_r</th><th>MgO: f cos</th><th>MgO: f_r</th>"
             f"</tr>{rows}</table>")
    return svg + table


def draw_torrance_sparrow_render(d):
    fig, ax = P.figure(5.2, 3.3)
    every = max(1, len(d["theta_r_deg"]) // 60)
    for k, name in enumerate(X.TS_MATERIALS):
        ax.plot(d["dense_deg"], d["dense_reference"][name], color=P.COLORS[k],
                label=f"{name}, reference")
        ax.plot(d["theta_r_deg"][::every], d["rendered"][name][::every], "o", mfc="none",
                color=P.COLORS[k], ms=4, label=f"{name}, render")
    ax.axvline(d["theta_i_deg"], color="#444", lw=0.8)
    ax.set_xlim(60, 90)
    ax.set_xlabel("θr (°)")
    ax.set_ylabel("f_r cos θr (1/sr)")
    ax.set_title(f"Rendered (exact mode) vs reference, θi = {d['theta_i_deg']:g}°")
    ax.legend(loc="upper left")
    return P.to_svg(fig)


def draw_vgroove(d):
    fig, ax = P.figure(5.2, 3.3)
    for k, (ti, (gv, gs)) in enumerate(d["curves"].items()):
        ax.plot(d["theta_o"] / DEG, gv, color=P.COLORS[k], label=f"V-groove, θi = {ti}°")
        ax.plot(d["theta_o"] / DEG, gs, color=P.COLORS[k], ls="--", label=f"Smith, θi = {ti}°")
    ax.set_xlim(-90, 90)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("θo (°; negative = toward the light's side)")
    ax.set_ylabel("G")
    ax.set_title(f"Shadowing G in the plane of incidence (Smith: Beckmann m = {d['m']})")
    ax.legend(loc="lower center")
    return P.to_svg(fig)


def draw_glitter(d):
    img, mask = d["image"], d["mask"]
    h, w = img.shape
    fig, ax = P.figure(w / 60 + 0.4, h / 60 + 0.5)
    ax.imshow(np.clip(img / max(float(img.max()), 1e-12), 0, 1) ** (1 / 2.2), cmap="gray",
              interpolation="nearest")
    ax.contour(mask.astype(float), levels=[0.5], colors="#e33", linewidths=0.8)
    ax.set_axis_off()
    ax.grid(False)
    ax.set_title(f"Rendered glitter path ({w}x{h}, 1 spp, exact mode); red: D ≥ D(0)/2",
                 fontsize=8)
    return P.to_svg(fig)


DRAW = {"phong": draw_phong, "energy": draw_energy, "distributions": draw_distributions,
        "smith": draw_smith, "torrance_sparrow": draw_torrance_sparrow,
        "torrance_sparrow_render": draw_torrance_sparrow_render, "vgroove": draw_vgroove,
        "glitter": draw_glitter}


def write(out_dir, results, *, fast=False, seconds=float("nan"), report_section=None):
    """Write ``out_dir/lecture.html`` from ``results`` (the list of
    ``(Figure, data, Check)`` of :func:`verification.suites.lecture.run_all`).
    ``report_section``: (href, label) of the anisotropy section of the main
    report, or None.  Returns the page's path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    sections = []
    for fig, data, check in results:
        svg = DRAW[fig.id](data) if data else ""
        sections.append({"id": fig.id, "title": fig.title, "slide": fig.slide,
                         "caption": fig.caption, "svg": svg, "check": check})
    page = render("lecture.html", sections=sections,
                  n_pass=sum(c.passed is True for _f, _d, c in results), n=len(results),
                  seconds=seconds, fast=fast,
                  rendered_left_out=not any(f.renders for f, _d, _c in results),
                  report_section=report_section)
    path = out_dir / "lecture.html"
    tmp = out_dir / "lecture.html.tmp"
    tmp.write_text(page, encoding="utf-8")
    os.replace(tmp, path)
    return path
